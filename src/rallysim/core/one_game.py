"""The physics steps of one game of one SIMPLE player with the paper flight, on local numbers.

This is the case of ``gym.make("RallySim/SimpleReturn-v0")``, the single env that third-party
trainers step. ``Game._step_lanes`` runs it on scalar lanes (``rallysim.core.lanes``), where
reading and writing lanes and calling the backend's functions cost several times the arithmetic.
``OneSimpleGame.run`` does the same IEEE-754 operations in the same order on local variables,
for the steps in which the shuttle is in play and stays apart from every box
(``Game._apart``): nearly all of them. A step in which it comes near a box is judged by
``Game._judge`` (the hits, the net, the landing) and a step out of play runs
``Game._step_lanes`` whole, so every rule stays written once; only the motion of a free step
(``SimpleBodies.step_lanes``, ``PaperShuttle.fly``, ``Game._observe``, ``Game._shape`` and the
floor, net and face tests of ``Game._apart``) is restated here, once, in ``_free_steps_with``.

That function runs as Python, or compiled by Numba (the ``fast`` extra) where NumPy's float64
sine and cosine give the same bits as the C library's that compiled code calls (NumPy's own
SIMD versions, used on some CPUs, may differ in the last bit): compiled, MuJoCo's ``mj_step``
is called from the loop directly, with no Python between physics steps. ``KERNEL`` (or the
environment variable ``RALLYSIM_KERNEL``: ``auto``, ``python``, ``compiled``) chooses.
``tests/test_one_game.py`` holds both, the lanes code and a batch's env 0 bit-identical state by
state.
"""

from __future__ import annotations

import ctypes
import functools
import glob
import os
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

from rallysim.core import rules
from rallysim.core.bodies import SimpleBodies
from rallysim.core.lanes import SCALARS, _cos, _sin
from rallysim.core.shuttle import GRAVITY, PaperShuttle

KERNELS = ("auto", "python", "compiled")
KERNEL = os.environ.get("RALLYSIM_KERNEL", "auto")  # which ``_free_steps_with`` runs (above)


def _free_steps_with(mj_step: Callable, sin: Callable, cos: Callable, apart: Callable
                     ) -> Callable:
    """The free physics steps of one game, calling these four functions (the Python ones, or
    their compiled counterparts: the source is the same).

    ``free_steps(model, data, <the state's arrays>, k, steps, shaping)`` runs up to ``steps``
    steps from and to the arrays until one needs judging; ``k`` holds ``OneSimpleGame``'s
    constants. Returns the steps run, whether the last needs judging, and the points the box
    test of that step started from (the face's frame, the world)."""

    def free_steps(model, data, torque, mocap, theta_a, omega_a, base_x_a, theta0_a, moved_a,
                   base_step_a, target_a, neg_limit_a, torque_limit_a, motion, q, shot_time_a,
                   gap_a, good_a, bad_a, has_hit_a, k, steps, shaping):
        lo, hi, inv_dt, rate, drive, limit = k[0], k[1], k[2], k[3], k[4], k[5]
        fo, pivot_z, dt, fall, f, fwd, top = k[6], k[7], k[8], k[9], k[10], k[11], k[12]
        net_lo, net_hi = (k[13], k[14], k[15]), (k[16], k[17], k[18])
        face_lo, face_hi = (k[19], k[20], k[21]), (k[22], k[23], k[24])
        todo = not has_hit_a.item()  # (``_shape``'s todo of a live game)
        base_step, target = base_step_a.item(), target_a.item()
        neg_limit, torque_limit = neg_limit_a.item(), torque_limit_a.item()
        base_x, theta, omega = base_x_a.item(), theta_a.item(), omega_a.item()
        px, py, pz = float(motion[0, 0]), float(motion[1, 0]), float(motion[2, 0])
        vx, vy, vz = float(motion[3, 0]), float(motion[4, 0]), float(motion[5, 0])
        qx, qy, qz = float(q[0, 0, 0]), float(q[0, 0, 1]), float(q[0, 0, 2])
        shot_time, gap = shot_time_a.item(), gap_a.item()
        good, bad = good_a.item(), bad_a.item()
        face, world = (qx, qy, qz), (px, py, pz)  # the points the box test starts from
        face0, world0 = face, world
        theta0, moved = theta, False
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
            s, c = sin(theta), cos(theta)
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
            # Game._apart: above the floor, apart from the net and from the face
            if not (world0[2] > top and pz > top and apart(world0, world, net_lo, net_hi)
                    and apart(face0, face, face_lo, face_hi)):
                judged = True
                break
        base_x_a[0, 0], theta0_a[0, 0], moved_a[0, 0] = base_x, theta0, moved
        motion[0, 0], motion[1, 0], motion[2, 0] = px, py, pz
        motion[3, 0], motion[4, 0], motion[5, 0] = vx, vy, vz
        q[0, 0, 0], q[0, 0, 1], q[0, 0, 2] = qx, qy, qz
        shot_time_a[0], gap_a[0, 0] = shot_time, gap
        good_a[0, 0], bad_a[0, 0] = good, bad
        return run, judged, face0, world0

    return free_steps


