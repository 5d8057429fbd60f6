"""Reading the JSON half of RallySim's file pairs (policies, checkpoints) without trusting it:
every failure is one ``ValueError`` (of the caller's subclass) naming the file and the field."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

TYPE_NAMES = {dict: "object", list: "list", str: "string", bool: "boolean", int: "integer",
              float: "number", type(None): "null"}


def type_name(value: Any) -> str:
    return TYPE_NAMES.get(type(value), type(value).__name__)


def read_object(path: Path, what: str, error: type[ValueError] = ValueError) -> dict[str, Any]:
    """The JSON object in ``path`` (a ``what``: "policy", "checkpoint"), or ``error`` saying
    why it cannot be one: unreadable, not UTF-8, not JSON, or not an object."""
    try:
        raw = Path(path).read_bytes()
    except OSError as err:
        raise error(f"{what} {path} is unreadable: {err}") from None
    try:
        text = raw.decode("utf-8")
    except UnicodeDecodeError as err:
        raise error(f"{what} {path} is corrupted: not valid UTF-8 at byte {err.start}") from None
    try:
        doc = json.loads(text)
    except json.JSONDecodeError as err:
        raise error(f"{what} {path} is corrupted: not valid JSON ({err})") from None
    except RecursionError:
        raise error(f"{what} {path} is corrupted: nested too deeply") from None
    if not isinstance(doc, dict):
        raise error(f"{what} {path} is corrupted: it must hold a JSON object, found a "
                    f"{type_name(doc)}")
    return doc


def require(doc: Any, field: str, kind: type | tuple[type, ...], source: Path, what: str,
            error: type[ValueError] = ValueError, where: str = "") -> Any:
    """``doc[field]``, which must be of ``kind`` (a boolean is not an integer; an integer is a
    number), or ``error`` naming ``source`` and the field (``where`` + ``field``)."""
    name = f"{where}{field}"
    if not isinstance(doc, dict):
        raise error(f"{what} {source}: {where.rstrip('.') or 'the document'} must be an "
                    f"object, found {type_name(doc)}")
    if field not in doc:
        raise error(f"{what} {source}: field {name} is missing")
    value = doc[field]
    kinds = kind if isinstance(kind, tuple) else (kind,)
    if not (type(value) in kinds or (type(value) is int and float in kinds)):
        wanted = " or ".join(TYPE_NAMES.get(k, k.__name__) for k in kinds)
        raise error(f"{what} {source}: field {name} must be {wanted}, found "
                    f"{type_name(value)} {str(value)[:40]!r}")
    return value
