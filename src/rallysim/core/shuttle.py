"""Shuttle flight models (docs/reference.md §4), batched over N shuttles and advanced in place.

Every model is selected by name (``SHUTTLE_MODELS``). Positions and velocities are world-frame
arrays of shape (N, 3); the models own no state beyond what ``ShuttleState`` holds.
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import numpy as np

from rallysim.core.lanes import ARRAYS, Ops

GRAVITY = 9.81
RADIUS = 0.1  # the original's overlap sphere; all models judge hits, net and floor with it


class ShuttleState:
    """Batched shuttle state. ``shot_speed``/``shot_time`` serve the paper's Algorithm 1.

    Position and velocity (copied in) are stored component-major in ``motion`` (6, N): rows x,
    y, z, vx, vy, vz, so that the rule code's lanes (``rallysim.core.lanes``) are contiguous
    rows (NumPy takes a slower, general path on the columns of an (N, 3) array). ``pos`` and
    ``vel`` are (N, 3) views of it."""

    def __init__(self, pos: np.ndarray, vel: np.ndarray, shot_speed: np.ndarray,
                 shot_time: np.ndarray) -> None:
        self.motion = np.empty((6, len(pos)))
        self.motion[:3] = np.asarray(pos, dtype=np.float64).T
        self.motion[3:] = np.asarray(vel, dtype=np.float64).T
        self.shot_speed = shot_speed  # (N,) speed at the last serve or hit
        self.shot_time = shot_time  # (N,) seconds since the last serve or hit
        self._lanes: SimpleNamespace | None = None  # made by lanes()

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_lanes": None}  # a copy makes views of its own arrays

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

    def shot(self, mask: np.ndarray) -> None:
        """Record a serve or hit for the shuttles in ``mask`` (after their velocity was set)."""
        v = self.vel[mask]
        # np.linalg.norm(v, axis=1)'s own operations, without its checks (this runs per serve)
        self.shot_speed[mask] = np.sqrt(np.add.reduce(v * v, axis=1))
        self.shot_time[mask] = 0.0

    def vectors(self) -> tuple[np.ndarray, np.ndarray]:
        """The position and velocity as vector lanes (``rallysim.core.lanes``): (3, N, 1) views
        of ``motion``."""
        return self.motion[:3, :, None], self.motion[3:, :, None]

    def lanes(self) -> SimpleNamespace:
        """Array lanes (``rallysim.core.lanes``) of this state for ``ShuttleModel.fly``: pos, vel,
        shot_speed, shot_time (views, made once). A plain namespace: flight models change lanes
        in place only, so no write-through is needed."""
        if self._lanes is None:
            pos, vel = self.vectors()
            self._lanes = SimpleNamespace(pos=pos, vel=vel, shot_speed=self.shot_speed[:, None],
                                          shot_time=self.shot_time[:, None])
        return self._lanes


class ShuttleModel:
    """A flight model. Subclasses implement ``fly``."""

    name: str = ""
    net_blocks: bool = False  # True: the net stops the shuttle; False: a net touch is only noted
    full_court: bool = False  # True: in/out on the full half court; False: the original trigger box

    def advance(self, s: ShuttleState, dt: float) -> None:
        """Advance the shuttles of ``s`` by ``dt`` seconds, in place."""
        self.fly(s.lanes(), dt, ARRAYS)

    def fly(self, g: Any, dt: float, ops: Ops) -> None:
        """``advance`` on lanes ``g`` (vectors ``pos`` and ``vel``, ``shot_speed``,
        ``shot_time``), which it changes in place only (``ShuttleState.lanes``)."""
        raise NotImplementedError

    def terminal_speed(self) -> float:
        raise NotImplementedError


class PaperShuttle(ShuttleModel):
    """The original builds' flight (docs/reference.md §4.1), per step:
    v <- (v + g dt)(1 - c dt); p <- p + v dt."""

    name = "paper"
    linear_damping = 1.5  # 1/s: Unity's drag, giving the factor 0.97 per 0.02 s step

    def __init__(self, dt: float = 0.02) -> None:
        self.dt = dt
        self.factor = 1.0 - self.linear_damping * dt

    def fly(self, g: Any, dt: float, ops: Ops) -> None:
        v = g.vel
        v[2] -= GRAVITY * dt
        ops.scale(v, self.factor)
        ops.axpy(g.pos, v, dt)
        g.shot_time += dt

    def terminal_speed(self) -> float:
        # fixed point of v = (v + g dt) f  ->  v = f g dt / (1 - f)
        return self.factor * GRAVITY * self.dt / (1.0 - self.factor)


class PaperAlg1Shuttle(PaperShuttle):
    """The paper's Algorithm 1 on top of the paper flight: for 0.6 s after each serve or hit
    the speed is forced to s0 (1 - t), direction kept; its timer restarts at every shot."""

    name = "paper-alg1"
    window = 0.6

    def fly(self, g: Any, dt: float, ops: Ops) -> None:
        super().fly(g, dt, ops)
        active = g.shot_time < self.window
        if ops.any(active):
            vx, vy, vz = g.vel
            speed = ops.sqrt((vx * vx + vy * vy) + vz * vz)  # np.linalg.norm's sum
            target = g.shot_speed * (1.0 - g.shot_time)
            ops.scale(g.vel, ops.where(active, ops.divide(target, speed), 1.0))


class AeroShuttle(ShuttleModel):
    """A real shuttlecock (docs/reference.md §4.2): quadratic drag a = -k |v| v with k = g / v_t^2
    and a 6.7 m/s terminal speed; the net blocks it; in/out is judged on the full half court.

    Each sub-step splits gravity around an exact drag step (pure quadratic drag solves to
    v / (1 + k |v| h)), which is stable at any speed and lands on the terminal speed to 1e-3;
    sub-steps are short enough that k |v| h <= 0.1, so a 100 m/s smash decays accurately."""

    name = "aero"
    net_blocks = True
    full_court = True
    v_terminal = 6.7
    max_decay_per_substep = 0.1

    def __init__(self, dt: float = 0.02) -> None:
        self.k = GRAVITY / self.v_terminal**2

    def fly(self, g: Any, dt: float, ops: Ops) -> None:
        vmax = float(ops.sqrt(ops.largest(_speed_squared(g.vel))))
        n = max(1, math.ceil(self.k * vmax * dt / self.max_decay_per_substep))
        h = dt / n
        v = g.vel
        for _ in range(n):
            v[2] -= 0.5 * GRAVITY * h
            ops.shrink(v, 1.0 + h * self.k * ops.sqrt(_speed_squared(v)))
            v[2] -= 0.5 * GRAVITY * h
            ops.axpy(g.pos, v, h)
        g.shot_time += dt

    def terminal_speed(self) -> float:
        return self.v_terminal


def _speed_squared(v: Any) -> Any:
    """|v|^2 of a vector lane, summed in the order of ``np.einsum("ij,ij->i", v, v)`` (x, z,
    then y), which the recorded episodes were computed with."""
    vx, vy, vz = v
    return (vx * vx + vz * vz) + vy * vy


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
