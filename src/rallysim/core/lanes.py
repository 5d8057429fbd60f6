"""Two backends for the task code that runs every decision, written once over
*lanes*.

A lane is one quantity of the batch: a NumPy array over the N games (``ARRAYS``; shape (N, 1)
per game, (N, P) per player), or, for a batch of one game of one player, a Python number
(``SCALARS``). Each NumPy call has a fixed cost whatever the array's size, which at N = 1 is
nearly all of a decision's task code; Python floats do the same IEEE-754 double operations
without it. Both backends run the same expressions, so they give bit-identical results; exp
calls NumPy's in both.

``ops.where`` chooses (both branches are evaluated, so both must be safe everywhere);
``if ops.any(mask):`` skips work no lane needs. (The physics steps are compiled:
``rallysim.core.kernels``.)
"""

from __future__ import annotations

import operator
from typing import Any

import numpy as np


class ArrayOps:
    """NumPy over the batch."""

    scalar = False
    where = staticmethod(np.where)
    logical_not = staticmethod(np.logical_not)
    exp = staticmethod(np.exp)

    @staticmethod
    def any(a: np.ndarray) -> bool:
        # count_nonzero is a plain C loop; ndarray.any() goes through the ufunc reduction
        # machinery, slower on small arrays.
        return np.count_nonzero(a) > 0

    # -- between lanes and arrays -------------------------------------------------------------
    @staticmethod
    def read(a: np.ndarray) -> np.ndarray:
        """An array as a lane: itself (one game's: its one number)."""
        return a

    @staticmethod
    def read0(a: np.ndarray) -> np.ndarray:
        """Player 0's lane of an (N, P) array: its first column."""
        return a[:, 0]

    @staticmethod
    def columns(a: np.ndarray) -> list:
        """The lanes a[..., 0], a[..., 1], ... of an array's last axis."""
        return [a[..., k] for k in range(a.shape[-1])]

    @staticmethod
    def put(a: np.ndarray, value: Any) -> None:
        """Write a lane into its (N, 1) or (N, P) array."""
        a[...] = value

    @staticmethod
    def tick(a: np.ndarray) -> np.ndarray:
        """Add 1 to a per-game integer counter (N,) in place; the counter as a lane."""
        a += 1
        return a


def _where(c: bool, a: Any, b: Any) -> Any:
    return a if c else b


def _exp(x: float) -> float:
    return float(np.exp(x))


def _read(a: np.ndarray) -> Any:
    return a.item()


def _columns(a: np.ndarray) -> list:
    return a.reshape(-1).tolist()


def _put(a: np.ndarray, value: Any) -> None:
    a[0, 0] = value


def _tick(a: np.ndarray) -> int:
    # (``a += 1`` on one element costs several times more: NumPy's casting checks)
    count = a.item() + 1
    a[0] = count
    return count


class ScalarOps:
    """Python numbers for one game of one player (the docstrings are ``ArrayOps``')."""

    scalar = True
    where = staticmethod(_where)
    logical_not = staticmethod(operator.not_)
    exp = staticmethod(_exp)
    any = staticmethod(bool)
    read = staticmethod(_read)
    read0 = staticmethod(_read)
    columns = staticmethod(_columns)
    put = staticmethod(_put)
    tick = staticmethod(_tick)


Ops = type[ArrayOps] | type[ScalarOps]
ARRAYS: Ops = ArrayOps
SCALARS: Ops = ScalarOps


def column(lane: Any, n: int) -> np.ndarray:
    """A per-game lane as a new (N,) array (N rows for a vector's lanes): a copy of an array
    lane, N copies of a number."""
    return lane.copy() if isinstance(lane, np.ndarray) else np.full(n, lane)
