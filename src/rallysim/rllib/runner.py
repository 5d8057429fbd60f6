"""Run one training stage with RLlib PPO on a Ray cluster: ``train_stage_rllib``.

The counterpart of ``rallysim.train.runner.train_stage`` (same ``TrainConfig``, same stages,
same evaluations, same policy files). What a run leaves in ``out_dir``:

| file | what |
|---|---|
| ``config.yaml`` | the resolved configuration, with ``backend: rllib`` and the env runners |
| ``checkpoints/policy_step_*.{safetensors,json}`` | the actor, every ``checkpoint_every`` |
| ``policy.{safetensors,json}`` | the final deterministic actor (``rallysim.policies.mlp``) |
| ``curve.json`` | per-iteration training returns and throughput, evaluations, env runner nodes |

The record (``config.yaml``, the curve, ``curve.json``, the evaluation and checkpoint
schedule, progress lines in the stage's budget unit) is kept by ``rallysim.train.run_log``, as
in the SB3 path. Unlike the SB3 path a run does not resume: RLlib's own checkpoints are
pickles, which RallySim never loads, and ``policy_step_*`` holds the actor alone (no critic, no
optimiser), so an interrupted run starts again. ``curve.json`` is written last and in one step,
as by the SB3 path: a run killed before it leaves none.
"""

from __future__ import annotations

import logging
import math
import os
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np

from rallysim.rllib import require_ray
from rallysim.train import stages
from rallysim.train.config import TrainConfig
from rallysim.train.players import PLAYERS
from rallysim.train.progress import say_stderr
from rallysim.train.run_log import RunLog

BACKEND = "rllib"
# the players whose stages the RLlib env adapters (rallysim.rllib.envs) build
RLLIB_PLAYERS: dict[str, tuple[str, ...]] = {"low": ("simple", "humanlike"),
                                             "high": ("simple",), "mono": ("simple",)}


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
    """Units of the budget sampled so far: env steps (single-agent: decisions), agent steps
    (multi-agent: turns or players' decisions)."""
    key = ("num_agent_steps_sampled_lifetime" if stages.of(config).multi_agent
           else "num_env_steps_sampled_lifetime")
    value = runners.get(key, 0)
    if isinstance(value, dict):  # per agent
        value = sum(value.values())
    return int(value)


def _episode_return(config: TrainConfig, runners: dict[str, Any]) -> float:
    """Mean return of the episodes finished this iteration; per player for the rallies (as a
    slot's return in the SB3 path)."""
    if not stages.of(config).multi_agent:
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
    """One training run: RLlib's iterations, with the record kept by the shared ``RunLog``
    (evaluations, exports, the curve, progress lines)."""

    def __init__(self, algo: Any, log: RunLog) -> None:
        from rallysim.rllib.envs import SHARED_MODULE

        self.algo, self.log, self.config = algo, log, log.config
        self.module_id = SHARED_MODULE if log.stage.multi_agent else None
        self.decisions = 0

    def module(self) -> Any:
        return self.algo.get_module(self.module_id) if self.module_id else self.algo.get_module()

    def iterate(self) -> None:
        log = self.log
        result = self.algo.train()
        runners = result.get("env_runners", {})
        self.decisions = _decisions(self.config, runners)
        wall = log.train_wall()
        row = {"iteration": int(result["training_iteration"]), "decisions": self.decisions,
               "wall_s": round(wall, 2), "ep_rew_mean": _episode_return(self.config, runners)}
        log.record_update(row)
        log.line(f"iter {row['iteration']:4d}  {log.unit} {self.decisions:>10,}/"
                 f"{self.config.budget:,}  ep_rew {row['ep_rew_mean']:7.3f}  "
                 f"{self.decisions / max(wall, 1e-9):8,.0f} {log.unit}/s")
        if log.eval_due(self.decisions):
            self.evaluate()
        if log.checkpoint_due(self.decisions):
            self.export(log.out / "checkpoints" / f"policy_step_{self.decisions}", None)

    def evaluate(self) -> dict[str, Any]:
        return self.log.evaluate(self.decisions, module_policy(self.module()))

    def export(self, prefix: Path, final: dict[str, Any] | None) -> None:
        from rallysim.rllib.export import export_module

        log = self.log
        meta = log.policy_metadata(self.decisions, final, {
            "backend": BACKEND, "env_runners": log.curve["env_runners"]})
        export_module(self.module(), prefix, env_id=log.stage.export_env(self.config),
                      metadata=meta)


def train_stage_rllib(config: TrainConfig, out_dir: str | Path, address: str | None = None,
                      env_runners: int = 2, progress: bool = True) -> dict[str, Any]:
    """Train ``config.stage`` with RLlib PPO into ``out_dir`` and return the learning curve
    with the final evaluation, the throughput and the node of each env runner.

    ``address``: a running Ray cluster (``"auto"`` or ``HOST:PORT``; every node needs RallySim
    installed); ``None`` starts a local Ray for this run."""
    if config.stage not in RLLIB_PLAYERS:  # the compete stage's league runs on SB3's loop
        raise ValueError(f"the RLlib backend does not train the {config.stage} stage; train "
                         "it with --backend sb3")
    if config.player not in RLLIB_PLAYERS[config.stage]:
        raise ValueError(f"the RLlib backend does not train the {PLAYERS[config.player].label} "
                         f"player's {config.stage} stage; train it with --backend sb3")
    if config.goal_sweep:
        # the sweep sets the SB3 actor's output bias; RLlib's module starts at the centre
        if progress:
            say_stderr(f"[{config.stage} rllib seed {config.seed}] the RLlib backend starts "
                       "the high level at the centre of the goal range (goal_sweep 0)")
        config = replace(config, goal_sweep=0)
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
        log = RunLog(config, out, "iterations", label=f"[{config.stage} rllib seed "
                     f"{config.seed}]", say=say_stderr if progress else None,
                     extra={"backend": BACKEND, "env_runners": env_runners})
        log.write_config({"backend": BACKEND, "env_runners": env_runners, "address": address})
        run = _Run(algo, log)
        log.curve["env_runner_nodes"] = env_runner_nodes(algo)
        log.curve["cluster_nodes"] = sorted(n["NodeID"] for n in ray.nodes() if n["Alive"])
        log.line(f"{env_runners} env runner(s) on {len(set(log.curve['env_runner_nodes']))} "
                 f"node(s) of {len(log.curve['cluster_nodes'])}")
        log.start_clock()
        while run.decisions < config.budget:
            run.iterate()
        final = log.evaluation_at(run.decisions)
        if final is None:
            final = run.evaluate()
        curve = log.finish(final, run.decisions)
        run.export(out / "policy", final)
        log.write_curve()
        return curve
    finally:
        if algo is not None:
            algo.stop()
        if started:
            ray.shutdown()

