"""The HUMAN-LIKE players' physics step, written once and compiled by Numba: one loop over every
game and player of the one batched model (``HumanLikeBodies``) around MuJoCo's step, for any
N x P (``gym.make`` at N = P = 1, a batch of thousands, two-player rallies).

One step: each player's servo torques (``_servo``: the desired accelerations, the deadbeat
torques, the active set of saturated joints), MuJoCo's ``mj_step2`` of the whole model, each
player's joint stops and hips motion, then ``mj_step1`` of the whole model (the split leaves the
kinematics, inertia and bias forces of the new state for the rulebook and the next servo solve;
see ``HumanLikeBodies.physics_step``). Players are independent, so env i of a batch seeded s
replays a single env seeded s + i bit for bit.

The arithmetic is NumPy's for these formulas, so results do not depend on the batch size:
``np_min``/``np_max`` are ``np.minimum``/``np.maximum`` (NaN propagates, the second argument
wins a tie, which decides signed zeros); ``row_sums8`` is NumPy's pairwise sum of a row of 8;
the solve is LAPACK's ``dgesv`` from the library behind NumPy's ``linalg.solve``, handed the
matrix in the layout NumPy hands it (NaN for a singular system, as NumPy's gufunc gives).
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable

import numpy as np

from rallysim.core import native
from rallysim.core.kernels.numpy_scalars import np_max, np_min

# The bodies' constants, read by name: each joint's stops and top rate, the step, the brake's
# factor, the speed ceiling, the hips' range and height, the active set's rounds.
CONSTANTS_DTYPE = np.dtype([("lo", "f8", (8,)), ("hi", "f8", (8,)), ("max_rate", "f8", (8,)),
                            ("dt", "f8"), ("brake", "f8"), ("max_speed", "f8"),
                            ("hips_lo", "f8", (2,)), ("hips_hi", "f8", (2,)),
                            ("hips_height", "f8"), ("rounds", "i8")])


def body_constants(**values: object) -> np.ndarray:
    """A (1,) record array of ``CONSTANTS_DTYPE`` holding ``values``, one per field."""
    if set(values) != set(CONSTANTS_DTYPE.names):
        raise ValueError(f"the HUMAN-LIKE constants are {CONSTANTS_DTYPE.names}, got "
                         f"{tuple(values)}")
    record = np.zeros(1, CONSTANTS_DTYPE)
    for name, value in values.items():
        if np.shape(value) != CONSTANTS_DTYPE[name].shape:  # (a number would fill a row)
            raise ValueError(f"{name} must have shape {CONSTANTS_DTYPE[name].shape}, got "
                             f"{np.shape(value)}")
        record[name] = value
    return record


def beyond(tau: float, lim: float) -> int:
    """+1 where ``tau`` is above ``lim``, -1 where it is below -``lim``, else 0."""
    return int(tau > lim) - int(tau < -lim)


def row_sums8(p: np.ndarray, out: np.ndarray) -> None:
    """``np.add.reduce(p, axis=-1)`` of an (8, 8) array: NumPy's pairwise sum of 8 terms,
    added to the reduction's +0.0 start."""
    for i in range(8):
        out[i] = 0.0 + (((p[i, 0] + p[i, 1]) + (p[i, 2] + p[i, 3]))
                        + ((p[i, 4] + p[i, 5]) + (p[i, 6] + p[i, 7])))


def _solve_with(dgesv: Callable) -> Callable:
    """``solve(A, r, u, a, ints, ipiv)``: u = A^-1 r for an (8, 8) A by ``dgesv`` on A copied
    into ``a`` in Fortran order, as NumPy's ``linalg.solve`` copies it; ``ints`` (5) and
    ``ipiv`` (8) int64 are scratch."""

    def solve(A, r, u, a, ints, ipiv):
        for i in range(8):
            for j in range(8):
                a[j * 8 + i] = A[i, j]
            u[i] = r[i]
        ints[0], ints[1], ints[2], ints[3], ints[4] = 8, 1, 8, 8, 0  # n, nrhs, lda, ldb, info
        dgesv(ints[0:], ints[1:], a, ints[2:], ipiv, u, ints[3:], ints[4:])
        if ints[4] != 0:  # a singular system: NumPy's gufunc gives NaN
            for i in range(8):
                u[i] = np.nan

    return solve


