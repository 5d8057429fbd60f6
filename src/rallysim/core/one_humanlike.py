"""One HUMAN-LIKE player's physics step, compiled: the servo, MuJoCo's step, the joint stops and
the hips, with no Python in between.

``HumanLikeBodies.physics_step`` of one player (N = P = 1, the single env
``gym.make("RallySim/HumanLikeReturn-v0")``) runs its ``_one`` methods on Python floats, which
restate the batch's array code operation for operation. ``_physics_step_with`` restates those
once more as loops that Numba compiles, so that the step costs about what
MuJoCo's own work does. It gives their bits because everything it calls from C is what they
call: MuJoCo's ``mj_step1`` and ``mj_step2`` from the bindings' own library, and LAPACK's
``dgesv`` from the library behind NumPy's ``linalg.solve``, handed the matrix in the layout
NumPy hands it; the row sums are NumPy's pairwise order for 8 terms, and both they and the
solve are probed against NumPy before the kernel is used (``rallysim.core.native``). Where the
compiled step cannot be had, the Python methods run, with the same results;
``tests/test_one_humanlike.py`` holds the two and a batch's env 0 bit-identical.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

from rallysim.core import native, one_game, rules
from rallysim.core.one_game import OneGame
from rallysim.core.shuttle import GRAVITY, PaperShuttle

# ``constants`` layout (``HumanLikeBodies._constants``): lo, hi, rate (8 each), then these
DT, BRAKE, MAX_SPEED, HIPS_LO, HIPS_HI, FORWARD, HIPS_HEIGHT = 24, 25, 26, 27, 29, 31, 32
ROUNDS = 33  # of the active set
N_CONSTANTS = 34


def row_sums8(p: np.ndarray, out: np.ndarray) -> None:
    """``np.add.reduce(p, axis=-1)`` of an (8, 8) array: NumPy's pairwise sum of 8 terms,
    added to the reduction's +0.0 start."""
    for i in range(8):
        out[i] = 0.0 + (((p[i, 0] + p[i, 1]) + (p[i, 2] + p[i, 3]))
                        + ((p[i, 4] + p[i, 5]) + (p[i, 6] + p[i, 7])))


def _solve_with(dgesv: Callable) -> Callable:
    """``solve(A, r, u)``: u = A^-1 r for an (8, 8) A, by ``dgesv`` on A in Fortran order, as
    NumPy's ``linalg.solve`` copies it (NaN where A is singular, as NumPy's gufunc gives)."""

    def solve(A, r, u):
        a = np.empty(64)
        for i in range(8):
            for j in range(8):
                a[j * 8 + i] = A[i, j]
            u[i] = r[i]
        ints = np.empty(5, np.int64)  # n, nrhs, lda, ldb, info
        ints[0], ints[1], ints[2], ints[3], ints[4] = 8, 1, 8, 8, 0
        ipiv = np.empty(8, np.int64)
        dgesv(ints[0:], ints[1:], a, ints[2:], ipiv, u, ints[3:], ints[4:])
        if ints[4] != 0:  # a singular system: NumPy's gufunc gives NaN
            for i in range(8):
                u[i] = np.nan

    return solve


