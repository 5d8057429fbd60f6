"""Checks shared by every API view: actions, goals and reset options. Each raises ``ValueError``
with the reason before anything is modified, so a rejected call leaves the env's state as it
was."""

from __future__ import annotations

import math
from collections.abc import Iterable
from typing import Any

import numpy as np

from rallysim.core.game import validate_seed

__all__ = ["check_keywords", "check_options", "keyword_names", "option_values", "positive_int",
           "read_options", "real_array", "validate_action_row", "validate_actions",
           "validate_goals", "validate_seed"]


def check_keywords(given: Iterable[str], valid: Iterable[str],
                   listed: Iterable[str] | None = None) -> None:
    """Refuse keyword arguments not among ``valid`` with ``TypeError`` in Python's own wording
    (clients such as TorchRL's ``GymEnv`` retry without an optional argument on exactly that
    error), listing every valid name (``listed``, default ``valid``), so that a misspelt one
    says what was meant."""
    valid = list(valid)
    unknown = sorted(set(given) - set(valid))
    if unknown:
        names = valid if listed is None else list(listed)
        raise TypeError(f"got an unexpected keyword argument {unknown[0]!r}; valid arguments: "
                        + ", ".join(names))


def keyword_names(function: Any) -> list[str]:
    """The names ``function`` takes as keyword arguments (not ``self``, not ``**kwargs``)."""
    import inspect

    kinds = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    return [p.name for p in inspect.signature(function).parameters.values()
            if p.kind in kinds and p.name != "self"]


def real_array(value: Any, what: str, shape: tuple[int, ...]) -> np.ndarray:
    """``value`` as a float64 array of real numbers. Strings, bytes, booleans, complex numbers,
    objects, dicts and None are refused rather than parsed or cast."""
    if value is None or isinstance(value, (dict, str, bytes)):
        raise ValueError(f"{what} must be real numbers with shape {shape}, got "
                         f"{type(value).__name__}")
    try:
        a = np.asarray(value)
    except (TypeError, ValueError) as err:
        raise ValueError(f"{what} must be real numbers with shape {shape}: {err}") from None
    if a.dtype.kind not in "iuf":
        raise ValueError(f"{what} must be real numbers with shape {shape}, got {a.dtype} "
                         "values")
    return a.astype(np.float64)


def _refuse_non_finite(a: np.ndarray, what: str) -> None:
    finite = np.isfinite(a)
    if np.count_nonzero(finite) == finite.size:  # cheaper than .all() on small arrays
        return
    bad = ~finite
    where = np.argwhere(bad)[:3].tolist()
    kind = "NaN" if np.isnan(a[bad]).any() else "inf"
    raise ValueError(f"{what} contain {kind} (non-finite) values at indices {where}")


def validate_actions(actions: Any, shape: tuple[int, ...], lo: float = -1.0,
                     hi: float = 1.0) -> np.ndarray:
    """``actions`` as a float64 array of exactly ``shape``, finite, clipped to [lo, hi]."""
    a = real_array(actions, "actions", shape)
    if a.shape != shape:
        raise ValueError(f"actions must have shape {shape}, got {a.shape}")
    _refuse_non_finite(a, "actions")
    # np.clip's result, in place on real_array's copy, with less overhead per call
    np.maximum(a, lo, out=a)
    return np.minimum(a, hi, out=a)


def validate_action_row(action: Any, shape: tuple[int, ...]) -> np.ndarray:
    """One environment's ``action`` validated as ``validate_actions`` does, as a (1, k) array.
    A float32 or float64 array of the right shape is checked and clipped on Python floats (the
    same numbers: np.maximum then np.minimum, each giving the bound on a tie); anything else,
    or a non-finite value, takes ``validate_actions``, which raises the same errors."""
    if type(action) is np.ndarray and action.shape == shape and action.dtype.char in "fd":
        values = action.tolist()
        if all(map(math.isfinite, values)):
            clipped = [v if v > -1.0 else -1.0 for v in values]
            return np.array([[v if v < 1.0 else 1.0 for v in clipped]])
    return validate_actions(action, shape)[None, :]


def validate_goals(goals: Any, shape: tuple[int, ...]) -> np.ndarray:
    """Turn-based goals as a finite float64 array of ``shape``; where goals are single values
    (a trailing 1 in ``shape``) that axis may be left out. Shapes are checked, never reshaped
    from the size alone."""
    a = real_array(goals, "goals", shape)
    if a.shape != shape and not (shape[-1] == 1 and a.shape == shape[:-1]):
        raise ValueError(f"goals must have shape {shape}, got {a.shape}")
    _refuse_non_finite(a, "goals")
    return a.reshape(shape)


def check_options(options: dict[str, Any] | None, valid: Iterable[str]) -> dict[str, Any]:
    """``options`` or {}, rejecting unknown keys with a list of the valid ones."""
    if options is None:
        return {}
    if not isinstance(options, dict):
        raise ValueError(f"options must be a dict, got {type(options).__name__}")
    valid = tuple(valid)
    unknown = sorted(set(options) - set(valid), key=repr)
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
        value = np.broadcast_to(real_array(opts[key], f"option {key!r}", shape), shape).copy()
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


def read_options(options: dict[str, Any] | None,
                 specs: dict[str, tuple[tuple[int, ...], Any]]) -> dict[str, np.ndarray]:
    """Every given reset option checked (``specs``: key -> (shape, bounds), as
    ``option_values``), all of them before the caller draws a random number or moves a body:
    a rejected reset changes nothing."""
    opts = check_options(options, specs)
    return {key: option_values(opts, key, shape, bounds)
            for key, (shape, bounds) in specs.items() if key in opts}


def positive_int(value: Any, name: str) -> int:
    """``value`` as an integer >= 1 (not a boolean, not a float)."""
    if isinstance(value, bool) or not isinstance(value, int | np.integer) or value < 1:
        raise ValueError(f"{name} must be an integer >= 1, got {value!r}")
    return int(value)