def _physics_step_with(mj_step1: Callable, mj_step2: Callable, solve: Callable,
                       row_sums: Callable, np_min: Callable, np_max: Callable,
                       beyond: Callable) -> Callable:
    """``physics_step(model, data, <the bodies' arrays>, forward, constants)`` over all N x P
    players (see the module docstring; the why of each formula is in
    ``rallysim.core.humanlike``'s docstring)."""

    def physics_step(model, data, mass, m_index, qpos, qvel, ctrl, bias, target, torque_limit,
                     side_a, face0, face, hips, hips_step, hips_velocity, moved, mocap,
                     forward, constants):
        n_envs, n_players = qpos.shape[0], qpos.shape[1]
        k = constants[0]
        lo, hi, max_rate, hips_lo, hips_hi = k.lo, k.hi, k.max_rate, k.hips_lo, k.hips_hi
        inv_dt = 1.0 / k.dt
        rounds = k.rounds
        M, products, masked, A = (np.empty((8, 8)), np.empty((8, 8)), np.empty((8, 8)),
                                  np.empty((8, 8)))
        lim, acc, tau, bound, r, u = (np.empty(8), np.empty(8), np.empty(8), np.empty(8),
                                      np.empty(8), np.empty(8))
        side, new = np.empty(8, np.int64), np.empty(8, np.int64)
        held = np.empty(8, np.bool_)
        a, ints, ipiv = np.empty(64), np.empty(5, np.int64), np.empty(8, np.int64)
        for e in range(n_envs):
            for p in range(n_players):
                for i in range(3):
                    face0[e, p, i] = face[e, p, i]
                # -- the servo: desired accelerations, then the torques within the limits
                for i in range(8):
                    for j in range(8):
                        M[i, j] = mass[m_index[e, p, i, j]]
                for i in range(8):
                    lim[i] = torque_limit[e, p, i]
                    err = target[e, p, i] - qpos[e, p, i]
                    size = abs(err)
                    speed = math.sqrt(k.brake * lim[i] / M[i, i] * size)
                    speed = np_min(speed, size * inv_dt)
                    speed = np_min(speed, max_rate[i])
                    acc[i] = (math.copysign(speed, err) - qvel[e, p, i]) * inv_dt
                for i in range(8):
                    for j in range(8):
                        products[i, j] = M[i, j] * acc[j]
                row_sums(products, tau)
                saturated = False
                for i in range(8):
                    tau[i] = tau[i] + bias[e, p, i]
                    old = side_a[e, p, i]
                    side[i] = old if old != 0 else beyond(tau[i], lim[i])
                    saturated = saturated or side[i] != 0
                if saturated:  # rounds of the active set until the saturated set settles
                    for _ in range(rounds):
                        for j in range(8):
                            held[j] = side[j] != 0
                            bound[j] = float(side[j]) * lim[j]
                        for i in range(8):
                            for j in range(8):
                                masked[i, j] = M[i, j] * (0.0 if held[j] else acc[j])
                                A[i, j] = M[i, j] if held[j] else (-1.0 if i == j else -0.0)
                        row_sums(masked, r)
                        for i in range(8):
                            r[i] = (bound[i] - bias[e, p, i]) - r[i]
                        solve(A, r, u, a, ints, ipiv)
                        same = True
                        for i in range(8):
                            if held[i]:
                                tau[i] = bound[i]
                                # KKT: a held joint must fall short of its desired
                                # acceleration in the direction it pushes (else it is
                                # released), unless its limit is zero (both bounds at once)
                                keep = side[i] * (u[i] - acc[i]) <= 0.0 or lim[i] == 0.0
                                new[i] = side[i] if keep else 0
                            else:
                                tau[i] = u[i]
                                new[i] = beyond(u[i], lim[i])
                            same = same and new[i] == side[i]
                        for i in range(8):
                            side[i] = new[i]
                        if same:
                            break
                for i in range(8):
                    side_a[e, p, i] = side[i]
                    ctrl[e, p, i] = np_min(np_max(tau[i], -lim[i]), lim[i])
        mj_step2(model, data)
        top = k.max_speed
        for e in range(n_envs):
            for p in range(n_players):
                # -- joint stops: a joint past one is put back and stopped; the speed ceiling
                stopped = False
                for i in range(8):
                    x = qpos[e, p, i]
                    if x > hi[i] or x < lo[i]:
                        stopped = True
                        qvel[e, p, i] = 0.0
                if stopped:
                    for i in range(8):
                        qpos[e, p, i] = np_min(np_max(qpos[e, p, i], lo[i]), hi[i])
                for i in range(8):
                    qvel[e, p, i] = np_min(np_max(qvel[e, p, i], -top), top)
                # -- the hips, clipped into their range; the mocap body follows (world frame)
                f = forward[e, p]
                m = False
                for i in range(2):
                    x = hips[e, p, i]
                    x1 = np_min(np_max(x + hips_step[e, p, i], hips_lo[i]), hips_hi[i])
                    v = (x1 - x) * inv_dt
                    hips_velocity[e, p, i] = v
                    m = m or v != 0.0
                    hips[e, p, i] = x1
                    mocap[e, p, i] = x1 * f
                moved[e, p] = m
                mocap[e, p, 2] = k.hips_height
        mj_step1(model, data)

    return physics_step


