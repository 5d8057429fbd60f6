"""The low stage: PPO on the player's return task, one SB3 step per decision, judged on fresh
serves; the only stage with a warm start (behaviour cloning of the player's scripted
controller).

SIMPLE: ``RallySim/SimpleReturn-v0`` (goal depth drawn per episode), judged by the mean episode
reward, hit rate and landing error; teacher ``ScriptedController``. HUMAN-LIKE:
``RallySim/HumanLikeReturn-v0`` (target racket velocity per episode), judged by the hit rate and
the velocity's angle and speed errors; teacher ``AimedSwing``.
"""

from __future__ import annotations

import re
import warnings
from collections.abc import Callable
from dataclasses import dataclass
from typing import TYPE_CHECKING, Any, ClassVar

from rallysim.envs.registration import (
    HUMANLIKE_RETURN_ID,
    SIMPLE_RETURN_ID,
    SIMPLE_RETURN_V1_ID,
)
from rallysim.policies.types import Policy
from rallysim.train.stages.base import Stage

if TYPE_CHECKING:
    from rallysim.train.config import TrainConfig
    from rallysim.train.sb3_vec import NativeVecEnv
    from rallysim.train.warm_start import CloneTask

# the warm start's data: the teacher plays with seeds apart from training's (seed + i) and
# the evaluations'
CLONE_SEED_OFFSET = 1_000_003


@dataclass(frozen=True)
class LowPlayer:
    """What the low stage does differently for one player."""

    env_id: str  # the registered id it trains on (built by rallysim.sb3.make_vec_env)
    env_kwargs: Callable[[TrainConfig], dict[str, Any]]
    evaluate: Callable[[TrainConfig, Policy, int], dict[str, Any]]  # (config, act, episodes)
    headline: Callable[[dict[str, Any]], str]
    teacher: Callable[[str], tuple[Policy, str]]  # shuttle -> (scripted controller, its name)
    # (envs, shuttle, **reward options) -> the warm start's vector env
    clone_env: Callable[..., Any]


def _simple_kwargs(config: TrainConfig) -> dict[str, Any]:
    from rallysim.core.tasks.simple_return import REWARD_OPTIONS

    return {"shuttle": config.shuttle, "incoming": config.incoming,
            "keep_bodies": config.keep_bodies, "goals": config.goals,
            **{name: getattr(config, name) for name in REWARD_OPTIONS}}


def _simple_evaluate(config: TrainConfig, act: Policy, episodes: int) -> dict[str, Any]:
    """The task's statistics and, from the same episodes, how closely landings follow the goal
    (the learning curves of docs/rl-alone.md plot both)."""
    from rallysim.eval.low_eval import goal_scores, play_returns, summarise_returns

    played = play_returns(act, episodes=episodes, seed=config.eval.seed, shuttle=config.shuttle)
    return {**summarise_returns(played).as_dict(),
            **goal_scores(played, config.eval.seed, config.shuttle)}


def _simple_headline(result: dict[str, Any]) -> str:
    return (f"reward {result['mean_reward']:.3f} hit {result['hit_rate']:.3f} "
            f"err {result['median_error']:.2f} m")


def _scripted_controller(shuttle: str) -> tuple[Policy, str]:
    from rallysim.policies import ScriptedController

    return ScriptedController().act_return, "ScriptedController"


def _simple_clone_env(n_envs: int, shuttle: str, **options: Any) -> Any:
    from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv

    return SimpleReturnVectorEnv(n_envs, shuttle=shuttle, autoreset_mode="same_step",
                                 **options)


def _humanlike_kwargs(config: TrainConfig) -> dict[str, Any]:
    return {"shuttle": config.shuttle}


def _humanlike_evaluate(config: TrainConfig, act: Policy, episodes: int) -> dict[str, Any]:
    from rallysim.eval.humanlike_eval import evaluate_humanlike

    return evaluate_humanlike(act, episodes=episodes, seed=config.eval.seed,
                              shuttle=config.shuttle)


