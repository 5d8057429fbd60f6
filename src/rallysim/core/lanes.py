"""Two backends for the rule code that runs every physics step, written once over *lanes*.

A lane is one quantity of the batch: a NumPy array over the N games (``ARRAYS``; shape (N, 1)
per game, (N, P) per player), or, for a batch of one game of one player, a Python number
(``SCALARS``). Each NumPy call has a fixed cost whatever the array's size, which at N = 1 is
nearly all of a physics step's time; Python floats do the same IEEE-754 double operations
without it. Both backends run the same expressions, so they give bit-identical results; sin,
cos and exp call NumPy's in both (NumPy's SIMD versions may differ from ``math``'s in the last
bit on some machines).

How code over lanes is written:

* lanes live on a lanes object (``ArrayLanes`` or ``ScalarLanes``); over a batch, assigning one
  (``lanes.x = value``) copies the value into the array behind it and augmented assignment
  (``lanes.x += y``) changes that array in place, so the batch's arrays always hold the state;
  scalar lanes are read from the arrays and written back explicitly (``load``, ``store``);
* a vector (the shuttle's position and velocity) is one lane of 3 rows: a (3, N, 1) array or a
  list of 3 numbers; ``v[k]`` is a row, and ``ops.scale``, ``ops.shrink`` and ``ops.axpy`` change
  it in place;
* a value kept across a change is taken with ``ops.copies`` (an array lane is a view);
* ``ops.where`` chooses (both branches are evaluated, so both must be safe everywhere);
  ``ops.divide`` divides where the divisor is positive;
* ``if ops.any(mask):`` skips work no lane needs.
"""

from __future__ import annotations

import math
import operator
from collections.abc import Iterable
from typing import Any

import numpy as np


class ArrayOps:
    """NumPy over the batch."""

    scalar = False
    where = staticmethod(np.where)
    logical_not = staticmethod(np.logical_not)
    sin = staticmethod(np.sin)
    cos = staticmethod(np.cos)
    exp = staticmethod(np.exp)
    sqrt = staticmethod(np.sqrt)

    @staticmethod
    def clip(a: Any, lo: Any, hi: Any) -> np.ndarray:
        """np.clip's result (``minimum(maximum(a, lo), hi)``)."""
        return np.minimum(np.maximum(a, lo), hi)

    @staticmethod
    def any(a: np.ndarray) -> bool:
        # count_nonzero is a plain C loop; ndarray.any() goes through the ufunc reduction
        # machinery, slower on small arrays.
        return np.count_nonzero(a) > 0

    @staticmethod
    def all(a: np.ndarray) -> bool:
        return np.count_nonzero(a) == np.size(a)

    @staticmethod
    def copies(*lanes: np.ndarray) -> tuple:
        return tuple(a.copy() for a in lanes)

    @staticmethod
    def scale(v: np.ndarray, f: Any) -> None:
        """A vector lane (3, N, 1) times ``f``, in place."""
        v *= f

    @staticmethod
    def shrink(v: np.ndarray, d: Any) -> None:
        """A vector lane divided by ``d``, in place."""
        v /= d

    @staticmethod
    def axpy(p: np.ndarray, v: np.ndarray, h: float) -> None:
        """``p += v * h`` for vector lanes, in place."""
        p += v * h

    @staticmethod
    def largest(a: np.ndarray) -> float:
        """The largest value over the batch (0.0 for an empty batch)."""
        return float(np.max(a)) if np.size(a) else 0.0

    @staticmethod
    def divide(a: np.ndarray, b: np.ndarray) -> np.ndarray:
        """``a / b`` where ``b > 0``, else 0."""
        out = np.zeros(np.broadcast_shapes(np.shape(a), np.shape(b)))
        return np.divide(a, b, out=out, where=b > 0)

    # -- between lanes and arrays -------------------------------------------------------------
    @staticmethod
    def read(a: np.ndarray) -> np.ndarray:
        """An array as a lane: itself (one game's: its one number)."""
        return a

    @staticmethod
    def vector(a: np.ndarray) -> np.ndarray:
        """A vector's (3, N, 1) array as its lane: itself."""
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

    @staticmethod
    def scaled(lanes: list, shape: tuple[int, ...], centre: Any, scale: Any) -> np.ndarray:
        """Lanes (each broadcastable to ``shape``; a constant may be the number 0.0) as the
        columns of a ``(*shape, k)`` array, each mapped by (lane - centre) / scale (``centre``
        and ``scale``: k numbers, best a float64 array: a tuple is converted at every call)."""
        out = np.zeros((*shape, len(lanes)))
        for k, lane in enumerate(lanes):
            if isinstance(lane, np.ndarray) or lane != 0.0:
                out[..., k] = lane
        out -= centre
        out /= scale
        return out

    @staticmethod
    def observations(lanes: list, shape: tuple[int, ...], centre: Any, scale: Any
                     ) -> np.ndarray:
        """``scaled``, clipped into [-1, 1] (np.clip's result), as float32."""
        return _clipped32(ArrayOps.scaled(lanes, shape, centre, scale))


def _clipped32(out: np.ndarray) -> np.ndarray:
    """``out`` clipped into [-1, 1] in place (np.clip's result), as float32."""
    np.maximum(out, -1.0, out=out)
    np.minimum(out, 1.0, out=out)
    return out.astype(np.float32)


def _where(c: bool, a: Any, b: Any) -> Any:
    return a if c else b