def _physics_step_with(mj_step1: Callable, mj_step2: Callable, solve: Callable,
                       row_sums: Callable) -> Callable:
    """``physics_step(model, data, <the bodies' arrays>, constants)``: ``HumanLikeBodies``'s
    ``_servo_one``, ``mj_step2``, ``_joint_stops_one``, ``_move_hips_one`` and ``mj_step1``, in
    their order, with the same operations (see those methods for the why of each)."""

    def physics_step(model, data, mass, m_index, qpos, qvel, ctrl, bias, target, torque_limit,
                     side_a, face0, face, hips, hips_step, hips_velocity, moved, mocap, k):
        dt = k[DT]
        inv_dt = 1.0 / dt
        for i in range(3):
            face0[0, 0, i] = face[0, 0, i]
        # -- _servo_one
        M = np.empty((8, 8))
        for i in range(8):
            for j in range(8):
                M[i, j] = mass[m_index[0, 0, i, j]]
        lim, acc = np.empty(8), np.empty(8)
        for i in range(8):
            lim[i] = torque_limit[0, 0, i]
            e = target[0, 0, i] - qpos[i]
            size = abs(e)
            speed = math.sqrt(k[BRAKE] * lim[i] / M[i, i] * size)
            cap = size * inv_dt
            speed = speed if speed < cap else cap
            cap = k[16 + i]
            speed = speed if speed < cap else cap
            acc[i] = (math.copysign(speed, e) - qvel[i]) * inv_dt
        products = np.empty((8, 8))
        for i in range(8):
            for j in range(8):
                products[i, j] = M[i, j] * acc[j]
        tau = np.empty(8)
        row_sums(products, tau)
        side = np.empty(8, np.int64)
        saturated = False
        for i in range(8):
            tau[i] = tau[i] + bias[i]
            old = side_a[0, 0, i]
            side[i] = old if old != 0 else int(tau[i] > lim[i]) - int(tau[i] < -lim[i])
            saturated = saturated or side[i] != 0
        if saturated:  # -- _saturate_one
            held = np.empty(8, np.bool_)
            bound, r, u, sums = np.empty(8), np.empty(8), np.empty(8), np.empty(8)
            A, masked = np.empty((8, 8)), np.empty((8, 8))
            new = np.empty(8, np.int64)
            for _ in range(int(k[ROUNDS])):
                for j in range(8):
                    held[j] = side[j] != 0
                    bound[j] = float(side[j]) * lim[j]
                for i in range(8):
                    for j in range(8):
                        masked[i, j] = products[i, j] * (0.0 if held[j] else 1.0)
                        A[i, j] = M[i, j] if held[j] else (-1.0 if i == j else -0.0)
                row_sums(masked, sums)
                for i in range(8):
                    r[i] = (bound[i] - bias[i]) - sums[i]
                solve(A, r, u)
                same = True
                for i in range(8):
                    if held[i]:
                        keep = side[i] * (u[i] - acc[i]) <= 0.0 or lim[i] == 0.0
                        new[i] = side[i] if keep else 0
                    else:
                        new[i] = int(u[i] > lim[i]) - int(u[i] < -lim[i])
                    same = same and new[i] == side[i]
                if same:
                    break
                for i in range(8):
                    side[i] = new[i]
            for i in range(8):
                tau[i] = bound[i] if held[i] else u[i]
                side[i] = new[i]
        for i in range(8):
            side_a[0, 0, i] = side[i]
            t = tau[i] if tau[i] > -lim[i] else -lim[i]
            ctrl[i] = t if t < lim[i] else lim[i]
        mj_step2(model, data)
        # -- _joint_stops_one
        top = k[MAX_SPEED]
        over = np.empty(8, np.bool_)
        stopped = False
        for i in range(8):
            over[i] = qpos[i] > k[8 + i] or qpos[i] < k[i]
            stopped = stopped or over[i]
        if stopped:  # every joint clamped (a -0.0 at a stop of +0.0 becomes +0.0)
            for i in range(8):
                x = qpos[i] if qpos[i] > k[i] else k[i]
                qpos[i] = x if x < k[8 + i] else k[8 + i]
                if over[i]:
                    qvel[i] = 0.0
        fast = False
        for i in range(8):
            fast = fast or qvel[i] > top or qvel[i] < -top
        if stopped or fast:
            for i in range(8):
                v = qvel[i] if qvel[i] > -top else -top
                qvel[i] = v if v < top else top
        # -- _move_hips_one
        f = k[FORWARD]
        for i in range(2):
            x = hips[0, 0, i]
            n = x + hips_step[0, 0, i]
            n = n if n > k[HIPS_LO + i] else k[HIPS_LO + i]
            n = n if n < k[HIPS_HI + i] else k[HIPS_HI + i]
            hips_velocity[0, 0, i] = (n - x) * inv_dt
            hips[0, 0, i] = n
            mocap[0, 0, i] = n * f
        moved[0, 0] = hips_velocity[0, 0, 0] != 0.0 or hips_velocity[0, 0, 1] != 0.0
        mocap[0, 0, 2] = k[HIPS_HEIGHT]
        mj_step1(model, data)

    return physics_step


