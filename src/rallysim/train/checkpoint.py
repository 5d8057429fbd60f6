"""Training checkpoints: safetensors for every tensor, JSON for everything else, no pickle.

A checkpoint of an SB3 PPO run is two files in ``RUN/checkpoints/``:
``step_{decisions:012d}.{digest}.safetensors`` (the policy's and the optimiser's tensors, named
after the first 16 hex digits of their SHA-256) and ``step_{decisions:012d}.json`` (stage,
config, decisions done, the optimiser's structure, the learning curve so far, the tensor file's
name and SHA-256, and a SHA-256 of the JSON's own fields). The JSON is the commit record: the
tensors are written first under their new name, then the JSON under a temporary name, renamed
over the old one in one step. A save that repeats a step therefore never changes a tensor file
that the previous JSON names (tensors equal to those are rewritten to the same bytes), and a run
killed at any moment (even ``kill -9``) leaves every checkpoint JSON naming a complete tensor
file that matches it. ``resume`` takes the newest intact checkpoint and says which
ones it skipped and why.

``write_pair``/``read_pair`` are the same machinery for other resumable state (the warm start's,
``rallysim.train.warm_start``).

Test hook: with ``RALLYSIM_CRASH_AT=LABEL:N`` in the environment the process kills itself
(SIGKILL) the N-th time it reaches the write point ``LABEL`` (``crash_point``), so that tests can
kill a run exactly between two writes. Labels: ``{kind}.tensors.tmp`` (tensors written under the
temporary name), ``{kind}.tensors`` (tensors in place, JSON not written), ``{kind}.json.tmp``
(JSON written, not yet renamed), ``{kind}.json`` (renamed, older checkpoints not yet pruned) and
``{kind}.saved`` (pruned), with ``kind`` ``checkpoint`` for PPO and ``warm`` for the warm start;
``warm.data.tmp`` and ``warm.data`` for a round's dataset.
"""

from __future__ import annotations

import hashlib
import json
import os
import re
import signal
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from rallysim import jsondoc
from rallysim.jsondoc import type_name

FORMAT = "rallysim-train-checkpoint"
FORMAT_VERSION = 2
READABLE_VERSIONS = (1, 2)  # version 1: no checksum of the JSON, one tensor file per step
MAX_DECISIONS = 10**12 - 1  # the file name holds 12 digits
_NAME = re.compile(r"step_(\d{12})\.json$")
CRASH_AT = "RALLYSIM_CRASH_AT"
_crash_counts: dict[str, int] = {}

Say = Callable[[str], None]


class CheckpointError(ValueError):
    """A checkpoint that cannot be used: corrupted, truncated or made for another run."""


class CheckpointMismatch(CheckpointError):
    """An intact checkpoint made with other settings: the folder belongs to another run, so no
    older checkpoint is tried in its place."""


def crash_point(label: str) -> None:
    """Kill this process (SIGKILL) if ``RALLYSIM_CRASH_AT`` asks for ``label`` and this is the
    N-th time it is reached (tests of what a ``kill -9`` between two writes leaves)."""
    spec = os.environ.get(CRASH_AT)
    if not spec:
        return
    target, _, nth = spec.rpartition(":")
    if target != label:
        return
    _crash_counts[label] = _crash_counts.get(label, 0) + 1
    if str(_crash_counts[label]) == nth.strip():
        os.kill(os.getpid(), getattr(signal, "SIGKILL", signal.SIGTERM))


def _fsync_dir(folder: Path) -> None:
    # the rename itself must survive a power cut, not only the file's bytes
    try:
        fd = os.open(folder, os.O_RDONLY)
    except OSError:  # Windows cannot open folders
        return
    try:
        os.fsync(fd)
    except OSError:
        pass
    finally:
        os.close(fd)


def atomic_write(path: Path, data: bytes, label: str | None = None) -> None:
    """Write ``data`` to ``path`` through a temporary file renamed into place: readers see the
    old file or the new one, never a part. ``label``: the write point's name (``crash_point``)."""
    path = Path(path)
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    try:
        with open(tmp, "wb") as f:
            f.write(data)
            f.flush()
            os.fsync(f.fileno())
        if label:
            crash_point(f"{label}.tmp")
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)  # a write that failed (a full disk, a folder in the way)
        raise
    _fsync_dir(path.parent)
    if label:
        crash_point(label)


