"""SIMPLE players' part of the compiled steps (``rallysim.core.kernels.step``): the bodies'
drive and base (``SimpleBodies``) around MuJoCo's ``mj_step``, the arm's hard stops, the face's
frame (a planar rotation about the arm's pivot), the face's velocity at a hit and the shot
(twice that velocity, docs/reference.md §5); and one-player games' observation, compiled.

``np.minimum(a, b)`` is ``a if a < b else b`` and ``np.maximum(a, b)`` ``a if a > b else b``
(``numpy_scalars``); the sine and cosine are the C library's, which NumPy's are wherever its
AVX-512 code is off (the tests' pins, docs/numerics.md).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from rallysim.core import native
from rallysim.core.kernels import step
from rallysim.core.kernels.arrays import SimpleArrays
from rallysim.core.kernels.numpy_scalars import np_max, np_min


def pieces_with(njit: Callable, mj_step: Callable, sin: Callable, cos: Callable) -> step.Pieces:
    """SIMPLE's ``step.Pieces``, calling MuJoCo's ``mj_step`` (of model and data addresses)."""
    inline = njit(inline="always")
    lower, upper = inline(np_max), inline(np_min)

    @inline
    def clip(a, lo, hi):
        return upper(lower(a, lo), hi)  # np.minimum(np.maximum(a, lo), hi)

    @inline
    def move(model, data, a, k, n, p):
        """The base slides, the arm's drive torque is set (the rate that reaches the target
        within the step, capped, then torque-limited), MuJoCo integrates, then the arm's hard
        stops (the drive can overshoot its target when its torque is low)."""
        for e in range(n):
            for j in range(p):
                theta = a.theta[e, j]
                a.theta0[e, j] = theta
                old = a.base_x[e, j]
                x = clip(old + a.base_step[e, j], k.base_lo, k.base_hi)
                a.base_moved[e, j] = x != old
                a.base_x[e, j] = x
                a.mocap[e, j, 0] = a.fwd[e, j] * x
                w = clip((a.target[e, j] - theta) * k.inv_dt, -k.max_rate, k.max_rate)
                w = (w - a.omega[e, j]) * k.drive
                a.torque[e, j] = clip(w, a.neg_limit[e, j], a.torque_limit[e, j])
        mj_step(model, data)
        for e in range(n):
            for j in range(p):
                theta = a.theta[e, j]
                if abs(theta) > k.limit:
                    a.theta[e, j] = clip(theta, -k.limit, k.limit)
                    a.omega[e, j] = 0.0

    @inline
    def face_point(a, k, e, j, x, y, z):
        """(normal, across, along the arm) about the face centre: the arm turns about y only."""
        theta = a.theta[e, j]
        s, c = sin(theta), cos(theta)
        fo = k.face_offset
        dx = x - a.base_x[e, j] - fo * s
        dz = z - k.pivot_z - fo * c
        return dx * c - dz * s, y, dx * s + dz * c

    @inline
    def racket(a, k, e, j, t):
        """The face centre's velocity at fraction ``t``: the arm turned at a constant rate
        through the step (Euler), so only the direction depends on ``t``."""
        th0 = a.theta0[e, j]
        th = th0 + t * (a.theta[e, j] - th0)
        w = a.omega[e, j]
        fo = k.face_offset
        return fo * w * cos(th), 0.0, -fo * w * sin(th)

    @inline
    def shot(k, x, y, z):
        f = k.shot_factor
        return f * x, f * y, f * z

    return step.Pieces(move, face_point, racket, shot)


def _observations_with(njit: Callable, sin: Callable, cos: Callable) -> Callable:
    """Every player's observation in each of N games, compiled: the 16 values of
    ``simple_obs.PLAYER_OBS`` in the player's own frame, then ``extra[e, j]``, each mapped by
    (x - centre) / scale and clipped into [-1, 1] as ``np.clip`` clips (NaN stays NaN),
    written into ``out`` (N, P, 16 + X) for the games ``rows``."""

    # (NumPy's error model: a zero scale gives inf or NaN, as the arrays do)
    @njit(error_model="numpy")
    def observations(theta_a, omega_a, base_x, fwd, m, extra, base_z, fo, centre, scale, rows,
                     out):
        p = theta_a.shape[1]
        n_extra = extra.shape[2]
        size = 16 + n_extra
        if out.shape[2] != size or centre.size != size or scale.size != size:
            raise ValueError("the observation's maps must have one entry per value")
        raw = np.empty(size)
        for e in rows:
            for j in range(p):
                theta, omega, f = theta_a[e, j], omega_a[e, j], fwd[e, j]
                s, c = sin(theta), cos(theta)
                half = 0.5 * theta
                raw[0], raw[1], raw[2] = base_x[e, j], 0.0, base_z
                raw[3], raw[4], raw[5], raw[6] = cos(half), 0.0, sin(half), 0.0  # about y
                raw[7], raw[8], raw[9] = fo * omega * c, 0.0, -fo * omega * s  # face velocity
                # the shuttle: the own frame turns x and y (f = -1 for player 1), not z
                raw[10], raw[11], raw[12] = f * m[0, e], f * m[1, e], m[2, e]
                raw[13], raw[14], raw[15] = f * m[3, e], f * m[4, e], m[5, e]
                for i in range(n_extra):
                    raw[16 + i] = extra[e, j, i]
                for i in range(size):
                    x = (raw[i] - centre[i]) / scale[i]
                    if x < -1.0:
                        x = -1.0
                    if x > 1.0:
                        x = 1.0
                    out[e, j, i] = x
        return out

    return observations


def _compile() -> tuple[step.Compiled, Callable]:
    """The steps and the observation compiled, calling MuJoCo's C ``mj_step``."""
    numba = native.numba_module()
    (mj_step,) = native.mujoco_functions("mj_step")
    sin = numba.njit(lambda x: np.sin(x))
    cos = numba.njit(lambda x: np.cos(x))
    from rallysim.core.kernels import state  # (imports Numba)

    compiled = step.compile_kind(pieces_with(numba.njit, mj_step, sin, cos), state.simple)
    observations = _observations_with(numba.njit, sin, cos)
    return compiled, native.jit(observations.py_func, error_model="numpy")


