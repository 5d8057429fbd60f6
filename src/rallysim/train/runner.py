"""Run one training stage with Stable-Baselines3 PPO: ``train_stage(config, out_dir)``.

What a run leaves in ``out_dir``:

| file | what |
|---|---|
| ``config.yaml`` | the resolved configuration |
| ``checkpoints/step_*.{safetensors,json}`` | resumable state every ``checkpoint_every`` steps |
| ``checkpoints/warm_start/`` | the warm start's resumable state, until the first PPO checkpoint |
| ``policy.{safetensors,json}`` | the final deterministic actor (``rallysim.policies.mlp``) |
| ``curve.json`` | evaluations and per-rollout training returns, with wall times |
| ``tb/`` | TensorBoard logs (``tensorboard --logdir out_dir/tb``) |

Progress: a bar with ETA when stderr is a terminal; otherwise (a log, CI, ``reproduce``) a
line at least every 30 s with the stage, seed, phase, steps, rate and ETA
(``rallysim.train.progress``).

A run started again on the same ``out_dir`` resumes from its newest intact checkpoint (after
any interruption, ``kill -9`` included), losing at most one checkpoint interval; it names any
damaged checkpoint it skips. A checkpoint made with another stage or network is refused with a
clear error. The warm start keeps its own state in ``checkpoints/warm_start/`` (every round's
dataset, the clone after every epoch: ``rallysim.train.warm_start``) until the first PPO
checkpoint supersedes it; ``resume=False`` removes every checkpoint first.
"""

from __future__ import annotations

import json
import math
import shutil
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np
import yaml

from rallysim.train import checkpoint as ckpt
from rallysim.train import stages
from rallysim.train.config import TrainConfig
from rallysim.train.progress import Heartbeat, Say, progress_lines, say_stderr