def sha256_bytes(data: bytes) -> str:
    return hashlib.sha256(data).hexdigest()


def json_default(value: Any) -> Any:
    """``json.dumps``'s ``default`` for the NumPy scalars and arrays in run records (json
    writes tuples as lists itself)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def plain_json(value: Any) -> Any:
    """``value`` as it reads back from JSON (tuples as lists, NumPy values as Python ones)."""
    return json.loads(json.dumps(value, default=json_default))


def meta_digest(doc: dict[str, Any]) -> str:
    """SHA-256 of a checkpoint JSON's fields (all but ``meta_sha256``), key order aside."""
    fields = {k: v for k, v in doc.items() if k != "meta_sha256"}
    canonical = json.dumps(fields, sort_keys=True, separators=(",", ":"), default=json_default)
    return sha256_bytes(canonical.encode())


# --- the optimiser's state as tensors + a JSON structure ---------------------------------

def flatten_optimizer(state: dict[str, Any], prefix: str = "optimizer"
                      ) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """A torch optimiser ``state_dict`` -> (tensors, JSON-able structure)."""
    tensors: dict[str, np.ndarray] = {}
    layout: dict[str, dict[str, Any]] = {}
    for pid, slots in state["state"].items():
        layout[str(pid)] = {}
        for key, value in slots.items():
            if hasattr(value, "detach"):
                tensors[f"{prefix}.{pid}.{key}"] = value.detach().cpu().numpy()
                layout[str(pid)][key] = "tensor"
            else:
                layout[str(pid)][key] = value
    groups = [dict(g) for g in state["param_groups"]]
    return tensors, {"state": layout, "param_groups": groups}


def unflatten_optimizer(tensors: dict[str, np.ndarray], doc: dict[str, Any], source: Path,
                        prefix: str = "optimizer") -> dict[str, Any]:
    """The inverse of ``flatten_optimizer``; ``source`` names the file in errors."""
    import torch

    state: dict[int, dict[str, Any]] = {}
    for pid, slots in doc["state"].items():
        if not isinstance(slots, dict) or not pid.isdigit():
            raise CheckpointError(f"checkpoint {source}: field optimizer.state.{pid} must map "
                                  "slot names to values")
        state[int(pid)] = {}
        for key, value in slots.items():
            if value != "tensor":
                state[int(pid)][key] = value
                continue
            name = f"{prefix}.{pid}.{key}"
            if name not in tensors:
                raise CheckpointError(f"checkpoint {source}: field optimizer.state.{pid}.{key} "
                                      f"names tensor {name}, which its tensor file lacks")
            state[int(pid)][key] = torch.from_numpy(np.array(tensors[name]))
    return {"state": state, "param_groups": doc["param_groups"]}


# Adam's per-parameter step count holds one value; every other slot of the optimisers RallySim
# trains with (Adam's moments) has its parameter's shape
_SCALAR_SLOTS = frozenset({"step"})


def check_shapes(tensors: dict[str, np.ndarray], expected: dict[str, tuple[int, ...]],
                 source: Path) -> None:
    """Refuse, in one line naming the tensor, a tensor of ``expected`` (name -> shape) that
    ``tensors`` lacks or holds in another shape: checksums only prove a file unchanged since it
    was sealed, so a forged or hand-edited file gets this far. Shape ``()`` is one value,
    which a tensor file holds as shape (1,) (``write_pair`` stores arrays of at least 1-D)."""
    for name, shape in expected.items():
        if name not in tensors:
            raise CheckpointError(f"checkpoint {source}: its tensor file lacks tensor {name}")
        found = tuple(np.shape(tensors[name]))
        if found != shape and not (shape == () and found == (1,)):
            raise CheckpointError(f"checkpoint {source}: tensor {name} has shape {found}, "
                                  f"this network's is {shape}")


