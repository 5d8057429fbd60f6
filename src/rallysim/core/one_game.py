"""The physics steps of one game of one SIMPLE player with the paper flight, on local numbers.

This is the case of ``gym.make("RallySim/SimpleReturn-v0")``, the single env that third-party
trainers step. ``Game._step_lanes`` runs it on scalar lanes (``rallysim.core.lanes``), where
reading and writing lanes and calling the backend's functions cost several times the arithmetic.
``OneSimpleGame.run`` does the same IEEE-754 operations in the same order on local variables,
for the steps in which the shuttle is in play and stays apart from every box
(``Game._apart``): nearly all of them. A step in which it comes near a box is judged by
``Game._judge`` (the hits, the net, the landing) and a step out of play runs
``Game._step_lanes`` whole, so every rule stays written once; only the motion of a free step
(``SimpleBodies.step_lanes``, ``PaperShuttle.fly``, ``Game._observe`` and ``Game._shape``) is
restated here. ``tests/test_one_game.py`` holds the two paths, and a batch's env 0, bit-identical
state by state.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from rallysim.core.bodies import SimpleBodies
from rallysim.core.lanes import SCALARS
from rallysim.core.shuttle import GRAVITY, PaperShuttle


class OneSimpleGame:
    """The fused physics steps of ``game`` (see the module docstring). It holds only numbers
    read from the game when it is made (so a copy of the game copies it whole), and is made
    once per game: the game's bodies, flight and boxes do not change."""

    @staticmethod
    def fits(game: Any) -> bool:
        """Whether ``game`` is one game of one SIMPLE player with the paper flight."""
        return (game.ops.scalar and type(game.bodies) is SimpleBodies
                and type(game.flight) is PaperShuttle)

    def __init__(self, game: Any) -> None:
        b, flight = game.bodies, game.flight
        self.dt = dt = flight.dt
        self.lo, self.hi = (float(x) for x in b.base_range)
        self.inv_dt = 1.0 / b.dt  # (the lanes code's factors, computed once)
        self.rate = float(b.max_rate)
        self.drive = b.inertia / b.dt
        self.limit = b.limit
        self.face_offset, self.pivot_z = b.face_offset, b.pivot_z
        self.fall = GRAVITY * dt
        self.factor = flight.factor
        self.fwd = float(b.forward.item())  # (fixed: player 0 faces +x)

    def run(self, game: Any, steps: int) -> None:
        """``steps`` physics steps of ``game``, from and to its arrays."""
        state, active = game.state, game._active
        done = 0
        while done < steps:
            if not (state.in_play.item() and active.item()):
                # out of play until the next reset: the rest of the decision on the lanes
                game._run_lanes(steps - done)
                return
            done += self._free_steps(game, steps - done)

    def _free_steps(self, game: Any, steps: int) -> int:
        """Up to ``steps`` steps of a live game, until one needs judging (judged here too);
        the number of steps run."""
        bodies, sh, ev = game.bodies, game.shuttle, game.events
        torque, mocap, theta_a, omega_a = bodies.torque, bodies.mocap, bodies.theta, bodies.omega
        model, data, mj_step = bodies.model, bodies.data, mujoco.mj_step
        sin, cos, apart = np.sin, np.cos, game._apart
        lo, hi, inv_dt, rate, drive = self.lo, self.hi, self.inv_dt, self.rate, self.drive
        limit, fo, pivot_z = self.limit, self.face_offset, self.pivot_z
        dt, fall, f = self.dt, self.fall, self.factor
        shaping = game.shaping
        todo = not game.state.has_hit.item()  # (``_shape``'s todo of a live game)
        fwd, base_step = self.fwd, bodies._base_step.item()
        target, neg_limit = bodies.target.item(), bodies._neg_limit.item()
        torque_limit, base_x = bodies.torque_limit.item(), bodies.base_x.item()
        theta, omega = theta_a.item(), omega_a.item()
        px, py, pz, vx, vy, vz = sh.motion.ravel().tolist()
        qx, qy, qz = game._q[0, 0].tolist()
        shot_time, gap = sh.shot_time.item(), game._gap.item()
        good, bad = ev.approach_good.item(), ev.approach_bad.item()
        face, world = (qx, qy, qz), (px, py, pz)  # the points the box test starts from
        run, judged = 0, False
        while run < steps:
            run += 1
            face0, world0 = face, world
            # SimpleBodies.step_lanes
            theta0 = theta
            x = base_x + base_step
            x = x if x >= lo else lo
            x = x if x <= hi else hi
            moved = x != base_x
            base_x = x
            w = (target - theta) * inv_dt
            w = w if w >= -rate else -rate
            w = w if w <= rate else rate
            w = (w - omega) * drive
            w = w if w >= neg_limit else neg_limit
            torque[0, 0] = w if w <= torque_limit else torque_limit
            mocap[0, 0, 0] = fwd * x
            mj_step(model, data)
            theta, omega = theta_a.item(), omega_a.item()
            if abs(theta) > limit:
                theta = theta if theta >= -limit else -limit
                theta = theta if theta <= limit else limit
                omega = 0.0
                theta_a[0, 0], omega_a[0, 0] = theta, omega
            # PaperShuttle.fly
            vz -= fall
            vx *= f
            vy *= f
            vz *= f
            px += vx * dt
            py += vy * dt
            pz += vz * dt
            shot_time += dt
            # Game._observe and SimpleBodies.face_frame (the game's fwd is the bodies')
            ox = fwd * px
            s, c = float(sin(theta)), float(cos(theta))
            dx = ox - base_x - fo * s
            dz = pz - pivot_z - fo * c
            qx, qy, qz = dx * c - dz * s, fwd * py, dx * s + dz * c
            if shaping:  # Game._shape of a live game
                new_gap = abs(ox - base_x)
                closer = moved & (new_gap < gap) & todo
                good += closer
                bad += todo ^ closer
                gap = new_gap
            face, world = (qx, qy, qz), (px, py, pz)
            if not apart(face0, face, world0, world):
                judged = True
                break
        bodies.base_x[0, 0], bodies._theta0[0, 0], bodies.base_moved[0, 0] = base_x, theta0, moved
        sh.motion[:, 0] = px, py, pz, vx, vy, vz
        game._q[0, 0] = qx, qy, qz
        sh.shot_time[0], game._gap[0, 0] = shot_time, gap
        ev.approach_good[0, 0], ev.approach_bad[0, 0] = good, bad
        if judged:
            g = game._lanes(SCALARS)
            game._judge(g, SCALARS, (face0, world0), True)
            game._store(g)
        return run
