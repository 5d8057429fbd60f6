"""Run one training stage with RLlib PPO on a Ray cluster: ``train_stage_rllib``.

The counterpart of ``rallysim.train.runner.train_stage`` (same ``TrainConfig``, same stages,
same evaluations, same policy files). What a run leaves in ``out_dir``:

| file | what |
|---|---|
| ``config.yaml`` | the resolved configuration, with ``backend: rllib`` and the env runners |
| ``checkpoints/policy_step_*.{safetensors,json}`` | the actor, every ``checkpoint_every`` |
| ``policy.{safetensors,json}`` | the final deterministic actor (``rallysim.policies.mlp``) |
| ``curve.json`` | per-iteration training returns and throughput, evaluations, env runner nodes |

Unlike the SB3 path a run does not resume: RLlib's own checkpoints are pickles, which RallySim
never loads, and ``policy_step_*`` holds the actor alone (no critic, no optimiser), so an
interrupted run starts again. ``curve.json`` is written last and in one step (renamed into
place, ``rallysim.train.checkpoint.atomic_write``), as by the SB3 path: a run killed before it
leaves none.
"""

from __future__ import annotations

import json
import logging
import math
import os
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from rallysim.rllib import require_ray
from rallysim.train.checkpoint import atomic_write, json_default
from rallysim.train.config import TrainConfig

BACKEND = "rllib"


def connect(address: str | None, env_runners: int) -> bool:
    """Join the Ray cluster at ``address`` (``"auto"`` or ``HOST:PORT``), or start a local one
    with a CPU per env runner at least; True when this call started Ray (and should stop it).
    An already-initialised Ray (a caller's own ``ray.init``) is used as it is."""
    import ray

    if ray.is_initialized():
        return False
    quiet = {"logging_level": "ERROR", "log_to_driver": False}
    if address:
        ray.init(address=address, **quiet)
    else:
        ray.init(num_cpus=max(os.cpu_count() or 1, env_runners), include_dashboard=False,
                 **quiet)
    return True


def env_runner_nodes(algo: Any) -> list[str]:
    """The Ray node id each remote env runner runs on (the driver's when there are none)."""
    import ray

    def node_id(_runner: Any) -> str:
        return ray.get_runtime_context().get_node_id()

    group = algo.env_runner_group
    if group.num_remote_env_runners() == 0:
        return [node_id(None)]
    return list(group.foreach_env_runner(node_id, local_env_runner=False))


def _decisions(config: TrainConfig, runners: dict[str, Any]) -> int:
    """Decisions sampled so far: env steps (low), agent steps (a turn or a player's decision)."""
    key = "num_env_steps_sampled_lifetime" if config.stage == "low" else (
        "num_agent_steps_sampled_lifetime")
    value = runners.get(key, 0)
    if isinstance(value, dict):  # per agent
        value = sum(value.values())
    return int(value)


def _episode_return(config: TrainConfig, runners: dict[str, Any]) -> float:
    """Mean return of the episodes finished this iteration; per player for the rallies (as a
    slot's return in the SB3 path)."""
    if config.stage == "low":
        return float(runners.get("episode_return_mean", math.nan))
    per_agent = runners.get("agent_episode_returns_mean") or {}
    return float(np.mean(list(per_agent.values()))) if per_agent else math.nan


def module_policy(module: Any) -> Any:
    """``module``'s deterministic actor as a NumPy ``MLPPolicy`` (what its export loads as)."""
    from rallysim.policies.mlp import MLPPolicy
    from rallysim.rllib.export import actor_layers

    layers, activation, log_std = actor_layers(module)
    space = module.action_space
    return MLPPolicy(layers, activation, np.asarray(space.low, np.float32),
                     np.asarray(space.high, np.float32), log_std, {})


