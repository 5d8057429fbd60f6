"""Paths the command line reads or writes, checked before any work: a bad path fails in a
second with one line saying why, not after an evaluation or a training run."""

from __future__ import annotations

import argparse
import os
import stat
import tempfile
from collections.abc import Callable
from pathlib import Path

from rallysim.cli.common import UsageError
from rallysim.jsondoc import MISSING, not_a_file


def os_message(err: OSError) -> str:
    """``'PATH': Reason`` for an OSError from the file system, else its own message."""
    if err.strerror and err.filename is not None:
        return f"{str(err.filename)!r}: {err.strerror}"
    return str(err) or type(err).__name__


def _nearest_existing(path: Path) -> Path:
    """``path`` or its nearest ancestor that exists (the folder a creation would start in)."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
    return Path(".")  # only a relative path gets here; its top folder is the current one


def _cannot_create(path: Path, start: Path) -> str | None:
    """Why ``path`` cannot be created from ``start``, its nearest existing ancestor."""
    if not start.is_dir():
        return f"cannot create {str(path)!r}: {str(start)!r} is not a directory"
    try:
        name_max = os.pathconf(start, "PC_NAME_MAX")
    except (OSError, ValueError):
        name_max = 255
    for part in path.relative_to(start).parts:
        if len(os.fsencode(part)) > name_max:
            return f"cannot create {str(path)!r}: the name {part[:20]!r}... is too long"
    return _cannot_write_in(start)


def _cannot_write_in(folder: Path) -> str | None:
    # create (and drop) a file rather than ask os.access: as root, access() says yes to a
    # read-only mode, and it does not see a read-only or virtual file system (/proc)
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as err:
        return f"cannot write in {str(folder)!r}: {err.strerror or err}"
    return None


def _is_stream(path: Path) -> bool:
    try:
        mode = path.stat().st_mode
    except OSError:  # a loop of links, a broken one: not_a_file has said what it is
        return False
    return stat.S_ISFIFO(mode) or stat.S_ISCHR(mode)


def path_problem(text: str, want: str) -> str | None:
    """What stops ``text`` from serving as ``want``, or None: ``"dir"``, an output folder
    (created with its parents); ``"file"``, an output file (likewise); ``"input"``, a file to
    read. Checked before any work, so a bad path fails in a second, not after an evaluation."""
    if not text:
        return "the path is empty"
    if "\0" in text:
        return "the path contains a NUL character"
    if want == "file" and text.endswith(("/", os.sep)):
        return f"{text!r} ends with '/' and so names a directory, not a file"
    path = Path(text)
    try:
        if want == "input":
            problem = not_a_file(path)
            if problem == MISSING:
                start = _nearest_existing(path.parent)
                if not start.is_dir():
                    return f"{text!r} does not exist: {str(start)!r} is not a directory"
                return f"{text!r} does not exist"
            # a pipe or a terminal is read as a stream (--config <(...), /dev/stdin)
            if problem is not None and not _is_stream(path):
                return f"{text!r} {problem}"
            return None if os.access(path, os.R_OK) else f"cannot read {text!r}: permission denied"
        if os.path.islink(path) and not path.exists():
            return f"{text!r} is a broken symbolic link"
        if path.exists():
            if want == "dir":
                return (f"{text!r} is not a directory" if not path.is_dir()
                        else _cannot_write_in(path))
            if path.is_dir():
                return f"{text!r} is a directory, not a file"
            return None if os.access(path, os.W_OK) else f"cannot write {text!r}: permission denied"
        return _cannot_create(path, _nearest_existing(path.parent))
    except OSError as err:  # e.g. a name too long for the system, a loop of links
        return os_message(err)


def _path_arg(want: str) -> Callable[[str], str]:
    def parse(text: str) -> str:
        problem = path_problem(text, want)
        if problem:
            raise argparse.ArgumentTypeError(problem)
        return text

    return parse


# argument types: an output folder, an output file, a file to read
out_dir, out_file, in_file = _path_arg("dir"), _path_arg("file"), _path_arg("input")


def require(path: Path, want: str) -> None:
    """``path_problem`` for a path the command builds (a default, a file inside ``--out``)."""
    problem = path_problem(str(path), want)
    if problem:
        raise UsageError(problem)
