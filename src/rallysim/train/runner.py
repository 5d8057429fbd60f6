"""Run one training stage with Stable-Baselines3 PPO: ``train_stage(config, out_dir)``.

What a run leaves in ``out_dir`` (the record is kept by ``rallysim.train.run_log``, shared with
the RLlib backend):

| file | what |
|---|---|
| ``config.yaml`` | the resolved configuration |
| ``checkpoints/step_*.{safetensors,json}`` | resumable state every ``checkpoint_every`` steps |
| ``checkpoints/warm_start/`` | the warm start's resumable state, until the first PPO checkpoint |
| ``policy.{safetensors,json}`` | the final deterministic actor (``rallysim.policies.mlp``) |
| ``curve.json`` | evaluations and per-rollout training returns, with wall times |
| ``tb/`` | TensorBoard logs (``tensorboard --logdir out_dir/tb``) |

One SB3 step is one unit of the stage's budget: a decision (low), a turn (high), a player's
decision (mono). Progress: a bar with ETA when stderr is a terminal; otherwise (a log, CI,
``reproduce``) a line at least every 30 s with the stage, seed, phase, units done, rate and ETA
(``rallysim.train.progress``).

A run started again on the same ``out_dir`` resumes from its newest intact checkpoint (after
any interruption, ``kill -9`` included), losing at most one checkpoint interval; it names any
damaged checkpoint it skips. A checkpoint made with another stage or network is refused with a
clear error. The warm start keeps its own state in ``checkpoints/warm_start/`` (every round's
dataset, the clone after every epoch: ``rallysim.train.warm_start``) until the first PPO
checkpoint supersedes it; ``resume=False`` removes every checkpoint first.
"""

from __future__ import annotations

import math
import shutil
import sys
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np

from rallysim.train import checkpoint as ckpt
from rallysim.train import stages
from rallysim.train.action_range import cap_log_std, log_std_cap, pull_mean_into_range
from rallysim.train.config import TrainConfig
from rallysim.train.progress import Heartbeat, Say, progress_lines, say_stderr
from rallysim.train.run_log import RunLog
from rallysim.train.torch_speed import no_distribution_checks


class _Monitor:
    """SB3 callback: progress bar or heartbeat, evaluations and checkpoints on the run log's
    schedule, a row of the curve per rollout."""

    def __init__(self, log: RunLog, progress: bool, beat: Heartbeat | None,
                 extra: Any = None) -> None:
        from stable_baselines3.common.callbacks import BaseCallback

        monitor = self

        class Callback(BaseCallback):
            def _on_step(self) -> bool:
                return True

            def _on_rollout_start(self) -> None:
                monitor.rollout_start(self.model)

            def _on_rollout_end(self) -> None:
                monitor.rollout_end(self.model)

        self.callback = Callback()
        self.log, self.progress, self.beat = log, progress, beat
        self.extra = extra  # the stage's own state (the compete stage's league)
        self.bar: Any = None

    def open_bar(self, done: int) -> None:
        if self.beat is not None:
            config = self.log.config
            self.beat.set_phase("PPO", count=(done, config.budget, config.budget_unit))
            self.log.say = self.beat.say
        elif self.progress:
            from tqdm import tqdm

            config = self.log.config
            self.bar = tqdm(total=config.budget, initial=done, unit=f" {self.log.unit}",
                            unit_scale=True, desc=f"train {config.stage}", file=sys.stderr,
                            dynamic_ncols=True, smoothing=0.1)
            self.log.say = self.bar.write

    def rollout_start(self, model: Any) -> None:
        ppo, config = self.log.config.ppo, self.log.config
        if ppo.log_std_end is not None:
            cap_log_std(model.policy, log_std_cap(ppo.log_std_init, ppo.log_std_end,
                                                  model.num_timesteps / config.budget))

    def rollout_end(self, model: Any) -> None:
        steps = int(model.num_timesteps)
        buf = model.ep_info_buffer
        ep_rew = float(np.mean([e["r"] for e in buf])) if buf else math.nan
        self.log.record_update({"steps": steps, "wall_s": round(self.log.train_wall(), 2),
                                "ep_rew_mean": ep_rew})
        if self.bar is not None:
            self.bar.update(steps - self.bar.n)
            self.bar.set_postfix_str(f"ep_rew {ep_rew:.3f}", refresh=False)
        if self.beat is not None:
            self.beat.update(steps)
        if self.extra is not None:
            self.log.stage.rollout_end(self.extra, model, self.log.say)
        if self.log.eval_due(steps):
            self.evaluate(model)
        if self.log.checkpoint_due(steps):
            self.save(model)

    def evaluate(self, model: Any) -> dict[str, Any]:
        act = lambda obs: model.predict(obs, deterministic=True)[0]  # noqa: E731
        row = self.log.evaluate(int(model.num_timesteps), act)
        logger = getattr(model, "_logger", None)  # none before any PPO (a clone alone)
        if logger is not None:
            for key, value in row.items():
                if key not in ("steps", "wall_s"):
                    logger.record(f"eval/{key}", value)
        return row

    def save(self, model: Any) -> None:
        config, out = self.log.config, self.log.out
        self.log.mark(int(model.num_timesteps))
        meta = {"stage": config.stage, "network": config.network(),
                "config": config.to_dict(), "curve": self.log.curve}
        if self.extra is not None:
            meta["stage_state"] = self.extra.state()
        ckpt.save_checkpoint(out, model, meta)
        # the PPO checkpoint holds the clone and its results: the warm start's state is spent
        shutil.rmtree(warm_start_dir(out), ignore_errors=True)