PYTHON_FREE_STEPS = _free_steps_with(mujoco.mj_step, _sin, _cos, rules.apart)


@functools.cache
def compiled_free_steps() -> Callable | None:
    """``_free_steps_with`` compiled by Numba, calling MuJoCo's C ``mj_step`` (its arguments:
    the model's and data's addresses); None where Numba or MuJoCo's library is missing, or where
    the compiled sine or cosine differ from NumPy's on a probe of angles (then the compiled
    steps would not replay a batch bit for bit)."""
    try:
        import numba
    except ImportError:
        return None
    libraries = glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*"))
    if not libraries:  # (another platform's library name: not compiled there)
        return None
    step = ctypes.CDLL(libraries[0]).mj_step
    step.argtypes, step.restype = [ctypes.c_void_p, ctypes.c_void_p], None
    sin = numba.njit(lambda x: np.sin(x))
    cos = numba.njit(lambda x: np.cos(x))

    @numba.njit
    def sines(angles):
        out = np.empty((2, angles.size))
        for i in range(angles.size):
            out[0, i], out[1, i] = sin(angles[i]), cos(angles[i])
        return out

    # whole turns of the arm, densely, then angles well beyond its stops
    angles = np.concatenate([np.linspace(-4.0, 4.0, 200_001),
                             np.random.default_rng(0).uniform(-40.0, 40.0, 100_000)])
    if sines(angles).tobytes() != np.stack([np.sin(angles), np.cos(angles)]).tobytes():
        return None
    return numba.njit(_free_steps_with(step, sin, cos, numba.njit(rules.apart)))


class OneSimpleGame:
    """The fused physics steps of ``game`` (see the module docstring). It holds only numbers
    read from the game when it is made (so a copy of the game copies it whole), and is made
    once per game: the game's bodies, flight and boxes do not change."""

    @staticmethod
    def fits(game: Any) -> bool:
        """Whether ``game`` is one game of one SIMPLE player with the paper flight."""
        return (game.ops.scalar and type(game.bodies) is SimpleBodies
                and type(game.flight) is PaperShuttle)

    def __init__(self, game: Any, kernel: str | None = None) -> None:
        kernel = KERNEL if kernel is None else kernel
        if kernel not in KERNELS:
            raise ValueError(f"unknown kernel {kernel!r}; valid: {', '.join(map(repr, KERNELS))}")
        if kernel == "compiled" and compiled_free_steps() is None:
            raise RuntimeError("the compiled kernel needs Numba (pip install 'rallysim[fast]') "
                               "and a NumPy whose sine and cosine are the C library's")
        # the kernel's name, not the function: a copy of the game (pickle) takes it along
        self.compiled = kernel != "python" and compiled_free_steps() is not None
        b, flight = game.bodies, game.flight
        dt, (lo, hi) = flight.dt, b.base_range
        net_lo, net_hi = game._net_apart
        face_lo, face_hi = game._face_apart
        # the lanes code's numbers and factors, computed once (``_free_steps_with`` names them)
        self.k = (float(lo), float(hi), 1.0 / b.dt, float(b.max_rate), b.inertia / b.dt,
                  b.limit, b.face_offset, b.pivot_z, dt, GRAVITY * dt, flight.factor,
                  float(b.forward.item()),  # (fixed: player 0 faces +x)
                  game._floor_top, *net_lo, *net_hi, *face_lo, *face_hi)
        self.k_array = np.array(self.k)

    @property
    def kernel(self) -> str:
        return "compiled" if self.compiled else "python"

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
        b, sh, ev = game.bodies, game.shuttle, game.events
        if self.compiled:
            free_steps, k = compiled_free_steps(), self.k_array
            model, data = b.model._address, b.data._address
        else:
            free_steps, k, model, data = PYTHON_FREE_STEPS, self.k, b.model, b.data
        run, judged, face0, world0 = free_steps(
            model, data, b.torque, b.mocap, b.theta, b.omega, b.base_x, b._theta0,
            b.base_moved, b._base_step, b.target, b._neg_limit, b.torque_limit, sh.motion,
            game._q, sh.shot_time, game._gap, ev.approach_good, ev.approach_bad,
            game.state.has_hit, k, steps, game.shaping)
        if judged:
            g = game._lanes(SCALARS)
            game._judge(g, SCALARS, (face0, world0), True)
            game._store(g)
        return run
