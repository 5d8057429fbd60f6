"""The high stage: PPO on the turn-based rally over a frozen low level, one SB3 step per turn,
one policy for both players; judged by the mean rally length.

SIMPLE: ``SimpleRallyTurnVectorEnv``, the action a in [-1, 1] setting the goal 4 + 2a m.
HUMAN-LIKE: ``HumanLikeRallyTurnVectorEnv``, the action the 3-D goal (speed, elevation and
azimuth of the racket velocity) for its low level (``AimedSwing`` when ``scripted``).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

import numpy as np

from rallysim.players import HUMANLIKE, SIMPLE, get_player
from rallysim.policies.callables import Composed
from rallysim.policies.registry import resolve
from rallysim.policies.types import Policy
from rallysim.train.stages.base import Stage, rally_result

if TYPE_CHECKING:
    from rallysim.train.config import TrainConfig
    from rallysim.train.sb3_vec import NativeVecEnv


@dataclass(frozen=True)
class HighPlayer:
    """What the high stage does differently for one player."""

    make_env: Callable[[TrainConfig], NativeVecEnv]
    rally_lengths: Callable[[TrainConfig, Policy, int], np.ndarray]  # (config, act, rallies)
    goal_mapping: str  # written into the exported policy
    export_env: str


def _simple_env(config: TrainConfig) -> NativeVecEnv:
    from gymnasium.wrappers.vector import RescaleAction

    from rallysim.envs.simple_rally_turn_v0 import SimpleRallyTurnVectorEnv
    from rallysim.train.sb3_vec import NativeVecEnv

    turns = SimpleRallyTurnVectorEnv(config.ppo.n_envs,
                                     low_level=resolve(config.low_policy, "rally_low"),
                                     autoreset_mode="same_step", seed=config.seed,
                                     shuttle=config.shuttle)
    # [-1, 1] onto the goal range [2, 6] m: SIMPLE.goal.from_action's 4 + 2a, in the wrapper's
    # float32 arithmetic (trained networks and their seeded runs were made with it)
    unit = np.ones(1, np.float32)
    return NativeVecEnv(RescaleAction(turns, min_action=-unit, max_action=unit))


def _simple_lengths(config: TrainConfig, act: Policy, rallies: int) -> np.ndarray:
    from rallysim.core.tasks.rally import RallyConfig
    from rallysim.eval.rally_eval import rally_lengths_turns

    return rally_lengths_turns(Composed(SIMPLE.goal.from_action, act),
                               resolve(config.low_policy, "rally_low"),
                               rallies, config.eval.seed, RallyConfig(shuttle=config.shuttle))


def _humanlike_env(config: TrainConfig) -> NativeVecEnv:
    from rallysim.envs.humanlike_rally_turn_v0 import HumanLikeRallyTurnVectorEnv
    from rallysim.train.sb3_vec import NativeVecEnv

    low = resolve(config.low_policy, "rally_low", HUMANLIKE)
    return NativeVecEnv(HumanLikeRallyTurnVectorEnv(config.ppo.n_envs, low_level=low,
                                                    seed=config.seed,
                                                    autoreset_mode="same_step",
                                                    shuttle=config.shuttle))


def _humanlike_lengths(config: TrainConfig, act: Policy, rallies: int) -> np.ndarray:
    from rallysim.core.tasks.rally import RallyConfig
    from rallysim.eval.rally_eval import rally_lengths_turns

    return rally_lengths_turns(act, resolve(config.low_policy, "rally_low", HUMANLIKE),
                               rallies, config.eval.seed, RallyConfig(shuttle=config.shuttle),
                               player=HUMANLIKE)


PLAYERS: dict[str, HighPlayer] = {
    "simple": HighPlayer(_simple_env, _simple_lengths, SIMPLE.goal.mapping,
                         "RallySim/SimpleRallyTurn-v0"),
    "humanlike": HighPlayer(_humanlike_env, _humanlike_lengths, HUMANLIKE.goal.mapping,
                            "RallySim/HumanLikeRallyTurn-v0"),
}


class HighStage(Stage):
    name: ClassVar[str] = "high"
    unit: ClassVar[str] = "turns"
    title: ClassVar[str] = "high"
    players: ClassVar[tuple[str, ...]] = tuple(PLAYERS)
    multi_agent: ClassVar[bool] = True
    sweeps_goals: ClassVar[bool] = True

    def make_env(self, config: TrainConfig) -> NativeVecEnv:
        return PLAYERS[config.player].make_env(config)

    def env_options(self, config: TrainConfig) -> dict[str, Any]:
        return {"shuttle": config.shuttle, "low_policy": config.low_policy}

    def start(self, config: TrainConfig, model: Any) -> dict[str, Any] | None:
        """The goal sweep (``rallysim.train.goal_sweep``): PPO's Gaussian starts at the fixed
        goal the frozen low level rallies longest on, one grid step wide."""
        if not config.goal_sweep:
            return None
        from rallysim.core.tasks.rally import RallyConfig
        from rallysim.train.goal_sweep import grid_step, start_at, sweep_goals

        player = get_player(config.player)
        low = resolve(config.low_policy, "rally_low", player)
        sweep = sweep_goals(player, low, config.goal_sweep_points, config.goal_sweep,
                            config.seed, RallyConfig(shuttle=config.shuttle))
        start_at(model, np.asarray(sweep["best_action"]), grid_step(config.goal_sweep_points))
        return sweep

    def evaluate(self, config: TrainConfig, act: Policy, rallies: int | None = None
                 ) -> dict[str, Any]:
        n = rallies or config.eval.episodes
        return rally_result(PLAYERS[config.player].rally_lengths(config, act, n))

    def export_env(self, config: TrainConfig) -> str:
        return PLAYERS[config.player].export_env

    def goal_mapping(self, config: TrainConfig) -> str | None:
        return PLAYERS[config.player].goal_mapping

    def decisions_simulated(self, vec_env: NativeVecEnv, steps: int) -> int:
        # a turn runs the frozen low level for many decisions; the turn env counts them
        inner = vec_env.venv.unwrapped
        return int(getattr(inner, "decisions_simulated", 0))


HIGH = HighStage()