def _free_steps_with(physics_step: Callable, step_apart: Callable, fly: Callable,
                     shape: Callable, load: Callable, store: Callable) -> Callable:
    """The free physics steps of one game of one HUMAN-LIKE player (``OneHumanLikeGame``),
    as ``rallysim.core.one_game._free_steps_with`` runs them for one SIMPLE player: the body's
    ``physics_step`` (above) in place of the arm's, the face's frame from MuJoCo's face site
    (``HumanLikeBodies.face_frame``); ``fly``, ``shape``, ``load``, ``store``:
    ``one_game.HELPERS`` compiled. Returns the steps run, whether the last needs judging,
    and the points the box test of that step started from (the face's frame, the world)."""

    def free_steps(model, data, mass, m_index, qpos, qvel, ctrl, bias, target, torque_limit,
                   side, face0, face, mat, hips, hips_step, hips_velocity, moved, mocap, k,
                   motion, q, shot_time_a, gap_a, good_a, bad_a, has_hit_a, g, steps, shaping):
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
                         moved, mocap, k)
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


def _compile() -> Callable:
    """``_physics_step_with`` compiled by Numba; ``native.Unavailable`` where Numba, MuJoCo's
    library or NumPy's LAPACK cannot be had, or where the compiled row sums or solve differ
    from NumPy's on a probe."""
    numba = native.numba_module()
    step1, step2 = native.mujoco_functions("mj_step1", "mj_step2")
    row_sums = numba.njit(row_sums8)
    solve = numba.njit(_solve_with(native.numpy_dgesv()))
    _probe(row_sums, solve)
    physics_step = native.jit(_physics_step_with(step1, step2, solve, row_sums))
    step_apart = numba.njit(rules.step_apart_with(numba.njit(rules.apart)))
    steps = Steps(physics_step, native.jit(_free_steps_with(physics_step, step_apart,
                                                            *one_game.compiled_helpers())))
    _dry_run(steps)
    return steps


def _dry_run(steps: Steps) -> None:
    """Compile both functions now, for arrays of the types a game's are, by a call of the free
    steps that runs no physics step, and ``physics_step`` for the same arrays (compiled with
    the free steps, or both loaded from Numba's cache), so that a failure shows here, where
    the Python code can take over."""
    f = np.zeros
    one = (f((1, 1, 8)), f((1, 1, 8)), f((1, 1, 8), np.int8), f((1, 1, 3)), f((1, 1, 3)),
           f((1, 1, 3, 3)), f((1, 1, 2)), f((1, 1, 2)), f((1, 1, 2)), f((1, 1), bool),
           f((1, 1, 3)), f(N_CONSTANTS))
    body = (0, 0, f(36), f((1, 1, 8, 8), np.int64), f(8), f(8), f(8), f(8))
    counts = f((1, 1), np.int64)
    steps.free_steps(*body, *one, f((6, 1)), f((1, 3, 3)), f(1), f((1, 1)), counts, counts,
                     f((1, 1), bool), f(18), 0, False)
    numba = native.numba_module()
    steps.physics_step.compile(tuple(numba.typeof(a) for a in body + one[:5] + one[6:]))