def load_optimizer(optimizer: Any, tensors: dict[str, np.ndarray], doc: dict[str, Any],
                   source: Path, prefix: str = "optimizer") -> None:
    """Put a saved optimiser state into ``optimizer`` or raise ``CheckpointError``."""
    state = unflatten_optimizer(tensors, doc, source, prefix)
    try:
        optimizer.load_state_dict(state)
    except (ValueError, KeyError, TypeError, RuntimeError) as err:
        raise CheckpointError(f"checkpoint {source}: field optimizer does not fit this "
                              f"network's optimiser: {err}") from None
    # torch loads moments of any shape and fails only at the first update, after a rollout;
    # checked once torch has matched the groups, so a refused file leaves only this fresh
    # optimiser loaded, which the next checkpoint tried replaces or the refused run drops
    saved = (pid for group in doc["param_groups"] for pid in group["params"])
    params = (p for group in optimizer.param_groups for p in group["params"])
    expected = {}
    for pid, param in zip(saved, params, strict=True):
        for key, value in doc["state"].get(str(pid), {}).items():
            if value == "tensor":
                shape = () if key in _SCALAR_SLOTS else tuple(param.shape)
                expected[f"{prefix}.{pid}.{key}"] = shape
    check_shapes(tensors, expected, source)


def load_module(module: Any, tensors: dict[str, np.ndarray], source: Path,
                prefix: str = "policy.") -> None:
    """Put the tensors named ``prefix`` + a ``module.state_dict()`` key into ``module``, or
    raise a one-line ``CheckpointError`` naming the first missing, extra or misshapen one."""
    import torch

    own = module.state_dict()
    check_shapes(tensors, {prefix + key: tuple(value.shape) for key, value in own.items()},
                 source)
    extra = sorted(k for k in tensors if k.startswith(prefix) and k[len(prefix):] not in own)
    if extra:
        raise CheckpointError(f"checkpoint {source}: tensor {extra[0]} is not in this network")
    try:
        module.load_state_dict({key: torch.from_numpy(np.array(tensors[prefix + key]))
                                for key in own})
    except (RuntimeError, TypeError) as err:  # names and shapes fit: a dtype torch cannot copy
        raise CheckpointError(f"checkpoint {source} does not fit this network: "
                              f"{' '.join(str(err).split())}") from None


# --- writing -------------------------------------------------------------------------------

def write_pair(folder: Path, stem: str, tensors: dict[str, np.ndarray], doc: dict[str, Any],
               kind: str) -> Path:
    """Write ``stem.{digest}.safetensors`` (``tensors``) and then ``stem.json`` (``doc`` with
    the tensor file's name and SHA-256 and the JSON's own checksum), the JSON renamed over any
    older one in one step. Returns the JSON's path. ``kind`` prefixes the write points' labels."""
    from safetensors.numpy import save

    folder.mkdir(parents=True, exist_ok=True)
    data = save({k: np.ascontiguousarray(v) for k, v in tensors.items()})
    digest = sha256_bytes(data)
    weights = folder / f"{stem}.{digest[:16]}.safetensors"
    atomic_write(weights, data, f"{kind}.tensors")
    doc = plain_json({**doc, "weights": weights.name, "weights_sha256": digest})
    doc["meta_sha256"] = meta_digest(doc)
    path = folder / f"{stem}.json"
    atomic_write(path, json.dumps(doc, indent=1).encode(), f"{kind}.json")
    return path


def save_checkpoint(run_dir: Path, model: Any, meta: dict[str, Any], keep: int = 3) -> Path:
    """Write the PPO ``model``'s policy and optimiser at ``model.num_timesteps`` decisions,
    keeping the newest ``keep`` checkpoints."""
    folder = Path(run_dir) / "checkpoints"
    step = int(model.num_timesteps)
    tensors = {f"policy.{k}": v.detach().cpu().numpy()
               for k, v in model.policy.state_dict().items()}
    opt_tensors, opt_doc = flatten_optimizer(model.policy.optimizer.state_dict())
    tensors.update(opt_tensors)
    doc = {"format": FORMAT, "format_version": FORMAT_VERSION, "decisions": step,
           "optimizer": opt_doc, **meta}
    path = write_pair(folder, f"step_{step:012d}", tensors, doc, "checkpoint")
    prune(folder, _NAME, keep, ("step_",))
    crash_point("checkpoint.saved")
    return path


