"""Shuttle flight models (docs/reference.md §4), batched over N shuttles and advanced in place.

Every model is selected by name (``SHUTTLE_MODELS``). Positions and velocities are world-frame
arrays of shape (N, 3); the models own no state beyond what ``ShuttleState`` holds. The flight
of every model is written once (``fly``), compiled: the game's steps inline it
(``rallysim.core.kernels.step``), and ``ShuttleModel.advance`` runs it on its own.
"""

from __future__ import annotations

import functools
import math
from collections.abc import Callable
from typing import Any

import numpy as np

from rallysim.core import native

GRAVITY = 9.81
RADIUS = 0.1  # the original's overlap sphere; all models judge hits, net and floor with it
# the flight models' codes (``code``, the constants' ``flight``)
PAPER, PAPER_ALG1, AERO = 0, 1, 2


class ShuttleState:
    """Batched shuttle state. ``shot_speed``/``shot_time`` serve the paper's Algorithm 1.

    Position and velocity (copied in) are stored component-major in ``motion`` (6, N): rows x,
    y, z, vx, vy, vz, each a contiguous row for the compiled steps and the tasks (NumPy takes a
    slower, general path on the columns of an (N, 3) array). ``pos`` and ``vel`` are (N, 3)
    views of it."""

    def __init__(self, pos: np.ndarray, vel: np.ndarray, shot_speed: np.ndarray,
                 shot_time: np.ndarray) -> None:
        self.motion = np.empty((6, len(pos)))
        self.motion[:3] = np.asarray(pos, dtype=np.float64).T
        self.motion[3:] = np.asarray(vel, dtype=np.float64).T
        self.shot_speed = shot_speed  # (N,) speed at the last serve or hit
        self.shot_time = shot_time  # (N,) seconds since the last serve or hit

    @property
    def pos(self) -> np.ndarray:
        """(N, 3) world positions (a view: writes move the shuttles)."""
        return self.motion[:3].T

    @property
    def vel(self) -> np.ndarray:
        """(N, 3) world velocities (a view)."""
        return self.motion[3:].T

    @classmethod
    def zeros(cls, n: int) -> ShuttleState:
        return cls(np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n), np.zeros(n))


class ShuttleModel:
    """A flight model: its numbers for ``fly``."""

    name: str = ""
    code: int = -1  # PAPER, PAPER_ALG1 or AERO
    net_blocks: bool = False  # True: the net stops the shuttle; False: a net touch is only noted
    full_court: bool = False  # True: in/out on the full half court; False: the original trigger box

    def numbers(self, dt: float) -> dict[str, float]:
        """The flight's constants (``FLIGHT_FIELDS``) for steps of ``dt`` seconds."""
        return dict(dt=dt, fall=GRAVITY * dt, factor=float(getattr(self, "factor", 0.0)),
                    flight=self.code, window=PaperAlg1Shuttle.window,
                    aero_k=float(getattr(self, "k", 0.0)),
                    max_decay=AeroShuttle.max_decay_per_substep, half_gravity=0.5 * GRAVITY)

    def advance(self, s: ShuttleState, dt: float) -> None:
        """Advance the shuttles of ``s`` by ``dt`` seconds, in place (``fly``)."""
        record = _flight_record(tuple(self.numbers(dt).items()))
        _compiled_advance()(s.motion, s.shot_time, s.shot_speed, record)

    def terminal_speed(self) -> float:
        raise NotImplementedError


class PaperShuttle(ShuttleModel):
    """The original builds' flight (docs/reference.md §4.1), per step:
    v <- (v + g dt)(1 - c dt); p <- p + v dt."""

    name = "paper"
    code = PAPER
    linear_damping = 1.5  # 1/s: Unity's drag, giving the factor 0.97 per 0.02 s step

    def __init__(self, dt: float = 0.02) -> None:
        self.dt = dt
        self.factor = 1.0 - self.linear_damping * dt

    def terminal_speed(self) -> float:
        # fixed point of v = (v + g dt) f  ->  v = f g dt / (1 - f)
        return self.factor * GRAVITY * self.dt / (1.0 - self.factor)


class PaperAlg1Shuttle(PaperShuttle):
    """The paper's Algorithm 1 on top of the paper flight: for 0.6 s after each serve or hit
    the speed is forced to s0 (1 - t), direction kept; its timer restarts at every shot."""

    name = "paper-alg1"
    code = PAPER_ALG1
    window = 0.6



class AeroShuttle(ShuttleModel):
    """A real shuttlecock (docs/reference.md §4.2): quadratic drag a = -k |v| v with k = g / v_t^2
    and a 6.7 m/s terminal speed; the net blocks it; in/out is judged on the full half court.

    Each sub-step splits gravity around an exact drag step (pure quadratic drag solves to
    v / (1 + k |v| h)), which is stable at any speed and lands on the terminal speed to 1e-3;
    sub-steps are short enough that k |v| h <= 0.1, so a 100 m/s smash decays accurately."""

    name = "aero"
    code = AERO
    net_blocks = True
    full_court = True
    v_terminal = 6.7
    max_decay_per_substep = 0.1

    def __init__(self, dt: float = 0.02) -> None:
        self.k = GRAVITY / self.v_terminal**2

    def terminal_speed(self) -> float:
        return self.v_terminal