@functools.cache
def compiled_step() -> Callable:
    """``_physics_step_with`` compiled by Numba, made once per process, calling MuJoCo's
    ``mj_step1``/``mj_step2`` and NumPy's LAPACK ``dgesv`` (obtained here, and only here,
    through ``rallysim.core.native``)."""
    numba = native.numba_module()
    step1, step2 = native.mujoco_functions("mj_step1", "mj_step2")
    dgesv = native.numpy_dgesv()
    jit = numba.njit
    step = _physics_step_with(step1, step2, jit(_solve_with(dgesv)), jit(row_sums8), jit(np_min),
                              jit(np_max), jit(beyond))
    # NumPy's error model: a division by zero gives inf, not an error
    return native.jit(step, error_model="numpy")


def _body_rows_with() -> Callable:
    """``body_rows(e, p, <MuJoCo's arrays>, <the bodies' arrays>, hips_height, out)``: the
    own-frame states of player (e, p)'s 5 driven bodies into ``out`` (5, 14): per body the
    velocity of its origin 3, angular velocity 3, origin relative to the hips 3, quaternion
    (w, x, y, z, w >= 0) 4 and effort 1 (``HumanLikeBodies.body_states``, ``body_effort``)."""

    def body_rows(e, p, xpos, xquat, cvel, subtree_com, body_ids, hips_ids, hips_velocity,
                  hips, torque, joint_max, forward, hips_height, out):
        f = forward[e, p]
        root = hips_ids[e, p]
        cx, cy, cz = subtree_com[root, 0], subtree_com[root, 1], subtree_com[root, 2]
        hvx, hvy = hips_velocity[e, p, 0], hips_velocity[e, p, 1]
        hx, hy = hips[e, p, 0], hips[e, p, 1]
        sq = np.empty(8)
        for i in range(8):
            x = torque[e, p, i] / joint_max[i]
            sq[i] = x * x
        sums = (sq[0], sq[1], (sq[2] + sq[3]) + sq[4], sq[5], sq[6] + sq[7])
        sizes = (1.0, 1.0, 3.0, 1.0, 2.0)  # joints per group
        for b in range(5):
            k = body_ids[e, p, b]
            px, py, pz = xpos[k, 0], xpos[k, 1], xpos[k, 2]
            a0, a1, a2 = cvel[k, 0], cvel[k, 1], cvel[k, 2]
            b0, b1, b2 = px - cx, py - cy, pz - cz
            # MuJoCo's cvel is the spatial velocity at the tree's centre of mass; the hips are
            # kinematic (invisible to MuJoCo's velocities), so their motion is added
            out[b, 0] = (cvel[k, 3] + (a1 * b2 - a2 * b1)) * f + hvx
            out[b, 1] = (cvel[k, 4] + (a2 * b0 - a0 * b2)) * f + hvy
            out[b, 2] = (cvel[k, 5] + (a0 * b1 - a1 * b0)) * 1.0
            out[b, 3], out[b, 4], out[b, 5] = a0 * f, a1 * f, a2 * 1.0
            out[b, 6], out[b, 7], out[b, 8] = px * f - hx, py * f - hy, pz * 1.0 - hips_height
            w, x, y, z = xquat[k, 0], xquat[k, 1], xquat[k, 2], xquat[k, 3]
            if f < 0.0:  # player 1's frame is the world turned 180 degrees about z
                w, x, y, z = -z, -y, x, w
            sign = -1.0 if w < 0.0 else 1.0
            out[b, 9], out[b, 10], out[b, 11], out[b, 12] = w * sign, x * sign, y * sign, z * sign
            out[b, 13] = math.sqrt(sums[b] / sizes[b])

    return body_rows


