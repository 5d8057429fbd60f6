"""The physics steps of one game of one SIMPLE player with the paper flight, on local numbers.

This is the case of ``gym.make("RallySim/SimpleReturn-v0")``, the single env that third-party
trainers step. ``Game._step_lanes`` runs it on scalar lanes (``rallysim.core.lanes``), where
reading and writing lanes and calling the backend's functions cost several times the arithmetic.
``OneSimpleGame.run`` does the same IEEE-754 operations in the same order on local variables,
for the steps in which the shuttle is in play and stays apart from every box
(``Game._apart``): nearly all of them, and for the steps of a game out of play (after a
landing, or held by ``Game.step``'s ``active``: the bodies move, the shuttle is held). A step
in which the shuttle comes near a box is judged by ``Game._judge`` (the hits, the net, the
landing), so the rules of play stay written once. What is restated here, once each, and held
to the lanes code's bits by ``tests/test_one_game.py``: the motion of a free or held step
(``SimpleBodies.step_lanes``, ``PaperShuttle.fly``, ``Game._observe``, ``Game._shape``, the
floor, net and face tests of ``Game._apart``, and ``Game._step_lanes``'s holding of a shuttle
out of play) in ``_free_steps_with``; and the player's scaled observation
(``simple_obs.raw_observation_lanes`` with ``ScalarOps.observations``) in
``_observation_with``, which runs compiled only.

That function runs as Python, or compiled by Numba (on Linux, where MuJoCo's
library is ``libmujoco.so``) where the compiled sine and cosine give NumPy's float64 bits (NumPy's
own SIMD versions, used on some CPUs, may differ from the C library's in the last bit): compiled,
MuJoCo's ``mj_step`` is called from the loop directly, with no Python between physics steps.
``rallysim.core.native.KERNEL`` (or the environment variable ``RALLYSIM_KERNEL``: ``auto``,
``python``, ``compiled``) chooses; ``auto`` takes the compiled kernel where it can be had and
Python elsewhere, with the same results. ``tests/test_one_game.py`` holds both, the lanes code
and a batch's env 0 bit-identical state by state.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import mujoco
import numpy as np

from rallysim.core import native, rules
from rallysim.core.bodies import SimpleBodies
from rallysim.core.lanes import SCALARS
from rallysim.core.shuttle import GRAVITY, PaperShuttle


def paper_flight(px: float, py: float, pz: float, vx: float, vy: float, vz: float,
                 shot_time: float, fall: float, f: float, dt: float) -> tuple:
    """``PaperShuttle.fly`` of one shuttle on local numbers (``fall``: gravity * dt, ``f``: the
    damping factor): the new position, velocity and shot time."""
    vz -= fall
    vx *= f
    vy *= f
    vz *= f
    return px + vx * dt, py + vy * dt, pz + vz * dt, vx, vy, vz, shot_time + dt


def approach_counts(gap: float, moved: bool, todo: bool, good: int, bad: int, old_gap: float
                    ) -> tuple[int, int, float]:
    """``Game._shape`` of one live game on local numbers (``todo``: the player has not hit
    yet): the approach counts and the gap to keep."""
    closer = moved & (gap < old_gap) & todo
    return good + closer, bad + (todo ^ closer), gap


def load_game(motion: Any, q: Any, shot_time_a: Any, gap_a: Any, good_a: Any, bad_a: Any,
              has_hit_a: Any) -> tuple:
    """One live game's moving numbers from its arrays (``Game.lane_views``): the shuttle's
    position and velocity, its point in the face's frame, the shot time, the shaping's gap and
    counts, and whether the player has yet to hit (``_shape``'s todo)."""
    return (float(motion[0, 0]), float(motion[1, 0]), float(motion[2, 0]), float(motion[3, 0]),
            float(motion[4, 0]), float(motion[5, 0]), float(q[0, 0, 0]), float(q[0, 0, 1]),
            float(q[0, 0, 2]), shot_time_a.item(), gap_a.item(), good_a.item(), bad_a.item(),
            not has_hit_a.item())


def store_game(motion: Any, q: Any, shot_time_a: Any, gap_a: Any, good_a: Any, bad_a: Any,
               px: float, py: float, pz: float, vx: float, vy: float, vz: float, qx: float,
               qy: float, qz: float, shot_time: float, gap: float, good: int, bad: int) -> None:
    """``load_game``'s numbers (but todo) back to the arrays."""
    motion[0, 0], motion[1, 0], motion[2, 0] = px, py, pz
    motion[3, 0], motion[4, 0], motion[5, 0] = vx, vy, vz
    q[0, 0, 0], q[0, 0, 1], q[0, 0, 2] = qx, qy, qz
    shot_time_a[0], gap_a[0, 0] = shot_time, gap
    good_a[0, 0], bad_a[0, 0] = good, bad


# what the free steps of every kind of player do alike (``compiled_helpers``: compiled)
HELPERS = (paper_flight, approach_counts, load_game, store_game)


def _free_steps_with(mj_step: Callable, sin: Callable, cos: Callable, step_apart: Callable,
                     fly: Callable = paper_flight, shape: Callable = approach_counts,
                     load: Callable = load_game, store: Callable = store_game) -> Callable:
    """The free physics steps of one game, calling these functions (the Python ones, or their
    compiled counterparts: the source is the same; ``step_apart``: ``rules.step_apart``, the
    box test of ``Game._apart``; the rest ``HELPERS``, which one HUMAN-LIKE game's steps call
    too).

    ``free_steps(model, data, <the state's arrays>, k, steps, shaping, live)`` runs up to
    ``steps`` steps from and to the arrays until one needs judging; ``k`` holds
    ``OneSimpleGame``'s constants. Returns the steps run, whether the last needs judging, and
    the points the box test of that step started from (the face's frame, the world). A game
    out of play (``live`` False: ``Game._step_lanes``'s held game) runs all ``steps``: the
    bodies move, the shuttle keeps its position and velocity (its shot time runs on), nothing
    is judged and nothing counts toward the shaping (its gap is kept up)."""

    def free_steps(model, data, torque, mocap, theta_a, omega_a, base_x_a, theta0_a, moved_a,
                   base_step_a, target_a, neg_limit_a, torque_limit_a, motion, q, shot_time_a,
                   gap_a, good_a, bad_a, has_hit_a, k, steps, shaping, live):
        lo, hi, inv_dt, rate, drive, limit = k[0], k[1], k[2], k[3], k[4], k[5]
        fo, pivot_z, dt, fall, f, fwd, top = k[6], k[7], k[8], k[9], k[10], k[11], k[12]
        net_lo, net_hi = (k[13], k[14], k[15]), (k[16], k[17], k[18])
        face_lo, face_hi = (k[19], k[20], k[21]), (k[22], k[23], k[24])
        base_step, target = base_step_a.item(), target_a.item()
        neg_limit, torque_limit = neg_limit_a.item(), torque_limit_a.item()
        base_x, theta, omega = base_x_a.item(), theta_a.item(), omega_a.item()
        px, py, pz, vx, vy, vz, qx, qy, qz, shot_time, gap, good, bad, todo = load(
            motion, q, shot_time_a, gap_a, good_a, bad_a, has_hit_a)
        todo = todo and live
        held = (px, py, pz, vx, vy, vz)
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
            px, py, pz, vx, vy, vz, shot_time = fly(px, py, pz, vx, vy, vz, shot_time, fall, f, dt)
            if not live:
                px, py, pz, vx, vy, vz = held
            # Game._observe and SimpleBodies.face_frame (the game's fwd is the bodies')
            ox = fwd * px
            s, c = sin(theta), cos(theta)
            dx = ox - base_x - fo * s
            dz = pz - pivot_z - fo * c
            qx, qy, qz = dx * c - dz * s, fwd * py, dx * s + dz * c
            if shaping:
                good, bad, gap = shape(abs(ox - base_x), moved, todo, good, bad, gap)
            face, world = (qx, qy, qz), (px, py, pz)
            if live and not step_apart(face0, face, world0, world, top, net_lo, net_hi,
                                       face_lo, face_hi):
                judged = True
                break
        base_x_a[0, 0], theta0_a[0, 0], moved_a[0, 0] = base_x, theta0, moved
        store(motion, q, shot_time_a, gap_a, good_a, bad_a, px, py, pz, vx, vy, vz, qx, qy, qz,
              shot_time, gap, good, bad)
        return run, judged, face0, world0

    return free_steps


def _observation_with(sin: Callable, cos: Callable) -> Callable:
    """One SIMPLE player's scaled observation, calling these sine and cosine: the 16 values
    of ``simple_obs.raw_observation_lanes`` for one game, then the values of ``extra``, each
    mapped by ``ScalarOps.observations`` ((x - centre) / scale, clipped into [-1, 1] as
    ``np.clip`` clips: NaN stays NaN) and given as float32, (1, 16 + len(extra)). ``k`` holds
    ``OneSimpleGame``'s observation constants: the player's fwd, base height and face
    offset."""

    def observation(theta_a, omega_a, base_x_a, motion, extra, k, centre, scale):
        fwd, base_z, fo = k[0], k[1], k[2]
        theta, omega = theta_a[0, 0], omega_a[0, 0]
        s, c = sin(theta), cos(theta)
        half = 0.5 * theta
        raw = np.empty(16 + extra.size)
        if centre.size != raw.size or scale.size != raw.size:
            raise ValueError("the observation's maps must have one entry per value")
        raw[0], raw[1], raw[2] = base_x_a[0, 0], 0.0, base_z
        raw[3], raw[4], raw[5], raw[6] = cos(half), 0.0, sin(half), 0.0
        raw[7], raw[8], raw[9] = fo * omega * c, 0.0, -fo * omega * s
        raw[10], raw[11], raw[12] = fwd * motion[0, 0], fwd * motion[1, 0], motion[2, 0]
        raw[13], raw[14], raw[15] = fwd * motion[3, 0], fwd * motion[4, 0], motion[5, 0]
        for i in range(extra.size):
            raw[16 + i] = extra[i]
        out = np.empty((1, raw.size), np.float32)
        for i in range(raw.size):
            x = (raw[i] - centre[i]) / scale[i]
            if x < -1.0:
                x = -1.0
            if x > 1.0:
                x = 1.0
            out[0, i] = x
        return out

    return observation


PYTHON_FREE_STEPS = _free_steps_with(mujoco.mj_step, SCALARS.sin, SCALARS.cos, rules.step_apart)
# this process's compiled kernels, made on first use (``compiled_free_steps``)
Compiled = native.Kernel(lambda: _compile())


class Kernels(NamedTuple):
    """The compiled functions of one SIMPLE game."""

    free_steps: Callable  # ``_free_steps_with``'s
    observation: Callable  # ``_observation_with``'s


def compiled_free_steps() -> Callable | None:
    """The compiled kernel, or None where it cannot be had (``Compiled.why_not`` says why)."""
    return _free_steps_of(Compiled.get())


def _free_steps_of(kernels: Kernels | None) -> Callable | None:
    return None if kernels is None else kernels.free_steps


def _compile() -> Kernels:
    """``_free_steps_with`` compiled by Numba, calling MuJoCo's C ``mj_step`` with the model's
    and data's addresses, and ``_observation_with``; ``native.Unavailable`` where Numba or
    MuJoCo's library is missing, or where the compiled sine or cosine differ from NumPy's on a
    probe of angles (then the compiled steps would not replay a batch bit for bit). Where
    either fails to compile, neither runs: the Python code does, with the same results."""
    numba = native.numba_module()
    (step,) = native.mujoco_functions("mj_step")
    sin = numba.njit(lambda x: np.sin(x))
    cos = numba.njit(lambda x: np.cos(x))

    @native.jit  # (cached, as the kernels: the probe runs in every process)
    def sines(angles):
        out = np.empty((2, angles.size))
        for i in range(angles.size):
            out[0, i], out[1, i] = sin(angles[i]), cos(angles[i])
        return out

    # whole turns of the arm, densely, then angles well beyond its stops
    angles = np.concatenate([np.linspace(-4.0, 4.0, 200_001),
                             np.random.default_rng(0).uniform(-40.0, 40.0, 100_000)])
    if sines(angles).tobytes() != np.stack([np.sin(angles), np.cos(angles)]).tobytes():
        raise native.Unavailable("Numba's sine or cosine differ from NumPy's on this machine")
    step_apart = numba.njit(rules.step_apart_with(numba.njit(rules.apart)))
    free_steps = native.jit(_free_steps_with(step, sin, cos, step_apart, *compiled_helpers()))
    # (NumPy's error model: a zero scale gives inf or NaN, as the lanes code's arrays do)
    observation = native.jit(_observation_with(sin, cos), error_model="numpy")
    _dry_run(free_steps, observation)
    return Kernels(free_steps, observation)


def compiled_helpers() -> tuple[Callable, ...]:
    """``HELPERS`` compiled (the compiled kernels call them)."""
    numba = native.numba_module()
    return tuple(numba.njit(helper) for helper in HELPERS)


def _dry_run(free_steps: Callable, observation: Callable) -> None:
    """Compile the kernels now, for arrays of the types a game's are (the observation's maps
    read-only, as the tasks' are), by calls that run no physics step (so a failure shows
    here, where the Python kernel can take over)."""
    f, b, i = np.zeros((1, 1)), np.zeros((1, 1), bool), np.zeros((1, 1), np.int64)
    free_steps(0, 0, f, np.zeros((1, 1, 3)), f, f, f, f, b, f, f, f, f, np.zeros((6, 1)),
               np.zeros((1, 3, 3)), np.zeros(1), f, i, i, b, np.zeros(25), 0, True, True)
    maps = np.ones(17)
    maps.flags.writeable = False
    observation(f, f, f, np.zeros((6, 1)), np.zeros(1), np.zeros(3), maps, maps)


class OneGame:
    """What the fused physics steps of one game share, whatever its player: ``run`` hands a
    step that needs judging to ``Game._judge``; a subclass runs the free steps between
    (``_steps``) and may run the steps out of play (``_held_steps``; by default the lanes
    code's, ``Game._run_lanes``)."""

    def run(self, game: Any, steps: int) -> None:
        """``steps`` physics steps of ``game``, from and to its arrays."""
        state, active = game.state, game._active
        done = 0
        while done < steps:
            if not (state.in_play.item() and active.item()):
                self._held_steps(game, steps - done)  # the rest of the decision
                return
            done += self._free_steps(game, steps - done)

    def _held_steps(self, game: Any, steps: int) -> None:
        """``steps`` steps of a game out of play (until its next reset): the lanes code's."""
        game._run_lanes(steps)

    def _free_steps(self, game: Any, steps: int) -> int:
        """Up to ``steps`` steps of a live game, until one needs judging (judged here too);
        the number of steps run."""
        run, judged, face0, world0 = self._steps(game, steps)
        if judged:
            g = game._lanes(SCALARS)
            game._judge(g, SCALARS, (face0, world0), True)
            game._store(g)
        return run

    def _steps(self, game: Any, steps: int) -> tuple[int, bool, tuple, tuple]:
        """The kernel's free steps of a game in play: the steps run, whether the last needs
        judging, and the points its box test started from (the face's frame, the world)."""
        raise NotImplementedError

    def kernel_in(self, game: Any) -> str:
        """What runs ``game``'s physics steps in this process: "compiled" or "python"."""
        raise NotImplementedError


class OneSimpleGame(OneGame):
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
        kernel = native.checked_kernel_name(kernel)
        # the name asked for, resolved in each process at its first observation or step
        # (compiling takes seconds: not where a game is only made): a copy taken elsewhere
        # (pickle) runs the compiled kernel where it can be had there
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
        self.observation_k = np.array([self.k[11], b.base_z, b.face_offset])

    def _free_steps_function(self) -> Callable | None:
        """The compiled kernel if it runs here, else None (Python); ``RuntimeError`` where the
        compiled one was asked for and cannot be had."""
        return _free_steps_of(Compiled.resolve(self.asked))

    def observation(self, game: Any, extra: np.ndarray, centre: np.ndarray,
                    scale: np.ndarray) -> np.ndarray | None:
        """The player's observation followed by the values ``extra`` (E,), scaled and clipped
        (``_observation_with``), where the compiled kernel runs; None where Python does (the
        caller's lanes code gives the same bits)."""
        kernels = Compiled.resolve(self.asked)
        if kernels is None:
            return None
        b = game.bodies
        return kernels.observation(b.theta, b.omega, b.base_x, game.shuttle.motion, extra,
                                   self.observation_k, centre, scale)

    @property
    def kernel(self) -> str:
        """The kernel that runs in this process: "compiled" or "python"."""
        return "python" if self._free_steps_function() is None else "compiled"

    def kernel_in(self, game: Any) -> str:
        return self.kernel

    def _held_steps(self, game: Any, steps: int) -> None:
        """``steps`` steps out of play, in the kernel (``_free_steps_with``'s ``live``)."""
        self._steps(game, steps, False)

    def _steps(self, game: Any, steps: int, live: bool = True
               ) -> tuple[int, bool, tuple, tuple]:
        b, sh, ev = game.bodies, game.shuttle, game.events
        free_steps = self._free_steps_function()
        if free_steps is None:
            free_steps, k, model, data = PYTHON_FREE_STEPS, self.k, b.model, b.data
        else:
            k, model, data = self.k_array, b.model._address, b.data._address
        return free_steps(
            model, data, b.torque, b.mocap, b.theta, b.omega, b.base_x, b._theta0,
            b.base_moved, b._base_step, b.target, b._neg_limit, b.torque_limit, sh.motion,
            game._q, sh.shot_time, game._gap, ev.approach_good, ev.approach_bad,
            game.state.has_hit, k, steps, game.shaping, live)