class _Run:
    """One training run's bookkeeping: progress lines, evaluations, exports, the curve."""

    def __init__(self, config: TrainConfig, out: Path, algo: Any, progress: bool,
                 env_runners: int) -> None:
        from rallysim.rllib.envs import SHARED_MODULE

        self.config, self.out, self.algo, self.progress = config, out, algo, progress
        self.module_id = SHARED_MODULE if config.stage != "low" else None
        self.curve: dict[str, Any] = {"stage": config.stage, "backend": BACKEND,
                                      "env_runners": env_runners, "evals": [],
                                      "iterations": []}
        self.decisions = 0
        self.eval_wall = 0.0
        self.start = time.perf_counter()
        every = config.eval_every or math.inf
        self.next_eval = every
        self.next_ckpt = config.checkpoint_every

    def module(self) -> Any:
        return self.algo.get_module(self.module_id) if self.module_id else self.algo.get_module()

    def train_wall(self) -> float:
        return time.perf_counter() - self.start - self.eval_wall

    def say(self, message: str) -> None:
        if self.progress:
            print(message, file=sys.stderr, flush=True)

    def iterate(self) -> None:
        result = self.algo.train()
        runners = result.get("env_runners", {})
        self.decisions = _decisions(self.config, runners)
        wall = self.train_wall()
        row = {"iteration": int(result["training_iteration"]), "decisions": self.decisions,
               "wall_s": round(wall, 2), "ep_rew_mean": _episode_return(self.config, runners)}
        self.curve["iterations"].append(row)
        self.say(f"[{self.config.stage} rllib] iter {row['iteration']:4d}  decisions "
                 f"{self.decisions:>10,}/{self.config.decisions:,}  ep_rew "
                 f"{row['ep_rew_mean']:7.3f}  {self.decisions / max(wall, 1e-9):8,.0f} "
                 f"decisions/s")
        if self.decisions >= self.next_eval:
            self.evaluate()
            while self.next_eval <= self.decisions:
                self.next_eval += self.config.eval_every
        if self.decisions >= self.next_ckpt:
            self.export(self.out / "checkpoints" / f"policy_step_{self.decisions}", None)
            while self.next_ckpt <= self.decisions:
                self.next_ckpt += self.config.checkpoint_every

    def evaluate(self) -> dict[str, Any]:
        from rallysim.train import stages

        t = time.perf_counter()
        result = stages.evaluate(self.config, module_policy(self.module()))
        row = {"steps": self.decisions, "wall_s": round(self.train_wall(), 2), **result}
        self.eval_wall += time.perf_counter() - t
        self.curve["evals"].append(row)
        self.say(f"[{self.config.stage} rllib] {self.decisions:>10,} decisions: "
                 + stages.headline(self.config, result))
        return row

    def export(self, prefix: Path, final: dict[str, Any] | None) -> None:
        from rallysim.rllib.export import export_module
        from rallysim.train import stages

        meta = {"stage": self.config.stage, "seed": self.config.seed, "steps": self.decisions,
                "backend": BACKEND, "env_runners": self.curve["env_runners"],
                "config": self.config.to_dict()}
        if final is not None:
            meta["final"] = final
        if (mapping := stages.goal_mapping(self.config)) is not None:
            meta["goal_mapping"] = mapping
        export_module(self.module(), prefix, env_id=stages.export_env(self.config),
                      metadata=meta)


def train_stage_rllib(config: TrainConfig, out_dir: str | Path, address: str | None = None,
                      env_runners: int = 2, progress: bool = True) -> dict[str, Any]:
    """Train ``config.stage`` with RLlib PPO into ``out_dir`` and return the learning curve
    with the final evaluation, the throughput and the node of each env runner.

    ``address``: a running Ray cluster (``"auto"`` or ``HOST:PORT``; every node needs RallySim
    installed); ``None`` starts a local Ray for this run."""
    if config.env == "humanlike" and config.stage != "low":
        raise ValueError("the RLlib backend trains the HUMAN-LIKE low level only; train its "
                         "high level with --backend sb3")
    require_ray()
    import ray
    import torch

    from rallysim.rllib.envs import register_rllib_envs
    from rallysim.rllib.ppo_config import build_ppo_config

    out = Path(out_dir)
    out.mkdir(parents=True, exist_ok=True)
    # RLlib warns on every run that PPO uses its new API stack, which is what RallySim wants
    logging.getLogger("ray.rllib").setLevel(logging.ERROR)
    torch.set_num_threads(config.torch_threads)  # the learner runs in this process
    started = connect(address, env_runners)
    algo = None
    try:
        register_rllib_envs()
        algo = build_ppo_config(config, env_runners).build_algo()
        doc = {**config.to_dict(), "backend": BACKEND, "env_runners": env_runners,
               "address": address}
        (out / "config.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))
        run = _Run(config, out, algo, progress, env_runners)
        run.curve["env_runner_nodes"] = env_runner_nodes(algo)
        run.curve["cluster_nodes"] = sorted(n["NodeID"] for n in ray.nodes() if n["Alive"])
        run.say(f"[{config.stage} rllib] {env_runners} env runner(s) on "
                f"{len(set(run.curve['env_runner_nodes']))} node(s) of "
                f"{len(run.curve['cluster_nodes'])}")
        run.start = time.perf_counter()
        while run.decisions < config.decisions:
            run.iterate()
        evals = run.curve["evals"]
        final = (evals[-1] if evals and evals[-1]["steps"] == run.decisions
                 else run.evaluate())
        curve = run.curve
        curve["final"] = final
        curve["steps"] = run.decisions
        curve["train_wall_s"] = round(run.train_wall(), 2)
        curve["steps_per_s"] = round(curve["steps"] / max(curve["train_wall_s"], 1e-9), 1)
        run.export(out / "policy", final)
        atomic_write(out / "curve.json",
                     json.dumps(curve, indent=1, default=json_default).encode(), "curve")
        return curve
    finally:
        if algo is not None:
            algo.stop()
        if started:
            ray.shutdown()

