"""What every training stage provides to the runners (``rallysim.train.runner`` for SB3,
``rallysim.rllib`` for RLlib), and the rally numbers the high and mono stages share.

A stage object is stateless; every method takes the run's ``TrainConfig``. What a player
changes inside a stage is looked up in the stage's own table of players, keyed by
``config.player``. Modules that load MuJoCo, torch or SB3 are imported inside the methods, so
that reading a configuration (which checks it against the stages) stays light.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

if TYPE_CHECKING:  # SB3 is imported where its env is built: the RLlib backend runs without it
    from rallysim.policies.types import Policy
    from rallysim.train.config import TrainConfig
    from rallysim.train.sb3_vec import NativeVecEnv
    from rallysim.train.warm_start import CloneTask


class Stage:
    """One stage of the method: the env it trains on, how it is judged and what it exports."""

    name: ClassVar[str]
    unit: ClassVar[str]  # what one SB3 step (one unit of the budget) is
    title: ClassVar[str]  # the stage in messages
    players: ClassVar[tuple[str, ...]]  # the players it trains
    score_key: ClassVar[str] = "mean_rally"  # the number a learning curve plots
    # one policy acts for both players of a rally (RLlib: multi-agent, agent steps counted)
    multi_agent: ClassVar[bool] = False
    # training slots per simulated env: 2 where each rally-player pair is a slot
    slots_per_env: ClassVar[int] = 1
    warm_starts: ClassVar[bool] = False  # whether a warm start (behaviour cloning) applies
    sweeps_goals: ClassVar[bool] = False  # whether a goal sweep (``goal_sweep``) applies

    def make_env(self, config: TrainConfig) -> NativeVecEnv:
        """The training env behind SB3's ``VecEnv`` API (same-step autoreset)."""
        raise NotImplementedError

    def env_options(self, config: TrainConfig) -> dict[str, Any]:
        """The plain values that rebuild the training env elsewhere (an RLlib env runner)."""
        return {"shuttle": config.shuttle}

    def evaluate(self, config: TrainConfig, act: Policy, rallies: int | None = None
                 ) -> dict[str, Any]:
        """The stage's numbers for deterministic policy ``act`` (observations -> actions)."""
        raise NotImplementedError

    def headline(self, config: TrainConfig, result: dict[str, Any]) -> str:
        """One line of ``evaluate``'s numbers for progress output."""
        return rally_headline(result)

    def export_env(self, config: TrainConfig) -> str:
        """The env id an exported policy drives (written into its JSON)."""
        raise NotImplementedError

    def goal_mapping(self, config: TrainConfig) -> str | None:
        """How the policy's action becomes a goal, for stages whose action is one."""
        return None

    def teacher(self, config: TrainConfig) -> tuple[Policy, str]:
        """The scripted controller a warm start clones, and its name (``warm_starts``)."""
        raise ValueError(f"the {self.name} stage has no warm start")

    def clone_task(self, config: TrainConfig) -> CloneTask:
        """Where a warm start's teacher and clone play (``warm_starts``)."""
        raise ValueError(f"the {self.name} stage has no warm start")

    def start(self, config: TrainConfig, model: Any) -> dict[str, Any] | None:
        """Before a new run's PPO (not on resume): set ``model``'s starting point and return
        what that cost and found, for the learning curve (the high stage's goal sweep);
        None where nothing is done. ``decisions`` in it count as decisions simulated."""
        return None

    def begin(self, config: TrainConfig, model: Any, out: Path,
              state: dict[str, Any] | None) -> Any:
        """Stage state beside PPO (the compete stage's league), restored from a checkpoint's
        ``state`` or new; None for stages without any."""
        return None

    def rollout_end(self, extra: Any, model: Any, say: Any) -> None:
        """After each PPO rollout, with ``begin``'s object."""

    def decisions_simulated(self, vec_env: NativeVecEnv, steps: int) -> int:
        """Decisions simulated by a training env after ``steps`` steps (the same, unless a
        step spans many decisions)."""
        return steps


def rally_result(lengths: np.ndarray) -> dict[str, Any]:
    """A stage's numbers from evaluation rally lengths."""
    return {"rallies": len(lengths), "mean_rally": float(lengths.mean()),
            "median_rally": float(np.median(lengths)), "capped": int((lengths >= 50).sum())}


def rally_headline(result: dict[str, Any]) -> str:
    return f"mean rally {result['mean_rally']:.2f} capped {result['capped']}/{result['rallies']}"