class _Monitor:
    """SB3 callback: progress bar with ETA, evaluations, checkpoints, the learning curve."""

    def __init__(self, config: TrainConfig, out: Path, curve: dict[str, Any],
                 progress: bool, beat: Heartbeat | None) -> None:
        from stable_baselines3.common.callbacks import BaseCallback

        monitor = self

        class Callback(BaseCallback):
            def _on_step(self) -> bool:
                return True

            def _on_rollout_end(self) -> None:
                monitor.rollout_end(self.model)

        self.callback = Callback()
        self.config, self.out, self.curve, self.progress = config, out, curve, progress
        self.beat = beat
        self.bar: Any = None
        self.eval_wall = 0.0
        self.start = time.perf_counter() - curve.get("train_wall_s", 0.0)
        done = curve.get("decisions", 0)
        every = config.eval_every or math.inf
        self.next_eval = (done // every + 1) * every if every < math.inf else math.inf
        self.next_ckpt = (done // config.checkpoint_every + 1) * config.checkpoint_every

    def open_bar(self, done: int) -> None:
        if self.beat is not None:
            self.beat.update(done)
            self.beat.set_phase("PPO")
        elif self.progress:
            from tqdm import tqdm

            self.bar = tqdm(total=self.config.decisions, initial=done, unit="step",
                            unit_scale=True, desc=f"train {self.config.stage}", file=sys.stderr,
                            dynamic_ncols=True, smoothing=0.1)

    def train_wall(self) -> float:
        return time.perf_counter() - self.start - self.eval_wall

    def rollout_end(self, model: Any) -> None:
        steps = int(model.num_timesteps)
        buf = model.ep_info_buffer
        ep_rew = float(np.mean([e["r"] for e in buf])) if buf else math.nan
        self.curve["rollouts"].append({"steps": steps, "wall_s": round(self.train_wall(), 2),
                                       "ep_rew_mean": ep_rew})
        if self.bar is not None:
            self.bar.update(steps - self.bar.n)
            self.bar.set_postfix_str(f"ep_rew {ep_rew:.3f}", refresh=False)
        if self.beat is not None:
            self.beat.update(steps)
        if steps >= self.next_eval:
            self.evaluate(model)
            while self.next_eval <= steps:
                self.next_eval += self.config.eval_every
        if steps >= self.next_ckpt:
            self.save(model)
            while self.next_ckpt <= steps:
                self.next_ckpt += self.config.checkpoint_every

    def evaluate(self, model: Any) -> dict[str, Any]:
        t = time.perf_counter()
        act = lambda obs: model.predict(obs, deterministic=True)[0]  # noqa: E731
        result = stages.evaluate(self.config, act)
        row = {"steps": int(model.num_timesteps), "wall_s": round(self.train_wall(), 2),
               **result}
        self.eval_wall += time.perf_counter() - t
        self.curve["evals"].append(row)
        logger = getattr(model, "_logger", None)  # none before any PPO (a clone alone)
        for key, value in result.items():
            if logger is not None:
                logger.record(f"eval/{key}", value)
        c = self.config
        message = (f"[{c.stage} seed {c.seed}] {row['steps']:>10,} steps: "
                   + stages.headline(c, result))
        if self.bar is not None:
            self.bar.write(message)
        elif self.beat is not None:
            self.beat.say(message)
        return row

    def save(self, model: Any) -> None:
        self.curve["decisions"] = int(model.num_timesteps)
        self.curve["train_wall_s"] = round(self.train_wall(), 2)
        ckpt.save_checkpoint(self.out, model, {
            "stage": self.config.stage, "network": self.config.network(),
            "config": self.config.to_dict(), "curve": self.curve})
        # the PPO checkpoint holds the clone and its results: the warm start's state is spent
        shutil.rmtree(warm_start_dir(self.out), ignore_errors=True)


def build_model(config: TrainConfig, out: Path) -> Any:
    import torch
    from stable_baselines3 import PPO

    torch.set_num_threads(config.torch_threads)
    env = stages.make_env(config)
    return PPO("MlpPolicy", env, seed=config.seed, device="cpu", verbose=0,
               tensorboard_log=str(out / "tb"), **config.ppo_kwargs())


def train_stage(config: TrainConfig, out_dir: str | Path, resume: bool = True,
                progress: bool = True, say: Say | None = None) -> dict[str, Any]:
    """Train ``config.stage`` into ``out_dir`` (resuming there if it holds a checkpoint) and
    return the learning curve with the final evaluation. ``progress``: a bar on a terminal,
    else progress lines on stderr; ``say``: where progress lines go instead (no bar)."""
    if say is None and progress:
        say = progress_lines()  # None on a terminal: the bar
    beat = None if say is None else Heartbeat(f"[{config.stage} seed {config.seed}]",
                                             config.decisions, say)
    if beat is None:
        return _train_stage(config, Path(out_dir), resume, progress, None)
    with beat:
        return _train_stage(config, Path(out_dir), resume, progress, beat)


def warm_start_dir(out: Path) -> Path:
    """Where a run's warm start keeps its resumable state."""
    return out / "checkpoints" / "warm_start"


def _train_stage(config: TrainConfig, out: Path, resume: bool, progress: bool,
                 beat: Heartbeat | None) -> dict[str, Any]:
    out.mkdir(parents=True, exist_ok=True)
    # warnings (a damaged checkpoint skipped) are shown even without progress output
    warn = beat.say if beat is not None else say_stderr
    note = warn if progress or beat is not None else None
    if not resume and (removed := ckpt.remove_checkpoints(out)) and note is not None:
        note(f"restarting {config.stage}: removed {removed} checkpoint(s) of the previous run")
    model = build_model(config, out)
    curve: dict[str, Any] = {"stage": config.stage, "evals": [], "rollouts": []}
    found = ckpt.resume(model, out, {"stage": config.stage, "network": config.network()},
                        warn) if resume else None
    if found is not None:
        latest, doc = found
        curve = doc["curve"]
        curve.setdefault("evals", [])
        curve.setdefault("rollouts", [])
        shutil.rmtree(warm_start_dir(out), ignore_errors=True)  # superseded, see _Monitor.save
        if note is not None:
            note(f"resuming {config.stage} from {latest.name} "
                 f"({model.num_timesteps:,} steps done)")
    elif config.warm_start == "scripted":
        if beat is not None:
            beat.set_phase("warm start (behaviour cloning)")
        curve["warm_start"] = warm_start(model, config, progress and beat is None, out,
                                         warn, note)
    (out / "config.yaml").write_text(yaml.safe_dump(config.to_dict(), sort_keys=False))
    monitor = _Monitor(config, out, curve, progress, beat)
    remaining = config.decisions - int(model.num_timesteps)
    monitor.open_bar(int(model.num_timesteps))
    try:
        if remaining > 0:
            model.learn(total_timesteps=remaining, callback=monitor.callback,
                        reset_num_timesteps=found is None, tb_log_name=config.stage)
    finally:
        if monitor.bar is not None:
            monitor.bar.close()
    evals = curve["evals"]
    final = (evals[-1] if evals and evals[-1]["steps"] == model.num_timesteps
             else monitor.evaluate(model))
    monitor.save(model)
    curve["final"] = final
    curve["steps"] = int(model.num_timesteps)
    curve["train_wall_s"] = round(monitor.train_wall(), 2)
    curve["steps_per_s"] = round(curve["steps"] / max(curve["train_wall_s"], 1e-9), 1)
    curve["decisions_simulated"] = (stages.decisions_simulated(model.get_env())
                                    if config.stage == "high" else curve["steps"])
    export_policy(model, config, out / "policy", final)
    # written last, in one step: reproduce takes a stage with a curve.json as trained
    ckpt.atomic_write(out / "curve.json", json.dumps(curve, indent=1).encode(), "curve")
    return curve


def warm_start(model: Any, config: TrainConfig, progress: bool, out: Path | None = None,
               warn: Say | None = None, note: Say | None = None) -> dict[str, Any]:
    """Behaviour-clone the scripted controller into ``model`` (labelled in every output):
    ``ScriptedController`` for SIMPLE, ``AimedSwing`` for HUMAN-LIKE. With ``out``, resumable:
    its state is saved in (and resumed from) ``warm_start_dir(out)``; ``warn``: where a
    skipped damaged state is reported, ``note``: where resuming is."""
    from rallysim.train.warm_start import WarmCheckpoint, behaviour_clone

    if config.env == "humanlike":
        from rallysim.policies.aimed_swing import AimedSwing

        teacher, name = AimedSwing(config.shuttle), "AimedSwing"
    else:
        from rallysim.policies import ScriptedController

        teacher, name = ScriptedController().act_return, "ScriptedController"
    if progress:
        print(f"warm start: cloning {name} over {config.warm_start_decisions:,} decisions "
              f"(+{config.warm_start_dagger} DAgger rounds) ...", file=sys.stderr, flush=True)

    def evaluate(act: Any, round_: int) -> dict[str, Any]:
        # the clone's learning curve over its DAgger rounds, with the stage's own numbers
        result = stages.evaluate(config, act)
        if progress:
            stage = f"DAgger round {round_}" if round_ else "clone"
            print(f"[warm start] {stage}: {stages.headline(config, result)}", file=sys.stderr,
                  flush=True)
        return result

    checkpoint = None
    if out is not None:
        checkpoint = WarmCheckpoint(warm_start_dir(out), say=warn or say_stderr, note=note,
                                    extra={"eval_episodes": config.eval_episodes,
                                           "eval_seed": config.eval_seed})
    result = behaviour_clone(model, teacher, config.warm_start_decisions,
                             epochs=config.warm_start_epochs,
                             log_std=config.warm_start_log_std, shuttle=config.shuttle,
                             seed=config.seed + 1_000_003, player=config.env,
                             dagger_rounds=config.warm_start_dagger,
                             batch_size=config.warm_start_batch_size,
                             lr_decay=config.warm_start_lr_decay,
                             evaluate=evaluate if config.warm_start_dagger else None,
                             checkpoint=checkpoint)
    return {**result, "teacher": name}


def export_policy(model: Any, config: TrainConfig, prefix: Path, final: dict[str, Any]) -> None:
    """The deterministic actor as safetensors + JSON (with its weights' SHA-256)."""
    from rallysim.train.export import save_policy

    meta = {"stage": config.stage, "seed": config.seed, "steps": int(model.num_timesteps),
            "final": final, "config": config.to_dict()}
    if (mapping := stages.goal_mapping(config)) is not None:
        meta["goal_mapping"] = mapping
    save_policy(model, prefix, env_id=stages.export_env(config), metadata=meta)
