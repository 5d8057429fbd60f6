"""Shuttle flight models (SPEC §4), batched over N shuttles and advanced in place.

Every model is selected by name (``SHUTTLE_MODELS``). Positions and velocities are world-frame
arrays of shape (N, 3); the models own no state beyond what ``ShuttleState`` holds.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

GRAVITY = 9.81
RADIUS = 0.1  # the original's overlap sphere; all models judge hits, net and floor with it


@dataclass
class ShuttleState:
    """Batched shuttle state. ``shot_speed``/``shot_time`` serve the paper's Algorithm 1."""

    pos: np.ndarray  # (N, 3)
    vel: np.ndarray  # (N, 3)
    shot_speed: np.ndarray  # (N,) speed at the last serve or hit
    shot_time: np.ndarray  # (N,) seconds since the last serve or hit

    @classmethod
    def zeros(cls, n: int) -> ShuttleState:
        return cls(np.zeros((n, 3)), np.zeros((n, 3)), np.zeros(n), np.zeros(n))

    def shot(self, mask: np.ndarray) -> None:
        """Record a serve or hit for the shuttles in ``mask`` (after their velocity was set)."""
        self.shot_speed[mask] = np.linalg.norm(self.vel[mask], axis=1)
        self.shot_time[mask] = 0.0


class ShuttleModel:
    """A flight model. Subclasses implement ``advance``."""

    name: str = ""
    net_blocks: bool = False  # True: the net stops the shuttle; False: a net touch is only noted
    full_court: bool = False  # True: in/out on the full half court; False: the original trigger box

    def advance(self, s: ShuttleState, dt: float) -> None:
        raise NotImplementedError

    def terminal_speed(self) -> float:
        raise NotImplementedError


class PaperShuttle(ShuttleModel):
    """The original builds' flight (SPEC §4.1), per step: v <- (v + g dt)(1 - c dt); p += v dt."""

    name = "paper"
    linear_damping = 1.5  # 1/s: Unity's drag, giving the factor 0.97 per 0.02 s step

    def __init__(self, dt: float = 0.02) -> None:
        self.dt = dt
        self.factor = 1.0 - self.linear_damping * dt

    def advance(self, s: ShuttleState, dt: float) -> None:
        s.vel[:, 2] -= GRAVITY * dt
        s.vel *= self.factor
        s.pos += s.vel * dt
        s.shot_time += dt

    def terminal_speed(self) -> float:
        # fixed point of v = (v + g dt) f  ->  v = f g dt / (1 - f)
        return self.factor * GRAVITY * self.dt / (1.0 - self.factor)


class PaperAlg1Shuttle(PaperShuttle):
    """The paper's Algorithm 1 on top of the paper flight: for 0.6 s after each serve or hit
    the speed is forced to s0 (1 - t), direction kept; its timer restarts at every shot."""

    name = "paper-alg1"
    window = 0.6

    def advance(self, s: ShuttleState, dt: float) -> None:
        super().advance(s, dt)
        active = s.shot_time < self.window
        if active.any():
            speed = np.linalg.norm(s.vel[active], axis=1)
            target = s.shot_speed[active] * (1.0 - s.shot_time[active])
            scale = np.divide(target, speed, out=np.zeros_like(speed), where=speed > 0)
            s.vel[active] *= scale[:, None]


class AeroShuttle(ShuttleModel):
    """A real shuttlecock (SPEC §4.2): quadratic drag a = -k |v| v with k = g / v_t^2 and a
    6.7 m/s terminal speed; the net blocks it; in/out is judged on the full half court.

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

    def advance(self, s: ShuttleState, dt: float) -> None:
        vmax = float(np.sqrt(np.max(np.einsum("ij,ij->i", s.vel, s.vel)))) if len(s.vel) else 0.0
        n = max(1, math.ceil(self.k * vmax * dt / self.max_decay_per_substep))
        h = dt / n
        for _ in range(n):
            s.vel[:, 2] -= 0.5 * GRAVITY * h
            speed = np.sqrt(np.einsum("ij,ij->i", s.vel, s.vel))
            s.vel /= (1.0 + h * self.k * speed)[:, None]
            s.vel[:, 2] -= 0.5 * GRAVITY * h
            s.pos += s.vel * h
        s.shot_time += dt

    def terminal_speed(self) -> float:
        return self.v_terminal


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
