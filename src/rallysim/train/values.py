"""Checking and reading the values of training settings, field by field.

Every settings dataclass (``rallysim.train.sections``, ``rallysim.train.config.TrainConfig``)
checks its fields here at construction, so a bad value fails naming the setting (``ppo.gamma``)
instead of deep inside SB3 or after hours of training. The check each field gets follows from
its annotation; the ranges and choices are the dataclass's own tables.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from dataclasses import fields
from typing import Any, get_type_hints

Bound = tuple[Callable[[Any], bool], str]  # (accepts the value, the range in words)

# seeds feed numpy's legacy seeding (below 2**32) after offsets such as the evaluation's
# + 1_000_003; the int32 range leaves room for those
SEED_MAX = 2**31 - 1


def at_least(low: float) -> Bound:
    return (lambda v: v >= low), f">= {low:g}"


def above(low: float) -> Bound:
    return (lambda v: v > low), f"> {low:g}"


def within(low: float, high: float) -> Bound:
    return (lambda v: low <= v <= high), f"in [{low:g}, {high:g}]"


SEED: Bound = within(0, SEED_MAX)


def kind_of(hint: Any) -> str:
    """The check an annotation asks for: int, float, bool, str, float|None, widths; a
    dataclass annotation (a section of settings) is ``section``."""
    if hint in (int, float, bool, str):
        return hint.__name__
    if hint == float | None:
        return "float|None"
    if hint == tuple[int, ...]:
        return "widths"
    if isinstance(hint, type) and hasattr(hint, "__dataclass_fields__"):
        return "section"
    raise TypeError(f"no check for the annotation {hint!r}")


def kinds(cls: type) -> dict[str, str]:
    """``{field: kind}`` of a settings dataclass."""
    hints = get_type_hints(cls)
    return {f.name: kind_of(hints[f.name]) for f in fields(cls)}


def check_type(name: str, kind: str, value: Any) -> None:
    # bool is an int subclass in Python: True must not pass as n_envs=1
    is_int = isinstance(value, int) and not isinstance(value, bool)
    if kind == "int" and not is_int:
        raise ValueError(f"{name} must be an integer, got {value!r}")
    if kind in ("float", "float|None") and not (kind == "float|None" and value is None):
        if not (is_int or isinstance(value, float)):
            raise ValueError(f"{name} must be a number, got {value!r}")
        if not math.isfinite(value):
            raise ValueError(f"{name} must be finite, got {value!r}")
    if kind == "bool" and not isinstance(value, bool):
        raise ValueError(f"{name} must be true or false, got {value!r}")
    if kind == "str" and not (isinstance(value, str) and value):
        raise ValueError(f"{name} must be a non-empty string, got {value!r}")
    if kind == "widths" and not (isinstance(value, tuple) and all(
            isinstance(v, int) and not isinstance(v, bool) for v in value)):
        shown = list(value) if isinstance(value, tuple) else value
        raise ValueError(f"{name} must be a list of integer layer widths, got {shown!r}")


def check_fields(obj: Any, prefix: str, choices: dict[str, tuple[str, ...]],
                 bounds: dict[str, Bound]) -> None:
    """Check every field of settings dataclass ``obj``: its type, then its choices and range
    (a value of None means "off" and is not bounded). ``prefix`` names its section in errors."""
    field_kinds = kinds(type(obj))
    for f in fields(obj):
        if field_kinds[f.name] != "section":
            check_type(prefix + f.name, field_kinds[f.name], getattr(obj, f.name))
    for name, valid in choices.items():
        if getattr(obj, name) not in valid:
            raise ValueError(f"{prefix}{name} must be one of {', '.join(map(repr, valid))}, got "
                             f"{getattr(obj, name)!r}")
    for name, (ok, words) in bounds.items():
        value = getattr(obj, name)
        if value is not None and not ok(value):
            raise ValueError(f"{prefix}{name} must be {words}, got {value!r}")


def coerce(kind: str | None, value: Any) -> Any:
    """A value read from YAML or ``--set`` as its field's type where the text is unambiguous.

    PyYAML reads ``3e-4`` (no dot) and ``1e6`` as strings and ``2.0`` as a float; those are
    what a user means as a learning rate or a budget. Anything else passes unchanged, for the
    dataclass to reject with the setting's name."""
    if kind == "widths" and isinstance(value, list | tuple):
        return tuple(_as_int(v) for v in value)
    if kind == "int":
        return _as_int(value)
    if kind in ("float", "float|None") and isinstance(value, str):
        try:
            return float(value)
        except ValueError:
            return value
    return value


def _as_int(value: Any) -> Any:
    if isinstance(value, str):
        try:
            value = float(value)
        except ValueError:
            return value
    if isinstance(value, float) and value.is_integer():
        return int(value)
    return value