def _referenced(path: Path) -> str | None:
    """The tensor file a checkpoint JSON names, or None when it cannot be read."""
    try:
        doc = json.loads(path.read_bytes().decode("utf-8"))
        name = doc["weights"] if isinstance(doc, dict) else None
    except (OSError, ValueError, KeyError):
        return None
    return name if isinstance(name, str) else None


def prune(folder: Path, pattern: re.Pattern[str], keep: int, owned: tuple[str, ...],
          extra: Callable[[Path], list[str]] | None = None) -> None:
    """Keep the newest ``keep`` JSONs matching ``pattern`` (by the number in their name) and
    the tensor files they name; remove older ones, tensor files whose names start with one of
    ``owned`` that no kept JSON names (a save killed between its two writes, a step saved
    again) and leftover temporary files. ``extra``: more files a kept JSON needs."""
    found = sorted((int(m.group(1)), p) for p in folder.iterdir()
                   if (m := pattern.search(p.name)))
    kept = [p for _, p in found[-keep:]]
    for _, old in found[:-keep]:
        old.unlink(missing_ok=True)
    needed: set[str] = set()
    for path in kept:
        name = _referenced(path)
        if name is None:  # unreadable: keep whatever it may name
            needed |= {p.name for p in folder.glob(f"{path.stem}.*")}
        else:
            needed.add(name)
        if extra is not None:
            needed |= set(extra(path))
    for p in folder.iterdir():
        if not p.is_file() or p.name in needed:
            continue
        leftover = p.name.startswith(".") and p.name.endswith(".tmp")
        if leftover or (p.suffix == ".safetensors" and p.name.startswith(owned)):
            p.unlink(missing_ok=True)


def remove_checkpoints(run_dir: Path) -> int:
    """Remove a run's checkpoints (a restart); the number of checkpoint JSONs removed."""
    import shutil

    folder = Path(run_dir) / "checkpoints"
    if not folder.is_dir():
        return 0
    count = sum(1 for p in folder.iterdir() if _NAME.search(p.name))
    shutil.rmtree(folder)
    return count


# --- reading -------------------------------------------------------------------------------

def require(doc: dict[str, Any], field: str, kind: type | tuple[type, ...], source: Path,
            where: str = "") -> Any:
    """``doc[field]`` of ``kind``, or a ``CheckpointError`` naming ``source`` and the field."""
    return jsondoc.require(doc, field, kind, source, "checkpoint", CheckpointError, where)


def require_count(doc: dict[str, Any], field: str, source: Path, where: str = "",
                  most: int = MAX_DECISIONS) -> int:
    """An integer field in [0, ``most``]."""
    value = require(doc, field, int, source, where)
    if not 0 <= value <= most:
        raise CheckpointError(f"checkpoint {source}: field {where}{field} = {value} is outside "
                              f"[0, {most:,}]")
    return value


def read_json(path: Path) -> dict[str, Any]:
    """A checkpoint JSON's object, or a ``CheckpointError`` saying why it cannot be one."""
    return jsondoc.read_object(path, "checkpoint", CheckpointError)


def read_named(path: Path, file: Path, field: str, what: str) -> bytes:
    """The bytes of ``file`` (a ``what``: "tensor file", "dataset"), which field ``field`` of
    checkpoint ``path`` names, or a ``CheckpointError`` saying why not."""
    problem = jsondoc.not_a_file(file)
    if problem is None:
        try:
            return file.read_bytes()
        except OSError as err:
            problem = f"cannot be read: {err.strerror or err}"
    if problem == jsondoc.MISSING:
        raise CheckpointError(f"checkpoint {path} lacks its {what} {file.name} (field {field})")
    raise CheckpointError(f"checkpoint {path}: its {what} {file.name} (field {field}) "
                          f"{problem}")


