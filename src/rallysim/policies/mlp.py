"""Trained policies as plain weights: ``PREFIX.safetensors`` + ``PREFIX.json``, run in NumPy.

No pickle anywhere: the weights are a safetensors file (``layers.{i}.weight`` (out, in),
``layers.{i}.bias`` (out,), ``log_std`` (actions,)); the architecture, the observation and
action conventions and a SHA-256 of the weights are a JSON document. Running a policy needs
neither torch nor Stable-Baselines3.
"""

from __future__ import annotations

import hashlib
from pathlib import Path
from typing import Any

import numpy as np

from rallysim.jsondoc import MISSING, not_a_file, read_object, require

FORMAT = "rallysim-mlp-policy"
FORMAT_VERSION = 1
ACTIVATIONS = {"tanh": np.tanh, "relu": lambda x: np.maximum(x, 0.0)}


def policy_paths(prefix: str | Path) -> tuple[Path, Path]:
    prefix = Path(prefix)
    return prefix.with_name(prefix.name + ".safetensors"), prefix.with_name(prefix.name + ".json")


def sha256_file(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


class MLPPolicy:
    """A deterministic MLP actor: ``policy(obs (N, d) or (d,)) -> actions``, the Gaussian's
    mean clipped to the action bounds."""

    def __init__(self, layers: list[tuple[np.ndarray, np.ndarray]], activation: str,
                 low: np.ndarray, high: np.ndarray, log_std: np.ndarray,
                 spec: dict[str, Any]) -> None:
        self.layers = layers
        self.activation = activation
        self._act = ACTIVATIONS[activation]
        self.low, self.high = low, high
        self.log_std = log_std
        self.spec = spec
        self.obs_size = layers[0][0].shape[1]

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        x = np.asarray(obs, np.float32)
        single = x.ndim == 1
        if x.shape[-1] != self.obs_size:
            raise ValueError(f"expected observations of size {self.obs_size}, got {x.shape}")
        x = np.atleast_2d(x)
        last = len(self.layers) - 1
        for i, (w, b) in enumerate(self.layers):
            x = x @ w.T + b
            if i < last:
                x = self._act(x)
        actions = np.clip(x, self.low, self.high)
        return actions[0] if single else actions


def load_policy(prefix: str | Path, expect_obs_size: int | None = None) -> MLPPolicy:
    """Load a policy written by ``rallysim.train.export.save_policy``.

    Raises ``FileNotFoundError`` for missing files and ``ValueError`` naming the file and the
    field for anything else: a path that is not a regular file (saying what it is), a
    corrupted or foreign file, a weights/JSON mismatch, tensors of the wrong shape (a bias that
    would broadcast), non-finite weights or action bounds, or an unexpected observation
    size."""
    from safetensors import SafetensorError
    from safetensors.numpy import load_file

    weights_path, json_path = policy_paths(prefix)
    for path in (weights_path, json_path):
        problem = not_a_file(path)
        if problem == MISSING:
            raise FileNotFoundError(f"policy file {path} {problem}")
        if problem is not None:
            raise ValueError(f"policy file {path} {problem}")
    spec = read_object(json_path, "policy")

    def field(doc: Any, name: str, kind: type | tuple[type, ...], where: str = "") -> Any:
        return require(doc, name, kind, json_path, "policy", where=where)

    if spec.get("format") != FORMAT or spec.get("format_version") != FORMAT_VERSION:
        raise ValueError(f"{json_path} is not a {FORMAT} v{FORMAT_VERSION} document")
    digest = field(spec, "weights_sha256", (str, type(None))) if "weights_sha256" in spec else None
    if digest is not None and sha256_file(weights_path) != digest:
        raise ValueError(f"{weights_path} does not match its JSON (SHA-256 differs): the file "
                         "is corrupted or belongs to another policy")
    arch = field(spec, "architecture", dict)
    n_layers = field(arch, "n_layers", int, "architecture.")
    sizes = field(arch, "sizes", list, "architecture.")
    activation = field(arch, "activation", str, "architecture.")
    if (n_layers < 1 or len(sizes) != n_layers + 1
            or not all(type(n) is int and n >= 1 for n in sizes)):
        raise ValueError(f"policy {json_path}: architecture.sizes must be {n_layers} + 1 "
                         f"positive integers (architecture.n_layers = {n_layers}), got {sizes}")
    if activation not in ACTIVATIONS:
        raise ValueError(f"policy {json_path}: architecture.activation must be one of "
                         f"{sorted(ACTIVATIONS)}, got {activation!r}")
    act = field(spec, "action", dict)
    bounds = [_finite_vector(field(act, key, list, "action."), sizes[-1], json_path,
                             f"action.{key}") for key in ("low", "high")]
    if np.any(bounds[0] > bounds[1]):
        raise ValueError(f"policy {json_path}: action.low exceeds action.high")
    try:
        tensors = load_file(str(weights_path))
    except (SafetensorError, OSError, ValueError) as err:
        raise ValueError(f"{weights_path} is corrupted: {err}") from None

    def tensor(name: str, shape: tuple[int, ...]) -> np.ndarray:
        if name not in tensors:
            raise ValueError(f"{weights_path} lacks tensor {name!r}")
        t = tensors[name]
        if t.shape != shape:
            raise ValueError(f"{weights_path}: tensor {name} has shape {t.shape}, the JSON's "
                             f"architecture.sizes {sizes} needs {shape}")
        if t.dtype.kind != "f" or not np.isfinite(t).all():
            raise ValueError(f"{weights_path}: tensor {name} must hold finite real numbers")
        return t

    layers = [(tensor(f"layers.{i}.weight", (sizes[i + 1], sizes[i])),
               tensor(f"layers.{i}.bias", (sizes[i + 1],))) for i in range(n_layers)]
    log_std = tensor("log_std", (sizes[-1],))
    if expect_obs_size is not None and sizes[0] != expect_obs_size:
        raise ValueError(f"{prefix} takes {sizes[0]} observations, this use needs "
                         f"{expect_obs_size}")
    return MLPPolicy(layers, activation, bounds[0], bounds[1], log_std, spec)


def _finite_vector(values: list, size: int, source: Path, name: str) -> np.ndarray:
    if len(values) != size or not all(type(v) in (int, float) for v in values):
        raise ValueError(f"policy {source}: {name} must be {size} numbers, got "
                         f"{str(values)[:60]}")
    out = np.asarray(values, np.float32)
    if not np.isfinite(out).all():
        raise ValueError(f"policy {source}: {name} must be finite, got {str(values)[:60]}")
    return out
