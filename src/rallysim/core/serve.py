"""Serve strategies: how each rally's shuttle is put in flight.

A ``Game`` holds one (the machine serve of docs/reference.md §4.3 unless told otherwise) and asks
it once per ``Game.reset``; nothing overwrites the shuttle afterwards. A strategy draws its
uniforms from each served game's own random stream (``draw(k)``: k from each), so the order of
draws within a stream is part of its behaviour: every strategy here keeps the order of v0's
seeded episodes.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Protocol

import numpy as np

from rallysim.core import rules

# ``draw(m)``: (k, m) uniforms in [0, 1), the next m of each of the k served games' streams
Draw = Callable[[int], np.ndarray]


class Serve(Protocol):
    """``serve(draw, receiver)``: world positions and velocities, (k, 3) each, of the shuttles
    served toward ``receiver`` (k,) players, drawn from the k served games' streams (``draw``)."""

    def __call__(self, draw: Draw, receiver: np.ndarray) -> tuple[np.ndarray, np.ndarray]: ...


def _to_receiver(pos: np.ndarray, vel: np.ndarray, receiver: np.ndarray) -> None:
    """Turn shots given in player 0's frame into the receiver's (x and y change sign for
    player 1), in place."""
    turn = rules.FORWARD[receiver][:, None]
    pos[:, :2] *= turn
    vel[:, :2] *= turn


@dataclass(frozen=True)
class MachineServe:
    """docs/reference.md §4.3: the machine serve from the far side (``rules.sample_serve``), drawing
    ``rules.SERVE_DRAWS`` uniforms per game."""

    def __call__(self, draw: Draw, receiver: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return rules.sample_serve(draw(rules.SERVE_DRAWS), receiver)


# docs/reference.md §10: the HUMAN-LIKE serve, in the receiver's own frame.
HUMANLIKE_SERVE_X, HUMANLIKE_SERVE_Y, HUMANLIKE_SERVE_Z = (1.0, 6.0), (-1.0, 1.0), (1.0, 1.5)
HUMANLIKE_SERVE_LATERAL, HUMANLIKE_SERVE_RISE = (-0.5, 0.5), (2.0, 3.0)
HUMANLIKE_SERVE_TOWARD = 3.0
HUMANLIKE_SERVE_SPEED = 15.0
HUMANLIKE_SERVE_DRAWS = 5  # uniforms one HUMAN-LIKE serve uses


def sample_humanlike_serves(u: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """HUMAN-LIKE serves toward player 0 (world = its own frame) from uniforms ``u`` (n, 5):
    positions and velocities, (n, 3) each."""
    x, y, z = HUMANLIKE_SERVE_X, HUMANLIKE_SERVE_Y, HUMANLIKE_SERVE_Z
    lateral, rise = HUMANLIKE_SERVE_LATERAL, HUMANLIKE_SERVE_RISE
    pos = np.stack([x[0] + u[:, 0] * (x[1] - x[0]),
                    y[0] + u[:, 1] * (y[1] - y[0]),
                    z[0] + u[:, 2] * (z[1] - z[0])], axis=1)
    direction = np.stack([np.full(len(u), -HUMANLIKE_SERVE_TOWARD),
                          lateral[0] + u[:, 3] * (lateral[1] - lateral[0]),
                          rise[0] + u[:, 4] * (rise[1] - rise[0])], axis=1)
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    return pos, HUMANLIKE_SERVE_SPEED * direction


@dataclass(frozen=True)
class HumanLikeServe:
    """docs/reference.md §10: the HUMAN-LIKE serve (``sample_humanlike_serves``) toward the
    receiver.

    v0 drew the machine serve's ``rules.SERVE_DRAWS`` uniforms as well and then replaced that
    serve; to keep v0's seeded episodes this strategy still draws them, unused: ``unused_before``
    its own 5 (the rally, where the machine serve came first) or ``unused_after`` them (the
    low-level task, which drew its serve's uniforms before the machine serve's)."""

    unused_before: int = 0
    unused_after: int = 0

    def __call__(self, draw: Draw, receiver: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        first = self.unused_before
        u = draw(first + HUMANLIKE_SERVE_DRAWS + self.unused_after)
        pos, vel = sample_humanlike_serves(u[:, first:first + HUMANLIKE_SERVE_DRAWS])
        _to_receiver(pos, vel, receiver)
        return pos, vel


class FedShots:
    """The SIMPLE low-level task's fed shots: the machine serve, replaced by a recorded rally
    shot (``rallysim.assets.load_shot_bank``: 4,096 shots of scripted players aiming at 2-6 m)
    in a ``share`` of the games (1.0: always).

    Per game it draws the machine serve's uniforms, then 2: whether to replace it (the first
    below ``share``) and which shot (the second)."""

    def __init__(self, share: float) -> None:
        if not 0.0 < share <= 1.0:
            raise ValueError(f"share must lie in (0, 1], got {share!r}")
        self.share = share
        self._bank: np.ndarray | None = None  # loaded on the first serve

    def __call__(self, draw: Draw, receiver: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        pos, vel = MachineServe()(draw, receiver)
        u = draw(2)
        take = u[:, 0] < self.share  # (always, for a share of 1: u < 1)
        if take.any():
            bank = self.bank()
            rows = (u[take, 1] * len(bank)).astype(np.int64)
            shot_pos, shot_vel = bank[rows, :3].copy(), bank[rows, 3:].copy()
            _to_receiver(shot_pos, shot_vel, receiver[take])
            pos[take], vel[take] = shot_pos, shot_vel
        return pos, vel

    def bank(self) -> np.ndarray:
        """The recorded shots (n, 6): world position and velocity toward player 0."""
        if self._bank is None:
            from rallysim.assets import load_shot_bank

            self._bank = load_shot_bank()
        return self._bank


