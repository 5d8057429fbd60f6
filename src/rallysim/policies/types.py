"""The shapes of policies, named once for every module that takes or returns one."""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Protocol

import numpy as np

if TYPE_CHECKING:
    from rallysim.players.spec import PlayerSpec

Policy = Callable[[np.ndarray], np.ndarray]
"""(M, observation) -> (M, action): a low-level task's policy or a Monolithic player."""

LowLevel = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""(rally observations (M, obs), goals (M, *goal)) -> actions (M, action): a rally's low level."""

HighLevel = Callable[[np.ndarray], np.ndarray]
"""(M, observation) -> (M, *goal) goals: a rally's high level."""


class Agent(Protocol):
    """One side of N batched competitive games (``rallysim.eval.agents``), acting every
    decision."""

    name: str
    player: PlayerSpec  # the kind of player it acts for (both sides of a game are one kind)

    def start(self, n: int) -> None:
        """Fresh state for ``n`` games."""

    def act(self, obs: np.ndarray, started: np.ndarray, rows: np.ndarray) -> np.ndarray:
        """Actions (M, action) for games ``rows`` (M,), given this side's observations (M, obs)
        and whether its turn began at this decision (M,)."""
