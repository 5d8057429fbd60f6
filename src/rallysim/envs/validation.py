"""Checks shared by every API view: actions and reset options."""

from __future__ import annotations

from collections.abc import Iterable
from typing import Any

import numpy as np


def validate_actions(actions: Any, shape: tuple[int, ...], lo: float = -1.0,
                     hi: float = 1.0) -> np.ndarray:
    """``actions`` as a float64 array of ``shape``, clipped to [lo, hi].

    Raises ``ValueError`` naming the problem for a wrong shape or non-finite values; nothing
    is modified, so the caller's state stays untouched."""
    try:
        a = np.asarray(actions, dtype=np.float64)
    except (TypeError, ValueError) as err:
        raise ValueError(f"actions must be numeric with shape {shape}: {err}") from None
    if a.shape != shape:
        raise ValueError(f"actions must have shape {shape}, got {a.shape}")
    bad = ~np.isfinite(a)
    if bad.any():
        where = np.argwhere(bad)[:3].tolist()
        kind = "NaN" if np.isnan(a[bad]).any() else "inf"
        raise ValueError(f"actions contain {kind} (non-finite) values at indices {where}")
    return np.clip(a, lo, hi)


def check_options(options: dict[str, Any] | None, valid: Iterable[str]) -> dict[str, Any]:
    """``options`` or {}, rejecting unknown keys with a list of the valid ones."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise ValueError(f"options must be a dict, got {type(options).__name__}")
    valid = tuple(valid)
    unknown = sorted(set(options) - set(valid))
    if unknown:
        raise ValueError(f"unknown reset option(s) {unknown}; valid options: {list(valid)}")
    return options


def option_values(opts: dict[str, Any], key: str, shape: tuple[int, ...],
                  bounds: Any) -> np.ndarray | None:
    """Reset option ``key`` broadcast to ``shape`` ((k,) or (k, size)), finite and within
    ``bounds`` ((lo, hi), or one (lo, hi) row per component); None when it was not given."""
    if key not in opts:
        return None
    try:
        value = np.broadcast_to(np.asarray(opts[key], dtype=np.float64), shape).copy()
    except (TypeError, ValueError):
        per = f"{shape[1]} numbers or one row of {shape[1]}" if len(shape) > 1 else "a number"
        raise ValueError(f"option {key!r} must be {per} (or one per environment), got "
                         f"{opts[key]!r}") from None
    if not np.all(np.isfinite(value)):
        raise ValueError(f"option {key!r} must be finite, got {opts[key]!r}")
    b = np.atleast_2d(np.asarray(bounds, dtype=np.float64))
    if np.any(value < b[:, 0] - 1e-9) or np.any(value > b[:, 1] + 1e-9):
        ranges = ", ".join(f"[{lo:.4g}, {hi:.4g}]" for lo, hi in b)
        raise ValueError(f"option {key!r} must lie in {ranges}, got {opts[key]!r}")
    return value