def build_model(config: TrainConfig, out: Path) -> Any:
    import torch
    from stable_baselines3 import PPO

    torch.set_num_threads(config.torch_threads)
    env = stages.make_env(config)
    model = PPO("MlpPolicy", env, seed=config.seed, device="cpu", verbose=0,
                tensorboard_log=str(out / "tb"), **config.ppo.sb3_kwargs())
    if config.ppo.mean_bound > 0:
        pull_mean_into_range(model.policy, config.ppo.mean_bound)
    return model


def train_stage(config: TrainConfig, out_dir: str | Path, resume: bool = True,
                progress: bool = True, say: Say | None = None) -> dict[str, Any]:
    """Train ``config.stage`` into ``out_dir`` (resuming there if it holds a checkpoint) and
    return the learning curve with the final evaluation. ``progress``: a bar on a terminal,
    else progress lines on stderr; ``say``: where progress lines go instead (no bar)."""
    if say is None and progress:
        say = progress_lines()  # None on a terminal: the bar
    beat = None if say is None else Heartbeat(f"[{config.stage} seed {config.seed}]",
                                             config.budget, say, unit=config.budget_unit)
    with no_distribution_checks():
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
    log = RunLog(config, out, "rollouts")
    # warnings (a damaged checkpoint skipped) are shown even without progress output
    warn = beat.say if beat is not None else say_stderr
    note = warn if progress or beat is not None else None
    if not resume and (removed := ckpt.remove_checkpoints(out)) and note is not None:
        note(log.restart_note(removed))
    model = build_model(config, out)
    found = ckpt.resume(model, out, {"stage": config.stage, "network": config.network()},
                        warn) if resume else None
    if found is not None:
        latest, doc = found
        log.adopt(doc["curve"])
        shutil.rmtree(warm_start_dir(out), ignore_errors=True)  # superseded, see _Monitor.save
        if note is not None:
            note(log.resume_note(latest, int(model.num_timesteps)))
    elif config.warm_start.enabled:
        fitted: Callable[[int], None] | None = None
        if beat is not None:
            from rallysim.train.warm_start import total_fit_epochs

            beat.set_phase("warm start (behaviour cloning)", count=(
                0, total_fit_epochs(config.warm_start), "epochs"))
            fitted = beat.update
        log.curve["warm_start"] = warm_start(model, config, progress and beat is None, out,
                                             warn, note, fitted)
    if found is None and (start := stages.of(config).start(config, model)) is not None:
        log.curve["start"] = start
        if note is not None:
            note(f"[{config.stage} seed {config.seed}] start: {_start_line(config, start)}")
    log.write_config()
    extra = stages.of(config).begin(config, model, out,
                                    None if found is None else found[1].get("stage_state"))
    log.start_clock()
    monitor = _Monitor(log, progress, beat, extra)
    remaining = config.budget - int(model.num_timesteps)
    monitor.open_bar(int(model.num_timesteps))
    try:
        if remaining > 0:
            model.learn(total_timesteps=remaining, callback=monitor.callback,
                        reset_num_timesteps=found is None, tb_log_name=config.stage)
    finally:
        if monitor.bar is not None:
            monitor.bar.close()
    final = log.evaluation_at(int(model.num_timesteps))
    if final is None:
        final = monitor.evaluate(model)
    monitor.save(model)
    steps = int(model.num_timesteps)
    simulated = stages.of(config).decisions_simulated(model.get_env(), steps)
    curve = log.finish(final, steps,
                       simulated + int(log.curve.get("start", {}).get("decisions", 0)))
    export_policy(model, log, out / "policy", final)
    log.write_curve()
    return curve


