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

That function runs as Python, or compiled by Numba (the ``fast`` extra; Linux, where MuJoCo's
library is ``libmujoco.so``) where the compiled sine and cosine give NumPy's float64 bits (NumPy's
own SIMD versions, used on some CPUs, may differ from the C library's in the last bit): compiled,
MuJoCo's ``mj_step`` is called from the loop directly, with no Python between physics steps.
``KERNEL`` (or the environment variable ``RALLYSIM_KERNEL``: ``auto``, ``python``, ``compiled``)
chooses; ``auto`` takes the compiled kernel where it can be had and Python elsewhere, with the
same results. ``tests/test_one_game.py`` holds both, the lanes code and a batch's env 0
bit-identical state by state.
"""

from __future__ import annotations

import ctypes
import glob
import os
from collections.abc import Callable
from typing import Any

import mujoco
import numpy as np

from rallysim.core import rules
from rallysim.core.bodies import SimpleBodies
from rallysim.core.lanes import SCALARS
from rallysim.core.shuttle import GRAVITY, PaperShuttle

KERNELS = ("auto", "python", "compiled")
KERNEL_VARIABLE = "RALLYSIM_KERNEL"
KERNEL = os.environ.get(KERNEL_VARIABLE, "auto")  # which ``_free_steps_with`` runs (above)


def _free_steps_with(mj_step: Callable, sin: Callable, cos: Callable, step_apart: Callable
                     ) -> Callable:
    """The free physics steps of one game, calling these four functions (the Python ones, or
    their compiled counterparts: the source is the same; ``step_apart``: ``rules.step_apart``,
    the box test of ``Game._apart``).

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
            if not step_apart(face0, face, world0, world, top, net_lo, net_hi, face_lo,
                              face_hi):
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


PYTHON_FREE_STEPS = _free_steps_with(mujoco.mj_step, SCALARS.sin, SCALARS.cos, rules.step_apart)


class Compiled:
    """The compiled kernel of this process, made on first use: ``free_steps`` (None where it
    cannot be had) and ``why_not`` (why, for errors and test skips)."""

    free_steps: Callable | None = None
    why_not: str = "not yet tried"
    tried = False


def compiled_free_steps() -> Callable | None:
    """``_free_steps_with`` compiled by Numba, calling MuJoCo's C ``mj_step`` with the model's
    and data's addresses; None where Numba or MuJoCo's library is missing, or where the compiled
    sine or cosine differ from NumPy's on a probe of angles (then the compiled steps would not
    replay a batch bit for bit), or where compiling fails (``Compiled.why_not`` says which)."""
    if not Compiled.tried:
        try:
            Compiled.free_steps, Compiled.why_not = _compile(), ""
        except _Unavailable as exc:
            Compiled.why_not = str(exc)
        except Exception as exc:  # a Numba that cannot compile it: Python, with the same results
            Compiled.why_not = f"compiling failed: {type(exc).__name__}: {exc}"
        Compiled.tried = True  # (not before: an interrupted try is tried again)
    return Compiled.free_steps


class _Unavailable(Exception):
    pass


def _compile() -> Callable:
    try:
        import numba
    except ImportError as exc:
        raise _Unavailable(f"Numba cannot be imported (pip install 'rallysim[fast]'): {exc}"
                           ) from None
    # the C library of the bindings' own version: a struct layout of another would corrupt
    # memory without an error
    version = mujoco.mj_versionString()
    libraries = sorted(glob.glob(os.path.join(os.path.dirname(mujoco.__file__), "libmujoco.so*")))
    for path in libraries:
        lib = ctypes.CDLL(path)
        if not hasattr(lib, "mj_versionString"):
            continue
        lib.mj_versionString.restype = ctypes.c_char_p
        if lib.mj_versionString().decode() == version:
            break
    else:
        raise _Unavailable(f"no libmujoco.so of MuJoCo {version} beside its Python bindings "
                           f"(found {[os.path.basename(p) for p in libraries]})")
    # (MuJoCo's errors inside this mj_step reach its default handler, which ends the process,
    # not the bindings' FatalError; one SIMPLE game's finite, clipped actions raise none)
    step = lib.mj_step
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
        raise _Unavailable("Numba's sine or cosine differ from NumPy's on this machine")
    step_apart = numba.njit(rules.step_apart_with(numba.njit(rules.apart)))
    free_steps = numba.njit(_free_steps_with(step, sin, cos, step_apart))
    _dry_run(free_steps)
    return free_steps


def _dry_run(free_steps: Callable) -> None:
    """Compile ``free_steps`` now, for arrays of the types a game's are, by a call that runs no
    physics step (so a failure shows here, where the Python kernel can take over)."""
    f, b, i = np.zeros((1, 1)), np.zeros((1, 1), bool), np.zeros((1, 1), np.int64)
    free_steps(0, 0, f, np.zeros((1, 1, 3)), f, f, f, f, b, f, f, f, f, np.zeros((6, 1)),
               np.zeros((1, 3, 3)), np.zeros(1), f, i, i, b, np.zeros(25), 0, True)


class OneSimpleGame:
    """The fused physics steps of ``game`` (see the module docstring). It holds only numbers
    read from the game when it is made and the name of the kernel asked for (so a copy of the
    game copies it whole), and is made once per game: the game's bodies, flight and boxes do
    not change."""

    @staticmethod
    def fits(game: Any) -> bool:
        """Whether ``game`` is one game of one SIMPLE player with the paper flight."""
        return (game.ops.scalar and type(game.bodies) is SimpleBodies
                and type(game.flight) is PaperShuttle)

    def __init__(self, game: Any, kernel: str | None = None) -> None:
        kernel = KERNEL if kernel is None else kernel
        if kernel not in KERNELS:
            raise ValueError(f"unknown kernel {kernel!r} (one_game.KERNEL or {KERNEL_VARIABLE});"
                             f" valid: {', '.join(map(repr, KERNELS))}")
        # the name asked for, resolved in each process at its first step (compiling takes
        # seconds: not where a game is only made): a copy taken elsewhere (pickle) runs the
        # compiled kernel where it can be had there
        self.asked = kernel
        if kernel == "compiled":
            self._free_steps_function()  # refused here, not at the first step
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

    def _free_steps_function(self) -> Callable | None:
        """The compiled kernel if it runs here, else None (Python); ``RuntimeError`` where the
        compiled one was asked for and cannot be had."""
        if self.asked == "python":
            return None
        compiled = compiled_free_steps()
        if compiled is None and self.asked == "compiled":
            raise RuntimeError(f"the compiled kernel cannot run here: {Compiled.why_not}")
        return compiled

    @property
    def kernel(self) -> str:
        """The kernel that runs in this process: "compiled" or "python"."""
        return "python" if self._free_steps_function() is None else "compiled"

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
        free_steps = self._free_steps_function()
        if free_steps is None:
            free_steps, k, model, data = PYTHON_FREE_STEPS, self.k, b.model, b.data
        else:
            k, model, data = self.k_array, b.model._address, b.data._address
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