def read_pair(path: Path, form: str, versions: tuple[int, ...],
              check: Callable[[dict[str, Any], Path], None] | None = None,
              expect: dict[str, Any] | None = None,
              upgrade: Callable[[dict[str, Any]], dict[str, Any]] | None = None,
              ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Load and verify a JSON + tensor file pair written by ``write_pair``: its format, its
    fields (``check`` raises on a bad one), the JSON's checksum, the ``expect``ed fields, the
    tensors' checksum. ``CheckpointMismatch`` when only ``expect`` fails. ``upgrade``: the
    checksummed fields as the current version names them (older writers' names replaced),
    before they are compared with ``expect``."""
    from safetensors.numpy import load

    path = Path(path)
    doc = read_json(path)
    if doc.get("format") != form or doc.get("format_version") not in versions:
        found = f"{doc.get('format')!r} v{doc.get('format_version')!r}"
        raise CheckpointError(f"{path} is not a {form} checkpoint of version "
                              f"{' or '.join(map(str, versions))} (fields format and "
                              f"format_version: {found})")
    name = require(doc, "weights", str, path)
    if Path(name).name != name or name.startswith("."):
        raise CheckpointError(f"checkpoint {path}: field weights must name a file beside it, "
                              f"found {name!r}")
    digest = require(doc, "weights_sha256", str, path)
    # the fields first: a damaged one is then named, not only found by the checksum
    if check is not None:
        check(doc, path)
    if doc["format_version"] >= 2:
        recorded = require(doc, "meta_sha256", str, path)
        if meta_digest(doc) != recorded:
            raise CheckpointError(f"checkpoint {path} is corrupted: its fields' SHA-256 differs "
                                  "from the one recorded in field meta_sha256")
    if upgrade is not None:
        doc = upgrade(doc)
    for key, value in (expect or {}).items():
        if plain_json(doc.get(key)) != plain_json(value):
            raise CheckpointMismatch(f"checkpoint {path} was made with {key}={doc.get(key)!r}, "
                                     f"this run has {key}={value!r}: use another --out folder, "
                                     "the same settings or --restart")
    weights = path.with_name(name)
    data = read_named(path, weights, "weights", "tensor file")
    if sha256_bytes(data) != digest:
        raise CheckpointError(f"checkpoint tensors {weights} are corrupted (SHA-256 differs "
                              f"from field weights_sha256 of {path.name})")
    try:
        tensors = load(data)
    except Exception as err:  # safetensors raises its own error types
        raise CheckpointError(f"checkpoint tensors {weights} are corrupted: {err}") from None
    return doc, tensors


def _check_ppo(doc: dict[str, Any], path: Path) -> None:
    """The fields a PPO checkpoint's resume reads, with their types."""
    decisions = require_count(doc, "decisions", path)
    m = _NAME.search(path.name)
    if m and int(m.group(1)) != decisions:
        raise CheckpointError(f"checkpoint {path}: field decisions = {decisions} disagrees "
                              f"with its file name (step {int(m.group(1))})")
    require(doc, "stage", str, path)
    require(doc, "network", dict, path)
    optimizer = require(doc, "optimizer", dict, path)
    state = require(optimizer, "state", dict, path, "optimizer.")
    for pid in state:
        if not pid.isdigit():
            raise CheckpointError(f"checkpoint {path}: field optimizer.state.{pid} must be "
                                  "keyed by a parameter number")
        require(state, pid, dict, path, "optimizer.state.")
    groups = require(optimizer, "param_groups", list, path, "optimizer.")
    for i, group in enumerate(groups):
        if not isinstance(group, dict):
            raise CheckpointError(f"checkpoint {path}: field optimizer.param_groups[{i}] must "
                                  f"be object, found {type_name(group)}")
    curve = require(doc, "curve", dict, path)
    for key in ("evals", "rollouts"):
        if key in curve:
            rows = require(curve, key, list, path, "curve.")
            for i, row in enumerate(rows):
                if not isinstance(row, dict) or not isinstance(row.get("steps"), int):
                    raise CheckpointError(f"checkpoint {path}: field curve.{key}[{i}] must be "
                                          "an object with an integer steps")
    if "decisions" in curve:
        require_count(curve, "decisions", path, "curve.")
    if "train_wall_s" in curve:
        require(curve, "train_wall_s", float, path, "curve.")
    if "warm_start" in curve:
        require(curve, "warm_start", dict, path, "curve.")


def upgrade_ppo(doc: dict[str, Any]) -> dict[str, Any]:
    """A PPO checkpoint's fields as this version names them: the network's ``env`` (the
    player, before the setting was named ``player``) becomes ``player``."""
    network = doc["network"]
    if "env" in network and "player" not in network:
        network = {("player" if key == "env" else key): value for key, value in network.items()}
        doc = {**doc, "network": network}
    return doc


def read_checkpoint(path: Path, expect: dict[str, Any] | None = None,
                    ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Load and verify a checkpoint; ``expect`` lists JSON fields that must match (e.g. the
    stage and the network). Raises ``CheckpointError`` naming the file and the field."""
    return read_pair(path, FORMAT, READABLE_VERSIONS, _check_ppo, expect, upgrade_ppo)


def checkpoints(folder: Path, pattern: re.Pattern[str] = _NAME) -> list[Path]:
    """The checkpoint JSONs in ``folder`` (a run's ``checkpoints/``), newest (the highest
    number in their name) first."""
    folder = Path(folder)
    if not folder.is_dir():
        return []
    found = [(int(m.group(1)), p) for p in folder.iterdir() if (m := pattern.search(p.name))]
    return [p for _, p in sorted(found, reverse=True)]


def latest_checkpoint(run_dir: Path) -> Path | None:
    """The newest checkpoint JSON of a run (by decisions), or None."""
    found = checkpoints(Path(run_dir) / "checkpoints")
    return found[0] if found else None


def newest_intact(paths: list[Path], load: Callable[[Path], Any], say: Say) -> Any:
    """``load`` each of ``paths`` (newest first) until one succeeds and return its result
    (None when there are no paths); ``say`` a line for each one skipped and why.
    ``CheckpointMismatch`` is not skipped: the folder belongs to another run. When every one
    fails: a ``CheckpointError`` listing them. A directory under a checkpoint's name is
    refused before any of them is tried: the run's saves and pruning could not replace it, so
    it would fail after training an interval."""
    for path in paths:
        if path.is_dir() and not path.is_symlink():
            raise CheckpointError(f"checkpoint {path} {jsondoc.not_a_file(path)}: a save "
                                  "cannot replace it; remove it or train again with --restart")
    skipped: list[str] = []
    for path in paths:
        try:
            result = load(path)
        except CheckpointMismatch:
            raise
        except CheckpointError as err:
            say(f"skipping checkpoint {path.name}: {err}")
            skipped.append(f"{path.name}: {err}")
            continue
        if skipped:
            say(f"resuming from the newest intact checkpoint, {path.name}, instead")
        return result
    if skipped:
        raise CheckpointError(f"no intact checkpoint in {paths[0].parent} ({'; '.join(skipped)})"
                              ": remove them or train again with --restart")
    return None


def resume(model: Any, run_dir: Path, expect: dict[str, Any], say: Say,
           ) -> tuple[Path, dict[str, Any]] | None:
    """Restore the newest intact checkpoint of ``run_dir`` into PPO ``model``; (its path, its
    JSON), or None when the run has none."""
    def load(path: Path) -> tuple[Path, dict[str, Any]]:
        doc, tensors = read_checkpoint(path, expect)
        restore(model, doc, tensors, path)
        return path, doc

    found: tuple[Path, dict[str, Any]] | None = newest_intact(
        checkpoints(Path(run_dir) / "checkpoints"), load, say)
    return found


def restore(model: Any, doc: dict[str, Any], tensors: dict[str, np.ndarray],
            source: Path | None = None) -> None:
    """Put a checkpoint's policy and optimiser state into a freshly built PPO ``model``."""
    where = Path(source or "(unnamed)")
    load_module(model.policy, tensors, where)
    load_optimizer(model.policy.optimizer, tensors, doc["optimizer"], where)
    model.num_timesteps = int(doc["decisions"])
