"""Trained policies as plain weights: ``PREFIX.safetensors`` + ``PREFIX.json``, run in NumPy.

No pickle anywhere: the weights are a safetensors file (``layers.{i}.weight`` (out, in),
``layers.{i}.bias`` (out,), ``log_std`` (actions,)); the architecture, the observation and
action conventions and a SHA-256 of the weights are a JSON document. Running a policy needs
neither torch nor Stable-Baselines3.
"""

from __future__ import annotations

import hashlib
import json
from pathlib import Path
from typing import Any

import numpy as np

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

    Raises ``FileNotFoundError`` for missing files and ``ValueError`` naming the problem for a
    corrupted file, a weights/JSON mismatch or an unexpected observation size."""
    from safetensors import SafetensorError
    from safetensors.numpy import load_file

    weights_path, json_path = policy_paths(prefix)
    for path in (weights_path, json_path):
        if not path.is_file():
            raise FileNotFoundError(f"policy file {path} does not exist")
    try:
        spec = json.loads(json_path.read_text())
    except json.JSONDecodeError as err:
        raise ValueError(f"{json_path} is corrupted (not JSON): {err}") from None
    if spec.get("format") != FORMAT or spec.get("format_version") != FORMAT_VERSION:
        raise ValueError(f"{json_path} is not a {FORMAT} v{FORMAT_VERSION} document")
    digest = spec.get("weights_sha256")
    if digest is not None and sha256_file(weights_path) != digest:
        raise ValueError(f"{weights_path} does not match its JSON (SHA-256 differs): the file "
                         "is corrupted or belongs to another policy")
    try:
        tensors = load_file(str(weights_path))
    except (SafetensorError, OSError, ValueError) as err:
        raise ValueError(f"{weights_path} is corrupted: {err}") from None
    arch = spec["architecture"]
    try:
        layers = [(tensors[f"layers.{i}.weight"], tensors[f"layers.{i}.bias"])
                  for i in range(arch["n_layers"])]
        log_std = tensors["log_std"]
    except KeyError as err:
        raise ValueError(f"{weights_path} lacks tensor {err}") from None
    sizes = [int(layers[0][0].shape[1])] + [int(w.shape[0]) for w, _ in layers]
    if sizes != arch["sizes"]:
        raise ValueError(f"weights have layer sizes {sizes}, the JSON says {arch['sizes']}")
    if expect_obs_size is not None and sizes[0] != expect_obs_size:
        raise ValueError(f"{prefix} takes {sizes[0]} observations, this use needs "
                         f"{expect_obs_size}")
    act = spec["action"]
    return MLPPolicy(layers, arch["activation"], np.asarray(act["low"], np.float32),
                     np.asarray(act["high"], np.float32), log_std, spec)