def _humanlike_headline(result: dict[str, Any]) -> str:
    return (f"reward {result['mean_reward']:.3f} hit {result['hit_rate']:.3f} angle "
            f"{result['mean_angle_error']:.1f} deg speed {result['mean_abs_speed_error']:.2f}")


def _aimed_swing(shuttle: str) -> tuple[Policy, str]:
    from rallysim.policies.aimed_swing import AimedSwing

    return AimedSwing(shuttle), "AimedSwing"


def _humanlike_clone_env(n_envs: int, shuttle: str) -> Any:
    from rallysim.envs.humanlike_return_v0 import HumanLikeReturnVectorEnv

    return HumanLikeReturnVectorEnv(n_envs, shuttle=shuttle, autoreset_mode="same_step")


PLAYERS: dict[str, LowPlayer] = {
    "simple": LowPlayer(SIMPLE_RETURN_ID, _simple_kwargs, _simple_evaluate, _simple_headline,
                        _scripted_controller, _simple_clone_env),
    "humanlike": LowPlayer(HUMANLIKE_RETURN_ID, _humanlike_kwargs, _humanlike_evaluate,
                           _humanlike_headline, _aimed_swing, _humanlike_clone_env),
}


class LowStage(Stage):
    name: ClassVar[str] = "low"
    unit: ClassVar[str] = "decisions"
    title: ClassVar[str] = "low"
    players: ClassVar[tuple[str, ...]] = tuple(PLAYERS)
    score_key: ClassVar[str] = "mean_reward"
    warm_starts: ClassVar[bool] = True

    def make_env(self, config: TrainConfig) -> NativeVecEnv:
        # a registered id with a batched vector entry point, built through the public adapter
        # (rallysim.sb3.make_vec_env): what users get is what training uses
        from rallysim.sb3 import make_vec_env

        env_id = self.export_env(config)
        with warnings.catch_warnings():
            # Gymnasium warns that SimpleReturn-v0 is out of date (v1 exists), but the config
            # chose it: v0 is the paper's task and goals="uniform", the default; v1 is
            # goals="reachable". Only that warning: any other still shows
            warnings.filterwarnings("ignore", f".*The environment {re.escape(env_id)} is out "
                                    "of date", DeprecationWarning)
            return make_vec_env(env_id, config.ppo.n_envs, seed=config.seed,
                                env_kwargs=PLAYERS[config.player].env_kwargs(config))

    def env_options(self, config: TrainConfig) -> dict[str, Any]:
        # "env" names the player: the key rallysim.rllib.envs.make_return_env reads
        return {**_simple_kwargs(config), "env": config.player}

    def evaluate(self, config: TrainConfig, act: Policy, rallies: int | None = None
                 ) -> dict[str, Any]:
        return PLAYERS[config.player].evaluate(config, act, rallies or config.eval.episodes)

    def headline(self, config: TrainConfig, result: dict[str, Any]) -> str:
        return PLAYERS[config.player].headline(result)

    def export_env(self, config: TrainConfig) -> str:
        if config.player == "simple" and config.goals == "reachable":
            return SIMPLE_RETURN_V1_ID
        return PLAYERS[config.player].env_id

    def teacher(self, config: TrainConfig) -> tuple[Policy, str]:
        """The player's scripted controller that the warm start clones, and its name."""
        return PLAYERS[config.player].teacher(config.shuttle)

    def clone_task(self, config: TrainConfig) -> CloneTask:
        """Where the warm start's teacher and clone play."""
        from rallysim.core.tasks.simple_return import REWARD_OPTIONS
        from rallysim.train.warm_start import CloneTask

        options = {k: getattr(config, k) for k in REWARD_OPTIONS if getattr(config, k)}
        return CloneTask(player=config.player, shuttle=config.shuttle,
                         seed=config.seed + CLONE_SEED_OFFSET,
                         make_env=PLAYERS[config.player].clone_env, options=options)


LOW = LowStage()
