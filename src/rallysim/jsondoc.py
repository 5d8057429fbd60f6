"""Reading the JSON half of RallySim's file pairs (policies, checkpoints) without trusting it:
every failure is one ``ValueError`` (of the caller's subclass) naming the file and the field."""

from __future__ import annotations

import errno
import json
import math
import os
import stat
from pathlib import Path
from typing import Any

TYPE_NAMES = {dict: "object", list: "list", str: "string", bool: "boolean", int: "integer",
              float: "number", type(None): "null"}


def jsonable(value: Any) -> Any:
    """``value`` with every non-finite float (an undefined rate: NaN) as None, through dicts,
    lists and tuples: JSON has no NaN, and ``json.dumps`` would write one that strict readers
    refuse."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if isinstance(value, dict):
        return {k: jsonable(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [jsonable(v) for v in value]
    return value


def type_name(value: Any) -> str:
    return TYPE_NAMES.get(type(value), type(value).__name__)


MISSING = "does not exist"
# what a non-regular file is, by its stat mode's test
_KINDS = ((stat.S_ISDIR, "a directory"), (stat.S_ISFIFO, "a FIFO (named pipe)"),
          (stat.S_ISCHR, "a character device"), (stat.S_ISBLK, "a block device"),
          (stat.S_ISSOCK, "a socket"))


def not_a_file(path: Path) -> str | None:
    """None if ``path`` is a regular file (through any links), else what it is, to follow the
    path in an error line: ``MISSING``, "is a directory, not a file", "is a loop of symbolic
    links", "is a symbolic link to a character device (/dev/zero), not a file", ... Every
    loader asks this first: reading a FIFO would wait for a writer, a device may never end,
    and "does not exist" would misname them all."""
    path = Path(path)
    try:
        mode = path.stat().st_mode
    except (FileNotFoundError, NotADirectoryError):
        if path.is_symlink():
            return f"is a broken symbolic link (to {os.readlink(path)!r})"
        return MISSING
    except OSError as err:
        if err.errno == errno.ELOOP:
            return "is a loop of symbolic links"
        return f"cannot be read: {err.strerror or err}"
    if stat.S_ISREG(mode):
        return None
    kind = next((name for test, name in _KINDS if test(mode)), "not a regular file")
    if path.is_symlink():
        return f"is a symbolic link to {kind} ({os.path.realpath(path)}), not a file"
    return f"is {kind}, not a file"


def read_object(path: Path, what: str, error: type[ValueError] = ValueError) -> dict[str, Any]:
    """The JSON object in ``path`` (a ``what``: "policy", "checkpoint"), or ``error`` saying
    why it cannot be one: not a regular file (``not_a_file``), unreadable, not UTF-8, not
    JSON, or not an object."""
    problem = not_a_file(path)
    if problem is not None:
        raise error(f"{what} {path} {problem}")
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