def _all_body_rows_with(body_rows: Callable) -> Callable:
    """``all_body_rows(..., out)``: ``body_rows`` of every player into ``out`` (N, P, 5, 14)."""

    def all_body_rows(xpos, xquat, cvel, subtree_com, body_ids, hips_ids, hips_velocity, hips,
                      torque, joint_max, forward, hips_height, out):
        for e in range(out.shape[0]):
            for p in range(out.shape[1]):
                body_rows(e, p, xpos, xquat, cvel, subtree_com, body_ids, hips_ids,
                          hips_velocity, hips, torque, joint_max, forward, hips_height,
                          out[e, p])

    return all_body_rows


def _observations_with(body_rows: Callable) -> Callable:
    """``observations(..., shuttle_pos, shuttle_vel, face, s, out)``: every player's 82 scaled
    values (``rallysim.core.humanlike_obs``) into ``out`` (N, P, 82); ``s``: the body
    speed, rate and offset scales, the shuttle speed scale, the position centre 3 and
    scale 3."""

    def observations(xpos, xquat, cvel, subtree_com, body_ids, hips_ids, hips_velocity, hips,
                     torque, joint_max, forward, hips_height, shuttle_pos, shuttle_vel, face,
                     s, out):
        rows = np.empty((5, 14))
        for e in range(out.shape[0]):
            for p in range(out.shape[1]):
                body_rows(e, p, xpos, xquat, cvel, subtree_com, body_ids, hips_ids,
                          hips_velocity, hips, torque, joint_max, forward, hips_height, rows)
                o = out[e, p]
                for b in range(5):
                    for i in range(3):
                        o[14 * b + i] = rows[b, i] / s[0]
                        o[14 * b + 3 + i] = rows[b, 3 + i] / s[1]
                        o[14 * b + 6 + i] = rows[b, 6 + i] / s[2]
                    for i in range(4):
                        o[14 * b + 9 + i] = rows[b, 9 + i]
                    o[14 * b + 13] = 2.0 * rows[b, 13] - 1.0
                f = forward[e, p]
                flip = (f, f, 1.0)
                for i in range(3):
                    o[70 + i] = (shuttle_pos[e, i] * flip[i] - s[4 + i]) / s[7 + i]
                    o[73 + i] = shuttle_vel[e, i] * flip[i] / s[3]
                    o[79 + i] = (face[e, p, i] * flip[i] - s[4 + i]) / s[7 + i]
                o[76] = (hips[e, p, 0] - s[4]) / s[7]
                o[77] = (hips[e, p, 1] - s[5]) / s[8]
                o[78] = (hips_height - s[6]) / s[9]

    return observations


@functools.cache
def compiled_observations() -> tuple[Callable, Callable]:
    """The compiled body rows of every player and observations of every player."""
    body_rows = native.numba_module().njit(error_model="numpy")(_body_rows_with())
    return (native.jit(_all_body_rows_with(body_rows), error_model="numpy"),
            native.jit(_observations_with(body_rows), error_model="numpy"))
