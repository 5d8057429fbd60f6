"""Training on RallySim's envs (needs the learning extras: torch, stable-baselines3, safetensors).

- ``rallysim.train.runner.train_stage``: one stage (low, high, mono) with PPO, checkpoints,
  resume, evaluations and the exported policy.
- ``rallysim.train.config``: ``TrainConfig`` (top-level settings and the ``ppo``,
  ``warm_start`` and ``eval`` sections of ``rallysim.train.sections``) and ``load_config``.
- ``rallysim.train.stages``: the stages as objects (``LOW``, ``HIGH``, ``MONO``): env factory,
  evaluation, export, budget unit, and a table of what each player changes;
  ``rallysim.train.players`` the players' names.
- ``rallysim.train.run_log``: a run's record (config.yaml, curve.json, schedule, progress
  lines), shared by the SB3 and RLlib (``rallysim.rllib``) runners.
- ``rallysim.train.sb3_vec.NativeVecEnv``: SB3 ``VecEnv`` over a natively batched vector env.
- ``rallysim.train.export``: ``save_policy`` (safetensors + JSON, no pickle; loaded by
  ``rallysim.policies.mlp.load_policy``) over ``write_policy``, which the RLlib backend
  (``rallysim.rllib``) shares.
- ``rallysim.train.warm_start``: the optional behaviour-cloning start of the low level.
- ``rallysim.train.reproduce``: the whole pipeline and the Table VII report.
- ``rallysim.train.results_doc``: the docs' generated tables, from the JSON that
  ``reproduce`` and the research studies (the repository's ``experiments/``, not part of
  the package) write; ``rallysim.train.study_tables`` renders the studies'.

Submodules are imported on use so that ``import rallysim.train`` stays light.
"""

from __future__ import annotations

from typing import Any

__all__ = ["TrainConfig", "load_config", "save_policy", "train_stage"]

_WHERE = {
    "TrainConfig": "rallysim.train.config",
    "load_config": "rallysim.train.config",
    "train_stage": "rallysim.train.runner",
    "save_policy": "rallysim.train.export",
}


def __getattr__(name: str) -> Any:
    if name in _WHERE:
        import importlib

        return getattr(importlib.import_module(_WHERE[name]), name)
    raise AttributeError(f"module 'rallysim.train' has no attribute {name!r}")
