"""The rally's state between physics steps: who may hit, who hit last, how many shots.

``RallyState`` is plain data (NumPy arrays over N games and P players); the rules that change it
are functions in ``rallysim.core.rules``, and ``Game`` holds one. Copies (``copy.deepcopy``,
``pickle``) are exact: every field is an array owned by the state.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

SERVE = -1  # ``last_hitter`` before anyone hit: the serve


@dataclass
class RallyState:
    """Per game (N,) or per player (N, P) rally state."""

    in_play: np.ndarray  # (N,) bool: the shuttle is flying (served and not landed)
    armed: np.ndarray  # (N, P) bool: the player's racket may hit the shuttle
    has_hit: np.ndarray  # (N, P) bool: the player hit since the serve
    last_hitter: np.ndarray  # (N,) int: the player who hit last, ``SERVE`` before a hit
    hits: np.ndarray  # (N,) int: hits since the serve (the rally's length)
    net_touched: np.ndarray  # (N,) bool: the shuttle touched the net since the last shot

    @classmethod
    def zeros(cls, n: int, p: int) -> RallyState:
        """N games of P players before their first serve: nothing in play."""
        return cls(in_play=np.zeros(n, bool), armed=np.zeros((n, p), bool),
                   has_hit=np.zeros((n, p), bool), last_hitter=np.full(n, SERVE),
                   hits=np.zeros(n, np.int64), net_touched=np.zeros(n, bool))
