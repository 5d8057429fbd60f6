"""The mono stage, the Monolithic baseline (Table VII): PPO on the rally at the physics rate,
one policy for both players, each rally-player pair a slot; one SB3 step is one decision of
one player; judged by the mean rally length. SIMPLE and HUMAN-LIKE players (the HUMAN-LIKE
rally of ``rallysim.envs.humanlike_rally_v0``: 15 actions per player every 0.1 s).
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any, ClassVar

from rallysim.policies.types import Policy
from rallysim.train.stages.base import Stage, rally_result

if TYPE_CHECKING:
    from rallysim.train.config import TrainConfig
    from rallysim.train.sb3_vec import NativeVecEnv


class MonoStage(Stage):
    name: ClassVar[str] = "mono"
    unit: ClassVar[str] = "player-decisions"
    title: ClassVar[str] = "monolithic"
    players: ClassVar[tuple[str, ...]] = ("simple", "humanlike")
    multi_agent: ClassVar[bool] = True
    slots_per_env: ClassVar[int] = 2

    def make_env(self, config: TrainConfig) -> NativeVecEnv:
        from gymnasium.envs.registration import load_env_creator

        from rallysim.train.sb3_vec import NativeVecEnv

        rallies = config.ppo.n_envs // self.slots_per_env
        vector_env = load_env_creator(VECTOR_ENVS[config.player])  # ("module:class")
        return NativeVecEnv(vector_env(rallies, autoreset_mode="same_step", seed=config.seed,
                                       shuttle=config.shuttle))

    def evaluate(self, config: TrainConfig, act: Policy, rallies: int | None = None
                 ) -> dict[str, Any]:
        from rallysim.core.tasks.rally import RallyConfig
        from rallysim.eval.rally_eval import rally_lengths_direct

        n = rallies or config.eval.episodes
        return rally_result(rally_lengths_direct(act, n, config.eval.seed,
                                                 RallyConfig(shuttle=config.shuttle),
                                                 player=config.player))

    def export_env(self, config: TrainConfig) -> str:
        return VECTOR_ENVS[config.player]


# each player's rally as slots: "module:class"
VECTOR_ENVS = {"simple": "rallysim.envs.simple_rally_v0:SimpleRallyVectorEnv",
               "humanlike": "rallysim.envs.humanlike_rally_v0:HumanLikeRallyVectorEnv"}


MONO = MonoStage()
