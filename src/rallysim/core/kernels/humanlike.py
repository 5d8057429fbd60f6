"""HUMAN-LIKE players' part of the compiled steps (``rallysim.core.kernels.step``): the bodies'
physics step (``rallysim.core.humanlike_step``: the servo, MuJoCo's step, the joint stops and
the hips), the face's frame (the face site's rotation and centre, as MuJoCo computed them),
the face's velocity at a hit (its displacement over the step / dt, the motion the swept test
interpolated) and the shot (along that velocity at min(60, 5 |v|) m/s, docs/reference.md §10).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rallysim.core import humanlike_step, native
from rallysim.core.kernels import step
from rallysim.core.kernels.arrays import HumanLikeArrays
from rallysim.core.kernels.numpy_scalars import norm3, np_min


def pieces_with(njit: Callable, physics_step: Callable) -> step.Pieces:
    """HUMAN-LIKE's ``step.Pieces``, around the bodies' compiled ``physics_step``."""
    inline = njit(inline="always")
    upper, length = inline(np_min), inline(norm3)

    @inline
    def move(model, data, a, k, n, p):
        physics_step(model, data, a.mass, a.m_index, a.qpos, a.qvel, a.ctrl, a.bias, a.target,
                     a.torque_limit, a.side, a.face0, a.face, a.hips, a.hips_step,
                     a.hips_velocity, a.base_moved, a.mocap, a.fwd, a.body_constants)

    @inline
    def face_point(a, k, e, j, x, y, z):
        """R^T (world point - centre), R the face site's rotation: (across, normal, along the
        handle) about the face's centre."""
        f = a.fwd[e, j]
        r0, r1, r2 = x * f - a.face[e, j, 0], y * f - a.face[e, j, 1], z - a.face[e, j, 2]
        m = a.mat
        return ((m[e, j, 0, 0] * r0 + m[e, j, 1, 0] * r1) + m[e, j, 2, 0] * r2,
                (m[e, j, 0, 1] * r0 + m[e, j, 1, 1] * r1) + m[e, j, 2, 1] * r2,
                (m[e, j, 0, 2] * r0 + m[e, j, 1, 2] * r1) + m[e, j, 2, 2] * r2)

    @inline
    def racket(a, k, e, j, t):
        """The face centre's own-frame velocity over the step, the same at every ``t``."""
        f = a.fwd[e, j]
        return ((a.face[e, j, 0] - a.face0[e, j, 0]) * f * k.inv_dt,
                (a.face[e, j, 1] - a.face0[e, j, 1]) * f * k.inv_dt,
                (a.face[e, j, 2] - a.face0[e, j, 2]) * 1.0 * k.inv_dt)

    @inline
    def shot(k, x, y, z):
        speed = length(x, y, z)
        scale = upper(60.0, 5.0 * speed) / speed if speed > 0.0 else 0.0
        return x * scale, y * scale, z * scale

    return step.Pieces(move, face_point, racket, shot)


def _compile() -> step.Compiled:
    numba = native.numba_module()
    from rallysim.core.kernels import state  # (imports Numba)

    return step.compile_kind(pieces_with(numba.njit, humanlike_step.compiled_step()),
                             state.humanlike)


class HumanLikeKernel(step.GameKernel):
    """The compiled steps of a game of HUMAN-LIKE players."""

    compiled = native.Kernel(lambda: _compile())

    def arrays(self, game: Any) -> HumanLikeArrays:
        b = game.bodies
        return HumanLikeArrays(
            **self.shared(game),
            mass=b._mass, m_index=b._m_index, qpos=b.qpos, qvel=b.qvel, ctrl=b.torque,
            bias=b._bias, target=b.target, torque_limit=b.torque_limit, side=b._side,
            face0=b._face0, face=b._face_pos, mat=b._face_mat, hips=b.hips,
            hips_step=b._hips_step, hips_velocity=b.hips_velocity, mocap=b._mocap,
            body_constants=b._constants)

    def prepare(self, game: Any) -> None:
        game.bodies._sync()  # the kinematics of a state set by hand
