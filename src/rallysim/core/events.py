"""What happened during one decision: ``Game.step`` returns a new ``Events`` every call."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass
class Events:
    """What happened during one decision, per environment (and per player where it says P).

    Each ``Game.step`` returns a new one that the game never writes again, so a caller may
    keep it, or hand its arrays on, without copying."""

    hit: np.ndarray  # (N, P) bool: the player hit the shuttle
    hit_speed: np.ndarray  # (N, P) racket face speed at the hit, m/s
    hit_point: np.ndarray  # (N, P, 3) world position of the shuttle at the hit
    hit_velocity: np.ndarray  # (N, P, 3) racket velocity at the hit, hitter's own frame; NaN
    net_touch: np.ndarray  # (N,) bool: first net touch since the last shot
    landed: np.ndarray  # (N,) bool: the shuttle's centre dropped below z = 0
    land_point: np.ndarray  # (N, 3) world landing point
    land_side: np.ndarray  # (N,) int: the player whose half it landed in
    land_in: np.ndarray  # (N,) bool: inside that half's court (paper trigger box or full half)

    @classmethod
    def empty(cls, n: int, p: int) -> Events:
        """No events in N games of P players (``hit_velocity`` NaN, everything else 0)."""
        return cls(
            hit=np.zeros((n, p), bool), hit_speed=np.zeros((n, p)), hit_point=np.zeros((n, p, 3)),
            hit_velocity=np.full((n, p, 3), np.nan), net_touch=np.zeros(n, bool),
            landed=np.zeros(n, bool), land_point=np.zeros((n, 3)),
            land_side=np.zeros(n, np.int64), land_in=np.zeros(n, bool),
        )

    def copy(self) -> Events:
        """A copy sharing no array (written out: this runs every decision)."""
        return Events(self.hit.copy(), self.hit_speed.copy(), self.hit_point.copy(),
                      self.hit_velocity.copy(), self.net_touch.copy(), self.landed.copy(),
                      self.land_point.copy(), self.land_side.copy(), self.land_in.copy())


class EventRows:
    """Hands out a new ``Events`` (no events yet) for each decision of N games of P players.

    For small batches they are rows of blocks made ``rows`` decisions at a time: taking a row
    of a block is cheaper than allocating a small array, and a single game takes 9 arrays per
    decision. Rows never handed out twice, so no two ``Events`` share memory. Larger batches
    copy a blank ``Events`` instead (their blocks would be large; the copy's cost is small next
    to the rest of their decision)."""

    block_bytes = 1 << 12  # the most one block of one field (of all fields: x 9) may hold
    min_rows = 8  # fewer rows per block: copy instead

    def __init__(self, n: int, p: int) -> None:
        self._blank = Events.empty(n, p)
        largest = max(a.nbytes for a in vars(self._blank).values())
        self.rows = self.block_bytes // largest
        self._blocks: list[tuple[np.ndarray, ...]] = []  # one decision's arrays each
        self._next = self.rows  # no block yet

    def __getstate__(self) -> dict[str, Any]:
        # a copy makes blocks of its own (rows left in a block hold no events)
        return {**self.__dict__, "_blocks": [], "_next": self.rows}

    def take(self) -> Events:
        """A new ``Events`` with no events (zeros; ``hit_velocity`` NaN)."""
        if self.rows < self.min_rows:
            return self._blank.copy()
        if self._next == self.rows:
            blocks = [np.repeat(a[None], self.rows, axis=0) for a in vars(self._blank).values()]
            # each decision's arrays, as rows of the blocks, made at once
            self._blocks = list(zip(*(list(block) for block in blocks), strict=True))
            self._next = 0
        i = self._next
        self._next = i + 1
        return Events(*self._blocks[i])