def _clip(a: float, lo: float, hi: float) -> float:
    a = a if a >= lo else lo
    return a if a <= hi else hi


def _sin(x: float) -> float:
    return float(np.sin(x))


def _cos(x: float) -> float:
    return float(np.cos(x))


def _exp(x: float) -> float:
    return float(np.exp(x))


def _copies(*lanes: Any) -> tuple:
    return lanes


def _same(x: Any) -> Any:
    return x


def _scale(v: list, f: float) -> None:
    v[0] *= f
    v[1] *= f
    v[2] *= f


def _shrink(v: list, d: float) -> None:
    v[0] /= d
    v[1] /= d
    v[2] /= d


def _axpy(p: list, v: list, h: float) -> None:
    p[0] += v[0] * h
    p[1] += v[1] * h
    p[2] += v[2] * h


def _divide(a: float, b: float) -> float:
    return a / b if b > 0 else 0.0


def _read(a: np.ndarray) -> Any:
    return a.item()


def _vector(a: np.ndarray) -> list:
    return a.ravel().tolist()


def _columns(a: np.ndarray) -> list:
    return a.reshape(-1).tolist()


def _put(a: np.ndarray, value: Any) -> None:
    a[0, 0] = value


def _tick(a: np.ndarray) -> int:
    # (``a += 1`` on one element costs several times more: NumPy's casting checks)
    count = a.item() + 1
    a[0] = count
    return count


def _scaled(lanes: list, shape: tuple[int, ...], centre: Any, scale: Any) -> np.ndarray:
    # the numbers as one array: each element's (x - c) / s, as on floats, in four NumPy calls
    out = np.array(lanes, dtype=np.float64)
    out -= centre
    out /= scale
    return out.reshape(*shape, len(lanes))


def _observations(lanes: list, shape: tuple[int, ...], centre: Any, scale: Any
                  ) -> np.ndarray:
    return _clipped32(_scaled(lanes, shape, centre, scale))


class ScalarOps:
    """Python numbers for one game of one player (the docstrings are ``ArrayOps``')."""

    scalar = True
    where = staticmethod(_where)
    clip = staticmethod(_clip)
    logical_not = staticmethod(operator.not_)
    sin = staticmethod(_sin)
    cos = staticmethod(_cos)
    exp = staticmethod(_exp)
    sqrt = staticmethod(math.sqrt)  # correctly rounded, as NumPy's
    any = staticmethod(bool)
    all = staticmethod(bool)
    copies = staticmethod(_copies)
    scale = staticmethod(_scale)
    shrink = staticmethod(_shrink)
    axpy = staticmethod(_axpy)
    largest = staticmethod(_same)
    divide = staticmethod(_divide)
    read = staticmethod(_read)
    read0 = staticmethod(_read)
    vector = staticmethod(_vector)
    columns = staticmethod(_columns)
    put = staticmethod(_put)
    tick = staticmethod(_tick)
    scaled = staticmethod(_scaled)
    observations = staticmethod(_observations)


Ops = type[ArrayOps] | type[ScalarOps]
ARRAYS: Ops = ArrayOps
SCALARS: Ops = ScalarOps


def column(lane: Any, n: int) -> np.ndarray:
    """A per-game lane as a new (N,) array (N rows for a vector's lanes): a copy of an array
    lane, N copies of a number."""
    return lane.copy() if isinstance(lane, np.ndarray) else np.full(n, lane)


class ArrayLanes:
    """Lanes that are views of the batch's arrays: assigning one copies into its array."""

    scalar = False

    def __init__(self, **views: Any) -> None:
        self.__dict__.update(views)

    def __setattr__(self, name: str, value: Any) -> None:
        d = self.__dict__
        current = d.get(name)
        if current is value:  # augmented assignment: already changed in place
            return
        if current.__class__ is np.ndarray:
            current[...] = value
        else:
            d[name] = value

    def rebind(self, **views: np.ndarray) -> None:
        """Make lanes views of other arrays (assigning would copy into the old ones)."""
        self.__dict__.update(views)


class ScalarLanes:
    """Lanes held as Python numbers: ``load`` reads them from (1, 1) arrays (a vector's from
    its (3, 1, 1) array, as a list), ``store`` writes them back."""

    scalar = True

    def __init__(self, **values: Any) -> None:
        self.__dict__.update(values)

    @classmethod
    def load(cls, views: dict[str, np.ndarray],
             vectors: dict[str, np.ndarray] | None = None) -> ScalarLanes:
        lanes = cls.__new__(cls)
        d = lanes.__dict__ = {name: v.item() for name, v in views.items()}
        if vectors:
            for name, v in vectors.items():  # (a loop: a generator costs more for two)
                d[name] = v.ravel().tolist()
        return lanes

    def reload(self, views: dict[str, np.ndarray],
               vectors: dict[str, np.ndarray] | None = None) -> None:
        """Read the lanes again (after array code changed their arrays)."""
        self.__dict__.update(ScalarLanes.load(views, vectors).__dict__)

    def store(self, views: dict[str, np.ndarray], names: Iterable[str] | None = None,
              vectors: dict[str, np.ndarray] | None = None) -> None:
        """Write the lanes ``names`` (default: all of ``views``) and ``vectors`` to their
        arrays."""
        d = self.__dict__
        for name in views if names is None else names:
            views[name][0, 0] = d[name]
        for name, v in (vectors or {}).items():
            x, y, z = d[name]
            v[0, 0, 0], v[1, 0, 0], v[2, 0, 0] = x, y, z  # (a list into a view converts it first)