def _start_line(config: TrainConfig, start: dict[str, Any]) -> str:
    """The goal sweep in one progress line."""
    from rallysim.players import get_player

    player = get_player(config.player)
    goal = np.round(player.goal.from_action(np.asarray(start["best_action"])), 2).tolist()
    return (f"goal sweep over {len(start['actions'])} goals x {start['rallies_per_goal']} "
            f"rallies ({start['decisions']:,} decisions): best goal {goal} {player.goal.unit}, "
            f"mean rally {start['best_mean_rally']:.2f}")


def warm_start(model: Any, config: TrainConfig, progress: bool, out: Path | None = None,
               warn: Say | None = None, note: Say | None = None,
               fitted: Callable[[int], None] | None = None) -> dict[str, Any]:
    """Behaviour-clone the player's scripted controller into ``model`` (labelled in every
    output): ``ScriptedController`` for SIMPLE, ``AimedSwing`` for HUMAN-LIKE. With ``out``,
    resumable: its state is saved in (and resumed from) ``warm_start_dir(out)``; ``warn``:
    where a skipped damaged state is reported, ``note``: where resuming is; ``fitted(done)``:
    after every epoch fitted (``rallysim.train.warm_start.behaviour_clone``)."""
    from rallysim.train.warm_start import WarmCheckpoint, behaviour_clone

    stage = stages.of(config)
    teacher, name = stage.teacher(config)
    settings = config.warm_start
    if progress:
        rally = f", +{settings.rally_dagger} in the rally" if settings.rally_dagger else ""
        print(f"warm start: cloning {name} over {settings.decisions:,} decisions "
              f"(+{settings.dagger} DAgger rounds{rally}) ...", file=sys.stderr, flush=True)

    def evaluate(act: Any, round_: int) -> dict[str, Any]:
        # the clone's learning curve over its DAgger rounds, with the stage's own numbers
        result = stage.evaluate(config, act)
        if progress:
            step = ("clone" if not round_ else f"DAgger round {round_}"
                    + (" (rally)" if round_ > settings.dagger else ""))
            print(f"[warm start] {step}: {stage.headline(config, result)}", file=sys.stderr,
                  flush=True)
        return result

    checkpoint = None
    if out is not None:
        checkpoint = WarmCheckpoint(warm_start_dir(out), say=warn or say_stderr, note=note,
                                    extra={"eval_episodes": config.eval.episodes,
                                           "eval_seed": config.eval.seed})
    result = behaviour_clone(model, teacher, settings, stage.clone_task(config),
                             evaluate=evaluate if settings.dagger or settings.rally_dagger
                             else None,
                             checkpoint=checkpoint, fitted=fitted)
    return {**result, "teacher": name}


def export_policy(model: Any, log: RunLog, prefix: Path, final: dict[str, Any]) -> None:
    """The deterministic actor as safetensors + JSON (with its weights' SHA-256)."""
    from rallysim.train.export import save_policy

    steps = int(model.num_timesteps)
    save_policy(model, prefix, env_id=log.stage.export_env(log.config),
                metadata=log.policy_metadata(steps, final))