def _probe(row_sums: Callable, solve: Callable) -> None:
    """The compiled row sums and solve against NumPy's on random systems of the servo's kind
    (inertia-like blocks mixed with -I columns, entries over many magnitudes)."""
    rng = np.random.default_rng(0)
    n = 2000
    p = rng.standard_normal((n, 8, 8)) * 10.0 ** rng.integers(-9, 6, (n, 8, 8))
    p[rng.random((n, 8, 8)) < 0.1] = -0.0
    p[0] = -0.0  # a zero total is +0.0
    L = rng.standard_normal((n, 8, 8))
    spd = L @ np.swapaxes(L, 1, 2) + 0.01 * np.eye(8)
    A = np.where(rng.random((n, 1, 8)) < 0.5, spd, -np.eye(8))
    r = rng.standard_normal((n, 8)) * 10.0 ** rng.integers(-3, 3, (n, 8))

    @native.jit  # (cached, as the kernels: the probe runs in every process)
    def run(p, A, r):
        sums, u = np.empty((p.shape[0], 8)), np.empty((p.shape[0], 8))
        for t in range(p.shape[0]):
            row_sums(p[t], sums[t])
            solve(A[t], r[t], u[t])
        return sums, u

    sums, u = run(p, A, r)
    if sums.tobytes() != np.add.reduce(p, axis=-1).tobytes():
        raise native.Unavailable("the compiled row sums differ from NumPy's on this machine")
    # (one call for all: NumPy's gufunc hands each system to dgesv as a call for one does)
    numpy_u = np.linalg.solve(A, r[:, :, None])[:, :, 0]
    if u.tobytes() != numpy_u.tobytes():
        raise native.Unavailable("the compiled solve differs from NumPy's on this machine")


class Steps(NamedTuple):
    """The compiled kernel: one physics step of the body, and the free steps of a game."""

    physics_step: Callable
    free_steps: Callable


# this process's compiled kernel, made on first use
Compiled = native.Kernel(lambda: _compile())


class OneHumanLikeGame(OneGame):
    """The fused physics steps of one game of one HUMAN-LIKE player with the paper flight, where
    the compiled kernel runs (elsewhere the lanes code runs them, with the same results). The
    kernel asked for is the bodies' (``HumanLikeBodies.kernel_asked``)."""

    @staticmethod
    def fits(game: Any) -> bool:
        """Whether ``game`` is one game of one player that the compiled step may run (the
        bodies say so: ``HumanLikeBodies.fits_compiled_step``) with the paper flight."""
        return (game.ops.scalar and getattr(game.bodies, "fits_compiled_step", False)
                and type(game.flight) is PaperShuttle)

    def __init__(self, game: Any) -> None:
        b, flight = game.bodies, game.flight
        net_lo, net_hi = game._net_apart
        face_lo, face_hi = game._face_apart
        self.k = np.array([flight.dt, GRAVITY * flight.dt, flight.factor, game._fwd.item(),
                           b.forward.item(), game._floor_top, *net_lo, *net_hi, *face_lo,
                           *face_hi])

    def kernel_in(self, game: Any) -> str:
        return game.bodies.kernel

    def run(self, game: Any, steps: int) -> None:
        if game.bodies.kernel == "python":
            game._run_lanes(steps)
        else:
            super().run(game, steps)

    def _steps(self, game: Any, steps: int) -> tuple[int, bool, tuple, tuple]:
        b, sh, ev = game.bodies, game.shuttle, game.events
        b._sync()
        return Compiled.function.free_steps(
            b.model._address, b.data._address, b._mass, b._m_index, b._flat_qpos, b._flat_qvel,
            b._flat_ctrl, b._flat_bias, b.target, b.torque_limit, b._side, b._face0,
            b._face_pos, b._face_mat, b.hips, b._hips_step, b.hips_velocity, b.base_moved,
            b._mocap, b._constants, sh.motion, game._q, sh.shot_time, game._gap,
            ev.approach_good, ev.approach_bad, game.state.has_hit, self.k, steps, game.shaping)
