"""NumPy's elementwise minimum and maximum of two numbers, and ``np.linalg.norm`` of three,
for the compiled steps of every player kind: the kernels must give the bits of the NumPy code
they replaced, signed zeros and NaN included."""

from __future__ import annotations

import math


def np_min(a: float, b: float) -> float:
    """``np.minimum`` of two numbers: NaN if either is NaN, ``b`` on a tie."""
    return a if a < b or a != a else b


def np_max(a: float, b: float) -> float:
    """``np.maximum`` of two numbers: NaN if either is NaN, ``b`` on a tie."""
    return a if a > b or a != a else b


def norm3(x: float, y: float, z: float) -> float:
    """``np.linalg.norm`` of (x, y, z): the squares summed in its order."""
    return math.sqrt((x * x + y * y) + z * z)
