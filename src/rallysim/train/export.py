"""Export trained actors as plain weights: ``PREFIX.safetensors`` + ``PREFIX.json``.

The format and its NumPy loader live in ``rallysim.policies.mlp`` (no torch needed to run a
policy). ``write_policy`` writes it from plain arrays, whatever trained them; ``save_policy``
extracts them from an SB3 ``ActorCriticPolicy`` (``rallysim.rllib.export`` from an RLlib
RLModule).
"""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np
from safetensors.numpy import save_file

from rallysim.jsondoc import jsonable
from rallysim.policies.mlp import FORMAT, FORMAT_VERSION, MLPPolicy, policy_paths, sha256_file
from rallysim.train.checkpoint import json_default

Layers = list[tuple[np.ndarray, np.ndarray]]  # (weight (out, in), bias (out,)) per linear layer


def _actor_modules(model: Any) -> tuple[list[Any], str]:
    """The actor's linear modules, the Gaussian's mean head last, and its activation, from an
    SB3 ``ActorCriticPolicy`` with an identity (flatten) feature extractor."""
    import torch

    policy = model.policy
    if policy.features_extractor.__class__.__name__ != "FlattenExtractor":
        raise TypeError("only MLP policies over flat observations can be exported")
    if getattr(model, "_vec_normalize_env", None) is not None:
        raise TypeError("observation normalisation (VecNormalize) is not exported")
    linears: list[Any] = []
    activation = None
    for module in policy.mlp_extractor.policy_net:
        if isinstance(module, torch.nn.Linear):
            linears.append(module)
        else:
            name = {torch.nn.Tanh: "tanh", torch.nn.ReLU: "relu"}.get(type(module))
            if name is None or activation not in (None, name):
                raise TypeError(f"unsupported actor activation {module!r}")
            activation = name
    return [*linears, policy.action_net], activation or "tanh"


def _actor_layers(model: Any) -> tuple[Layers, str, np.ndarray]:
    """(weight, bias) of the actor's linear layers, its activation and log-std."""
    linears, activation = _actor_modules(model)
    layers = [(m.weight.detach().cpu().numpy(), m.bias.detach().cpu().numpy())
              for m in linears]
    return layers, activation, model.policy.log_std.detach().cpu().numpy()


def load_actor(model: Any, policy: Any) -> None:
    """Put an exported actor (``rallysim.policies.mlp.MLPPolicy``) into SB3 PPO ``model``'s
    actor, the inverse of ``save_policy``: its linear layers, activation and log-std must be
    the model's shape; the critic is left as it is."""
    import torch

    if not isinstance(policy, MLPPolicy):
        raise ValueError(f"an exported MLP actor is needed to start from, got {policy!r}")
    linears, activation = _actor_modules(model)
    log_std = model.policy.log_std
    shapes = [(tuple(m.weight.shape), tuple(m.bias.shape)) for m in linears]
    given = [(w.shape, b.shape) for w, b in policy.layers]
    if given != shapes or policy.activation != activation or \
            policy.log_std.shape != tuple(log_std.shape):
        raise ValueError(f"the policy's actor ({len(given)} layers, {policy.activation}) does "
                         f"not fit this model's ({len(shapes)} layers, {activation}): "
                         f"{given} against {shapes}")
    with torch.no_grad():
        for module, (w, b) in zip(linears, policy.layers, strict=True):
            module.weight.copy_(torch.as_tensor(w))
            module.bias.copy_(torch.as_tensor(b))
        log_std.copy_(torch.as_tensor(policy.log_std))


def save_policy(model: Any, path_prefix: str | Path, env_id: str = "RallySim/SimpleReturn-v0",
                metadata: dict[str, Any] | None = None) -> tuple[Path, Path]:
    """Write the actor of SB3 PPO ``model`` to ``PREFIX.safetensors`` and ``PREFIX.json``."""
    layers, activation, log_std = _actor_layers(model)
    return write_policy(layers, activation, log_std, model.observation_space,
                        model.action_space, path_prefix, env_id=env_id, metadata=metadata)


def write_policy(layers: Layers, activation: str, log_std: np.ndarray, obs_space: Any,
                 act_space: Any, path_prefix: str | Path,
                 env_id: str = "RallySim/SimpleReturn-v0",
                 metadata: dict[str, Any] | None = None) -> tuple[Path, Path]:
    """Write an MLP actor to ``PREFIX.safetensors`` and ``PREFIX.json``.

    ``layers``: (weight (out, in), bias (out,)) per linear layer, ``activation`` between them
    (none after the last, whose outputs are the Gaussian's means); ``log_std`` (actions,);
    ``obs_space``/``act_space``: the Gymnasium ``Box`` spaces the actor reads and writes."""
    tensors = {"log_std": np.ascontiguousarray(log_std, np.float32)}
    for i, (w, b) in enumerate(layers):
        tensors[f"layers.{i}.weight"] = np.ascontiguousarray(w, np.float32)
        tensors[f"layers.{i}.bias"] = np.ascontiguousarray(b, np.float32)
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
        "metadata": jsonable(metadata or {}),
    }
    weights_path, json_path = policy_paths(path_prefix)
    weights_path.parent.mkdir(parents=True, exist_ok=True)
    save_file(tensors, str(weights_path), metadata={"format": FORMAT})
    doc["weights_sha256"] = sha256_file(weights_path)
    json_path.write_text(json.dumps(doc, indent=1, default=json_default))
    return weights_path, json_path

