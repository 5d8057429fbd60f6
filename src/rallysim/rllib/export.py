"""RLlib PPO RLModule actor -> RallySim's policy files (``PREFIX.safetensors`` + JSON).

RLlib's default PPO module (``vf_share_layers=False``, ``free_log_std=True``) computes the
action means as ``pi.net(encoder.actor_encoder(obs))``: the actor encoder's linear layers with
their activation, then one linear layer to the means; the log-std is a free vector. That is
exactly the MLP of ``rallysim.policies.mlp``, so the weights copy over unchanged and the file
is written by the same ``write_policy`` as SB3's.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np
import torch

from rallysim.train.export import Layers, write_policy

_ACTIVATIONS = {torch.nn.Tanh: "tanh", torch.nn.ReLU: "relu"}


def _walk(part: torch.nn.Module, layers: Layers, activations: list[str]) -> None:
    for sub in part.modules():
        if isinstance(sub, torch.nn.Linear):
            layers.append((sub.weight.detach().cpu().numpy().copy(),
                           sub.bias.detach().cpu().numpy().copy()))
        elif type(sub) in _ACTIVATIONS:
            activations.append(_ACTIVATIONS[type(sub)])
        elif not list(sub.children()) and any(True for _ in sub.parameters(recurse=False)):
            raise TypeError(f"cannot export actor layer {sub!r}")


def actor_layers(module: Any) -> tuple[Layers, str, np.ndarray]:
    """(weight, bias) per linear layer of the deterministic actor, its activation and log-std,
    from an RLlib ``DefaultPPOTorchRLModule`` built with ``free_log_std=True``."""
    encoder = getattr(module.encoder, "actor_encoder", None)
    if encoder is None:
        raise TypeError("the RLModule shares its encoder with the critic; train with "
                        "vf_share_layers=False to export the actor alone")
    log_std = getattr(module.pi, "log_std", None)
    if log_std is None:
        raise TypeError("the policy head outputs its log-std per observation; train with "
                        "free_log_std=True to export a RallySim policy")
    layers: Layers = []
    activations: list[str] = []
    _walk(encoder, layers, activations)
    _walk(module.pi.net, layers, activations)
    kinds = set(activations)
    if len(kinds) > 1 or len(activations) != len(layers) - 1:
        raise TypeError(f"the actor must be linear layers with one activation between them, "
                        f"found {activations}")
    return layers, kinds.pop() if kinds else "tanh", log_std.detach().cpu().numpy().copy()


def export_module(module: Any, path_prefix: str | Path, env_id: str,
                  metadata: dict[str, Any] | None = None) -> tuple[Path, Path]:
    """Write ``module``'s actor as a RallySim policy (read by ``rallysim evaluate``)."""
    layers, activation, log_std = actor_layers(module)
    return write_policy(layers, activation, log_std, module.observation_space,
                        module.action_space, path_prefix, env_id=env_id, metadata=metadata)
