"""Export trained actors as plain weights: ``PREFIX.safetensors`` + ``PREFIX.json``.

No pickle anywhere: the weights are a safetensors file (tensors ``layers.{i}.weight`` (out, in),
``layers.{i}.bias`` (out,), and ``log_std`` (actions,)), the architecture and the observation /
action conventions a JSON document. ``load_policy`` rebuilds the deterministic actor (the mean
action, clipped to the action bounds) in NumPy, so running a policy needs neither torch nor SB3.
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from safetensors.numpy import load_file, save_file

FORMAT = "rallysim-mlp-policy"
FORMAT_VERSION = 1
ACTIVATIONS = {"tanh": np.tanh, "relu": lambda x: np.maximum(x, 0.0)}


def _paths(prefix: str | Path) -> tuple[Path, Path]:
    prefix = Path(prefix)
    return prefix.with_name(prefix.name + ".safetensors"), prefix.with_name(prefix.name + ".json")


def _actor_layers(model: Any) -> tuple[list[tuple[np.ndarray, np.ndarray]], str, np.ndarray]:
    """(weight, bias) of the actor's linear layers, its activation and log-std, from an SB3
    ``ActorCriticPolicy`` with an identity (flatten) feature extractor."""
    import torch

    policy = model.policy
    if policy.features_extractor.__class__.__name__ != "FlattenExtractor":
        raise TypeError("only MLP policies over flat observations can be exported")
    if getattr(model, "_vec_normalize_env", None) is not None:
        raise TypeError("observation normalisation (VecNormalize) is not exported")
    layers: list[tuple[np.ndarray, np.ndarray]] = []
    activation = None
    for module in policy.mlp_extractor.policy_net:
        if isinstance(module, torch.nn.Linear):
            layers.append((module.weight.detach().cpu().numpy(),
                           module.bias.detach().cpu().numpy()))
        else:
            name = {torch.nn.Tanh: "tanh", torch.nn.ReLU: "relu"}.get(type(module))
            if name is None or activation not in (None, name):
                raise TypeError(f"unsupported actor activation {module!r}")
            activation = name
    head = policy.action_net
    layers.append((head.weight.detach().cpu().numpy(), head.bias.detach().cpu().numpy()))
    log_std = policy.log_std.detach().cpu().numpy()
    return layers, activation or "tanh", log_std


def save_policy(model: Any, path_prefix: str | Path, env_id: str = "RallySim/SimpleReturn-v0",
                metadata: dict[str, Any] | None = None) -> tuple[Path, Path]:
    """Write the actor of SB3 PPO ``model`` to ``PREFIX.safetensors`` and ``PREFIX.json``."""
    layers, activation, log_std = _actor_layers(model)
    tensors = {"log_std": np.ascontiguousarray(log_std, np.float32)}
    for i, (w, b) in enumerate(layers):
        tensors[f"layers.{i}.weight"] = np.ascontiguousarray(w, np.float32)
        tensors[f"layers.{i}.bias"] = np.ascontiguousarray(b, np.float32)
    obs_space, act_space = model.observation_space, model.action_space
    sizes = [int(layers[0][0].shape[1])] + [int(w.shape[0]) for w, _ in layers]
    doc = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "env_id": env_id,
        "architecture": {"type": "mlp", "sizes": sizes, "activation": activation,
                         "output_activation": None, "n_layers": len(layers)},
        "observation": {"shape": list(obs_space.shape),
                        "low": np.asarray(obs_space.low, float).tolist(),
                        "high": np.asarray(obs_space.high, float).tolist()},
        "action": {"shape": list(act_space.shape),
                   "low": np.asarray(act_space.low, float).tolist(),
                   "high": np.asarray(act_space.high, float).tolist(),
                   "deterministic": "mean of a diagonal Gaussian, clipped to [low, high]"},
        "metadata": metadata or {},
    }
    weights_path, json_path = _paths(path_prefix)
    weights_path.parent.mkdir(parents=True, exist_ok=True)
    save_file(tensors, str(weights_path), metadata={"format": FORMAT})
    json_path.write_text(json.dumps(doc, indent=1, default=_json_default))
    return weights_path, json_path


def _json_default(value: Any) -> Any:
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    raise TypeError(f"not JSON serialisable: {type(value).__name__}")


class MLPPolicy:
    """A deterministic MLP actor in NumPy: ``policy(obs (N, d) or (d,)) -> actions``."""

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


def load_policy(path_prefix: str | Path) -> MLPPolicy:
    """Load a policy written by ``save_policy`` (safetensors + JSON only; nothing unpickled)."""
    weights_path, json_path = _paths(path_prefix)
    spec = json.loads(json_path.read_text())
    if spec.get("format") != FORMAT or spec.get("format_version") != FORMAT_VERSION:
        raise ValueError(f"{json_path} is not a {FORMAT} v{FORMAT_VERSION} document")
    tensors = load_file(str(weights_path))
    arch = spec["architecture"]
    layers = [(tensors[f"layers.{i}.weight"], tensors[f"layers.{i}.bias"])
              for i in range(arch["n_layers"])]
    sizes = [int(layers[0][0].shape[1])] + [int(w.shape[0]) for w, _ in layers]
    if sizes != arch["sizes"]:
        raise ValueError(f"weights have layer sizes {sizes}, the JSON says {arch['sizes']}")
    act = spec["action"]
    low = np.asarray(act["low"], np.float32)
    high = np.asarray(act["high"], np.float32)
    return MLPPolicy(layers, arch["activation"], low, high, tensors["log_std"], spec)
