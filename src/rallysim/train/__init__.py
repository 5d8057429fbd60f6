"""Training on RallySim's envs (needs the learning extras: torch, stable-baselines3, safetensors).

- ``rallysim.train.runner.train_stage``: one stage (low, high, mono) with PPO, checkpoints,
  resume, evaluations and the exported policy; ``rallysim.train.config`` its settings.
- ``rallysim.train.sb3_vec.NativeVecEnv``: SB3 ``VecEnv`` over a natively batched vector env.
- ``rallysim.train.low``: ``LowConfig`` and ``train_low`` (PPO on the SIMPLE low-level task).
- ``rallysim.train.export``: ``save_policy`` / ``load_policy`` (safetensors + JSON, no pickle).
- ``rallysim.train.evaluate``: ``evaluate_low`` (deterministic, seeded, batched evaluation).

Submodules are imported on use so that ``import rallysim.train`` stays light.
"""

from __future__ import annotations

from typing import Any

__all__ = ["LowConfig", "evaluate_low", "load_policy", "save_policy", "train_low"]

_WHERE = {
    "LowConfig": "rallysim.train.low",
    "train_low": "rallysim.train.low",
    "save_policy": "rallysim.train.export",
    "load_policy": "rallysim.train.export",
    "evaluate_low": "rallysim.train.evaluate",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        import importlib

        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'rallysim.train' has no attribute {name!r}")