# the constants ``fly`` reads, by name from a record (``GameConstants`` has them too)
FLIGHT_FIELDS = ("dt", "fall", "factor", "flight", "window", "aero_k", "max_decay",
                 "half_gravity")
FLIGHT_DTYPE = np.dtype([(name, np.int64 if name == "flight" else np.float64)
                         for name in FLIGHT_FIELDS])


def substeps(m: np.ndarray, k: Any, n: int) -> int:
    """aero's sub-steps this step: from the fastest of the ``n`` shuttles (``m``: their
    motion, (6, N)), held ones too; 1 for the other models. |v|^2 is summed in the order of
    ``np.einsum("ij,ij->i", v, v)`` (x, z, then y), which the recorded episodes used."""
    if k.flight != AERO:
        return 1
    largest = 0.0
    for e in range(n):
        vx, vy, vz = m[3, e], m[4, e], m[5, e]
        s = (vx * vx + vz * vz) + vy * vy
        if e == 0 or s > largest or s != s:
            largest = s
    count = math.ceil(k.aero_k * math.sqrt(largest) * k.dt / k.max_decay)
    return max(1, count)


def fly(px: float, py: float, pz: float, vx: float, vy: float, vz: float, shot_time: float,
        shot_speed: float, k: Any, count: int) -> tuple:
    """A shuttle at (px, py, pz) moving at (vx, vy, vz) through one step of ``k.dt`` seconds:
    the paper flight (docs/reference.md §4.1: v <- (v + g dt)(1 - c dt); p <- p + v dt), with
    Algorithm 1's speed s0 (1 - t) in its window (paper-alg1), or aero's ``count`` sub-steps
    (docs/reference.md §4.2: gravity split around an exact drag step). Returns the new
    position, velocity and shot time (numbers in, numbers out: compiled and inlined, this
    passes no array)."""
    dt = k.dt
    if k.flight == AERO:
        h = dt / count
        half = k.half_gravity * h
        for _ in range(count):
            vz -= half
            d = 1.0 + h * k.aero_k * math.sqrt((vx * vx + vz * vz) + vy * vy)
            vx /= d
            vy /= d
            vz /= d
            vz -= half
            px += vx * h
            py += vy * h
            pz += vz * h
        shot_time = shot_time + dt
    else:
        vz -= k.fall
        f = k.factor
        vx *= f
        vy *= f
        vz *= f
        px += vx * dt
        py += vy * dt
        pz += vz * dt
        shot_time = shot_time + dt
        if k.flight == PAPER_ALG1 and shot_time < k.window:
            # the speed forced to s0 (1 - t), direction kept (np.linalg.norm's sum)
            speed = math.sqrt((vx * vx + vy * vy) + vz * vz)
            target = shot_speed * (1.0 - shot_time)
            r = target / speed if speed > 0 else 0.0
            vx *= r
            vy *= r
            vz *= r
    return px, py, pz, vx, vy, vz, shot_time


def flight_with(njit: Callable) -> tuple[Callable, Callable]:
    """``substeps`` and ``fly`` compiled by ``njit``, to be inlined where they are called."""
    inline = njit(inline="always")
    return inline(substeps), inline(fly)


def _advance_with(njit: Callable) -> Callable:
    count_of, fly_one = flight_with(njit)

    def advance(m, shot_time, shot_speed, record):
        k = record[0]
        n = m.shape[1]
        count = count_of(m, k, n)
        for e in range(n):
            (m[0, e], m[1, e], m[2, e], m[3, e], m[4, e], m[5, e], shot_time[e]) = fly_one(
                m[0, e], m[1, e], m[2, e], m[3, e], m[4, e], m[5, e], shot_time[e],
                shot_speed[e], k, count)

    return advance


@functools.cache
def _flight_record(numbers: tuple) -> np.ndarray:
    """The compiled flight's record of ``numbers`` ((name, value) pairs), made once: planners
    advance their predictions a step at a time."""
    record = np.zeros(1, FLIGHT_DTYPE)
    for name, value in numbers:
        record[name] = value
    return record


@functools.cache
def _compiled_advance() -> Callable:
    return native.jit(_advance_with(native.numba_module().njit), error_model="numpy")


SHUTTLE_MODELS: dict[str, type[ShuttleModel]] = {
    cls.name: cls for cls in (PaperShuttle, PaperAlg1Shuttle, AeroShuttle)
}


def check_shuttle_name(name: Any) -> str:
    """``name`` if it names a flight model; else a ``ValueError`` listing the valid names."""
    if not isinstance(name, str) or name not in SHUTTLE_MODELS:
        valid = ", ".join(repr(k) for k in SHUTTLE_MODELS)
        raise ValueError(f"unknown shuttle model {name!r}; valid models: {valid}")
    return name


def make_shuttle_model(name: str, dt: float = 0.02) -> ShuttleModel:
    """The flight model called ``name``; a clear error lists the valid names."""
    return SHUTTLE_MODELS[check_shuttle_name(name)](dt)
