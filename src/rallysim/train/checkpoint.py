"""Training checkpoints: safetensors for every tensor, JSON for everything else, no pickle.

A checkpoint of an SB3 PPO run is two files in ``RUN/checkpoints/``:
``step_{decisions:012d}.safetensors`` (the policy's and the optimiser's tensors) and
``step_{decisions:012d}.json`` (stage, config, decisions done, the optimiser's structure, the
learning curve so far and a SHA-256 of the tensor file). Both are written to temporary names and
renamed into place, the JSON last, so a run killed at any moment (even ``kill -9``) leaves only
complete checkpoints behind and resumes from the newest, losing at most one interval.
"""

from __future__ import annotations

import json
import os
import re
from pathlib import Path
from typing import Any

import numpy as np

FORMAT = "rallysim-train-checkpoint"
FORMAT_VERSION = 1
_NAME = re.compile(r"step_(\d{12})\.json$")


class CheckpointError(ValueError):
    """A checkpoint that cannot be used: corrupted, truncated or made for another run."""


def _atomic_write(path: Path, data: bytes) -> None:
    tmp = path.with_name(path.name + ".tmp")
    with open(tmp, "wb") as f:
        f.write(data)
        f.flush()
        os.fsync(f.fileno())
    os.replace(tmp, path)


def _flatten_optimizer(state: dict[str, Any]) -> tuple[dict[str, np.ndarray], dict[str, Any]]:
    """A torch optimiser ``state_dict`` -> (tensors, JSON-able structure)."""
    tensors: dict[str, np.ndarray] = {}
    layout: dict[str, dict[str, Any]] = {}
    for pid, slots in state["state"].items():
        layout[str(pid)] = {}
        for key, value in slots.items():
            if hasattr(value, "detach"):
                tensors[f"optimizer.{pid}.{key}"] = value.detach().cpu().numpy()
                layout[str(pid)][key] = "tensor"
            else:
                layout[str(pid)][key] = value
    groups = [{k: v for k, v in g.items()} for g in state["param_groups"]]
    return tensors, {"state": layout, "param_groups": groups}


def _unflatten_optimizer(tensors: dict[str, np.ndarray], doc: dict[str, Any]) -> dict[str, Any]:
    import torch

    state: dict[int, dict[str, Any]] = {}
    for pid, slots in doc["state"].items():
        state[int(pid)] = {
            key: torch.from_numpy(np.array(tensors[f"optimizer.{pid}.{key}"]))
            if value == "tensor" else value
            for key, value in slots.items()
        }
    return {"state": state, "param_groups": doc["param_groups"]}


def save_checkpoint(run_dir: Path, model: Any, meta: dict[str, Any], keep: int = 3) -> Path:
    """Write the PPO ``model``'s policy and optimiser at ``model.num_timesteps`` decisions,
    keeping the newest ``keep`` checkpoints."""
    from safetensors.numpy import save

    from rallysim.policies.mlp import sha256_file

    folder = Path(run_dir) / "checkpoints"
    folder.mkdir(parents=True, exist_ok=True)
    step = int(model.num_timesteps)
    tensors = {f"policy.{k}": v.detach().cpu().numpy()
               for k, v in model.policy.state_dict().items()}
    opt_tensors, opt_doc = _flatten_optimizer(model.policy.optimizer.state_dict())
    tensors.update(opt_tensors)
    weights = folder / f"step_{step:012d}.safetensors"
    _atomic_write(weights, save({k: np.ascontiguousarray(v) for k, v in tensors.items()}))
    doc = {"format": FORMAT, "format_version": FORMAT_VERSION, "decisions": step,
           "weights": weights.name, "weights_sha256": sha256_file(weights),
           "optimizer": opt_doc, **meta}
    path = folder / f"step_{step:012d}.json"
    _atomic_write(path, json.dumps(doc, indent=1, default=json_default).encode())
    _prune(folder, keep)
    return path


def _prune(folder: Path, keep: int) -> None:
    found = sorted((int(m.group(1)), p) for p in folder.iterdir() if (m := _NAME.search(p.name)))
    for _, old in found[:-keep]:
        old.unlink(missing_ok=True)
        old.with_suffix(".safetensors").unlink(missing_ok=True)


def json_default(value: Any) -> Any:
    """``json.dumps``'s ``default`` for the NumPy scalars and arrays in run records (json
    writes tuples as lists itself)."""
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


def latest_checkpoint(run_dir: Path) -> Path | None:
    """The newest checkpoint JSON of a run (by decisions), or None."""
    folder = Path(run_dir) / "checkpoints"
    if not folder.is_dir():
        return None
    found = sorted((int(m.group(1)), p) for p in folder.iterdir()
                   if (m := _NAME.search(p.name)))
    return found[-1][1] if found else None


def read_checkpoint(path: Path, expect: dict[str, Any] | None = None,
                    ) -> tuple[dict[str, Any], dict[str, np.ndarray]]:
    """Load and verify a checkpoint; ``expect`` lists JSON fields that must match (e.g. the
    stage and the network). Raises ``CheckpointError`` saying what is wrong."""
    from safetensors.numpy import load_file

    from rallysim.policies.mlp import sha256_file

    path = Path(path)
    try:
        doc = json.loads(path.read_text())
    except (OSError, json.JSONDecodeError) as err:
        raise CheckpointError(f"checkpoint {path} is unreadable or corrupted: {err}") from None
    if doc.get("format") != FORMAT or doc.get("format_version") != FORMAT_VERSION:
        raise CheckpointError(f"{path} is not a {FORMAT} v{FORMAT_VERSION} checkpoint")
    weights = path.with_name(doc["weights"])
    if not weights.is_file():
        raise CheckpointError(f"checkpoint {path} lacks its tensor file {weights.name}")
    if sha256_file(weights) != doc["weights_sha256"]:
        raise CheckpointError(f"checkpoint tensors {weights} are corrupted (SHA-256 differs "
                              "from the one recorded in its JSON)")
    for key, value in (expect or {}).items():
        if json.loads(json.dumps(doc.get(key), default=json_default)) != json.loads(
                json.dumps(value, default=json_default)):
            raise CheckpointError(f"checkpoint {path} was made with {key}={doc.get(key)!r}, "
                                  f"this run has {key}={value!r}: use another --out folder "
                                  "or the same settings")
    try:
        tensors = load_file(str(weights))
    except Exception as err:  # safetensors raises its own error types
        raise CheckpointError(f"checkpoint tensors {weights} are corrupted: {err}") from None
    return doc, tensors


def restore(model: Any, doc: dict[str, Any], tensors: dict[str, np.ndarray]) -> None:
    """Put a checkpoint's policy and optimiser state into a freshly built PPO ``model``."""
    import torch

    policy_state = {k[len("policy."):]: torch.from_numpy(np.array(v))
                    for k, v in tensors.items() if k.startswith("policy.")}
    try:
        model.policy.load_state_dict(policy_state)
    except RuntimeError as err:
        raise CheckpointError(f"checkpoint does not fit this network: {err}") from None
    model.policy.optimizer.load_state_dict(_unflatten_optimizer(tensors, doc["optimizer"]))
    model.num_timesteps = int(doc["decisions"])