# this process's compiled functions, made on first use
Compiled = native.Kernel(lambda: _compile())


class SimpleKernel(step.GameKernel):
    """The compiled steps of a game of SIMPLE players."""

    compiled = native.Kernel(lambda: Compiled.get()[0])

    def arrays(self, game: Any) -> SimpleArrays:
        b = game.bodies
        return SimpleArrays(
            **self.shared(game),
            theta=b.theta, omega=b.omega, torque=b.torque, mocap=b.mocap, theta0=b._theta0,
            base_step=b._base_step, target=b.target, neg_limit=b._neg_limit,
            torque_limit=b.torque_limit)

    def body_constants(self, game: Any) -> dict[str, float]:
        b = game.bodies
        lo, hi = b.base_range
        return dict(base_lo=float(lo), base_hi=float(hi), max_rate=float(b.max_rate),
                    drive=b.inertia / b.dt, limit=float(b.limit),
                    face_offset=float(b.face_offset), pivot_z=float(b.pivot_z),
                    shot_factor=float(b.shot_factor))


def observations(game: Any, extra: np.ndarray, centre: np.ndarray, scale: np.ndarray,
                 rows: np.ndarray | None = None, out: np.ndarray | None = None) -> np.ndarray:
    """Every SIMPLE player's observation followed by ``extra`` (N, P, X), scaled, clipped,
    float32 (N, P, 16 + X) (``_observations_with``); with ``rows`` and ``out``, only those
    games', written into ``out``."""
    b = game.bodies
    if rows is None:
        rows = game.every_env
        if out is None:
            out = np.empty((*b.theta.shape, 16 + extra.shape[2]), np.float32)
    elif out is None:
        raise ValueError("observing some rows needs the observation they go into (out)")
    # (only the arrays it reads: each array passed costs the call some time)
    return Compiled.get()[1](b.theta, b.omega, b.base_x, b.forward, game.shuttle.motion, extra,
                             b.base_z, b.face_offset, centre, scale, rows, out)
