"""The fused physics steps of one game of one HUMAN-LIKE player with the paper flight
(``gym.make("RallySim/HumanLikeReturn-v0")``), compiled: the body's step, the flight, the face's
frame and the box test, with no Python between physics steps. The body's step is the batch's
own (``rallysim.core.humanlike_step``, called for the game's N = P = 1 arrays); a step that
needs judging goes to ``Game._judge``.
"""

from __future__ import annotations

import functools
from collections.abc import Callable
from typing import Any

import numpy as np

from rallysim.core import humanlike_step, native, one_game, rules
from rallysim.core.humanlike import HumanLikeBodies
from rallysim.core.one_game import OneGame
from rallysim.core.shuttle import GRAVITY, PaperShuttle


def _free_steps_with(physics_step: Callable, step_apart: Callable, fly: Callable,
                     shape: Callable, load: Callable, store: Callable) -> Callable:
    """The free physics steps of one game of one HUMAN-LIKE player (``OneHumanLikeGame``),
    around the body's ``physics_step`` (``rallysim.core.humanlike_step``), the face's frame
    from MuJoCo's face site (``HumanLikeBodies.face_frame``); ``fly``, ``shape``, ``load``,
    ``store``: ``one_game.HELPERS`` compiled. Returns the steps run, whether the last needs judging,
    and the points the box test of that step started from (the face's frame, the world)."""

    def free_steps(model, data, mass, m_index, qpos, qvel, ctrl, bias, target, torque_limit,
                   side, face0, face, mat, hips, hips_step, hips_velocity, moved, mocap, forward,
                   k, motion, q, shot_time_a, gap_a, good_a, bad_a, has_hit_a, g, steps,
                   shaping):
        dt, fall, f, fwd, bfwd, top = g[0], g[1], g[2], g[3], g[4], g[5]
        net_lo, net_hi = (g[6], g[7], g[8]), (g[9], g[10], g[11])
        face_lo, face_hi = (g[12], g[13], g[14]), (g[15], g[16], g[17])
        px, py, pz, vx, vy, vz, qx, qy, qz, shot_time, gap, good, bad, todo = load(
            motion, q, shot_time_a, gap_a, good_a, bad_a, has_hit_a)
        fq, world = (qx, qy, qz), (px, py, pz)
        fq0, world0 = fq, world
        run, judged = 0, False
        while run < steps:
            run += 1
            fq0, world0 = fq, world
            physics_step(model, data, mass, m_index, qpos, qvel, ctrl, bias, target,
                         torque_limit, side, face0, face, hips, hips_step, hips_velocity,
                         moved, mocap, forward, k)
            base_x = hips[0, 0, 0]
            px, py, pz, vx, vy, vz, shot_time = fly(px, py, pz, vx, vy, vz, shot_time, fall, f, dt)
            # Game._observe and HumanLikeBodies.face_frame
            ox, oy = fwd * px, fwd * py
            r0, r1, r2 = ox * bfwd - face[0, 0, 0], oy * bfwd - face[0, 0, 1], pz - face[0, 0, 2]
            qx = (mat[0, 0, 0, 0] * r0 + mat[0, 0, 1, 0] * r1) + mat[0, 0, 2, 0] * r2
            qy = (mat[0, 0, 0, 1] * r0 + mat[0, 0, 1, 1] * r1) + mat[0, 0, 2, 1] * r2
            qz = (mat[0, 0, 0, 2] * r0 + mat[0, 0, 1, 2] * r1) + mat[0, 0, 2, 2] * r2
            if shaping:
                good, bad, gap = shape(abs(ox - base_x), moved[0, 0], todo, good, bad, gap)
            fq, world = (qx, qy, qz), (px, py, pz)
            if not step_apart(fq0, fq, world0, world, top, net_lo, net_hi, face_lo, face_hi):
                judged = True
                break
        store(motion, q, shot_time_a, gap_a, good_a, bad_a, px, py, pz, vx, vy, vz, qx, qy, qz,
              shot_time, gap, good, bad)
        return run, judged, fq0, world0

    return free_steps


@functools.cache
def compiled_free_steps() -> Callable:
    """``_free_steps_with`` compiled by Numba on the compiled body step, made once per
    process."""
    numba = native.numba_module()
    step_apart = numba.njit(rules.step_apart_with(numba.njit(rules.apart)))
    return native.jit(_free_steps_with(humanlike_step.compiled_step(), step_apart,
                                       *one_game.compiled_helpers()))


class OneHumanLikeGame(OneGame):
    """The fused physics steps of one game of one HUMAN-LIKE player with the paper flight."""

    @staticmethod
    def fits(game: Any) -> bool:
        """Whether ``game`` is one game of one player of ``HumanLikeBodies`` itself (a subclass
        may change the motion) with the paper flight."""
        return (game.ops.scalar and type(game.bodies) is HumanLikeBodies
                and (game.n_envs, game.n_players) == (1, 1) and type(game.flight) is PaperShuttle)

    def __init__(self, game: Any) -> None:
        b, flight = game.bodies, game.flight
        net_lo, net_hi = game._net_apart
        face_lo, face_hi = game._face_apart
        self.k = np.array([flight.dt, GRAVITY * flight.dt, flight.factor, game._fwd.item(),
                           b.forward.item(), game._floor_top, *net_lo, *net_hi, *face_lo,
                           *face_hi])

    def kernel_in(self, game: Any) -> str:
        return "compiled"

    def _steps(self, game: Any, steps: int) -> tuple[int, bool, tuple, tuple]:
        b, sh, ev = game.bodies, game.shuttle, game.events
        b._sync()
        return compiled_free_steps()(
            b.model._address, b.data._address, b._mass, b._m_index, b.qpos, b.qvel, b.torque,
            b._bias, b.target, b.torque_limit, b._side, b._face0, b._face_pos, b._face_mat,
            b.hips, b._hips_step, b.hips_velocity, b.base_moved, b._mocap, b.forward,
            b._constants, sh.motion, game._q, sh.shot_time, game._gap, ev.approach_good,
            ev.approach_bad, game.state.has_hit, self.k, steps, game.shaping)
