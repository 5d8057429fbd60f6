"""NumPy's elementwise minimum and maximum of two numbers, for the compiled steps of every
player kind: the kernels must give the bits of the NumPy code they replaced, signed zeros and
NaN included."""

from __future__ import annotations


def np_min(a: float, b: float) -> float:
    """``np.minimum`` of two numbers: NaN if either is NaN, ``b`` on a tie."""
    return a if a < b or a != a else b


def np_max(a: float, b: float) -> float:
    """``np.maximum`` of two numbers: NaN if either is NaN, ``b`` on a tie."""
    return a if a > b or a != a else b
