"""The compete_mono stage: the flat (Monolithic) competitive baseline. One network acts for
its player every decision (the rally observation to the motor action), by self-play against a
league of its own frozen snapshots (``rallysim.train.league``, as the compete stage's learner);
one SB3 step is one decision of every game. SIMPLE only. ``low_policy`` is the low level of
the hierarchical agents among its opponents (anchors, ladder, evaluation), as in the compete
stage.

Its actor starts from ``init_policy``, the cooperative Monolithic policy (default: the shipped
``simple_mono``), as the hierarchical competitive learner starts over the cooperatively trained
low level; ``init_policy=none`` starts from random weights. Judged like the compete stage, by
its point-win rate against ``league.eval_opponents``.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from rallysim.policies.types import Agent, LowLevel, Policy
from rallysim.train.stages.compete import CompeteStage

if TYPE_CHECKING:
    from rallysim.envs.compete_turn import CompeteSeat
    from rallysim.train.config import TrainConfig

EXPORT_ENV = "rallysim.envs.compete_turn:CompeteDecisionVectorEnv"


class CompeteMonoStage(CompeteStage):
    name: ClassVar[str] = "compete_mono"
    unit: ClassVar[str] = "decisions"
    title: ClassVar[str] = "flat compete"

    def seat(self, config: TrainConfig, opponents: list[Agent]) -> CompeteSeat:
        """The learner's seat in ``config.ppo.n_envs`` games: it acts every decision."""
        from rallysim.envs.compete_turn import CompeteDecisionVectorEnv

        return CompeteDecisionVectorEnv(
            config.ppo.n_envs, opponents, seed=config.seed,
            max_decisions=config.league.max_decisions, shuttle=config.shuttle)

    def env_options(self, config: TrainConfig) -> dict[str, Any]:
        return {"shuttle": config.shuttle}

    def learner(self, config: TrainConfig, act: Policy, low: LowLevel) -> Agent:
        from rallysim.eval.agents import Direct

        return Direct(act, "learner")  # (no low level: the flat player acts itself)

    def snapshot_agent(self, config: TrainConfig, prefix: Path, name: str,
                       low: LowLevel) -> Agent:
        from rallysim.eval.agents import Direct
        from rallysim.policies.registry import resolve

        return Direct(resolve(str(prefix), "mono", config.player), name)

    def export_env(self, config: TrainConfig) -> str:
        return EXPORT_ENV

    def goal_mapping(self, config: TrainConfig) -> str | None:
        return None

    def begin(self, config: TrainConfig, model: Any, out: Path,
              state: dict[str, Any] | None) -> Any:
        """A new run's actor starts from ``init_policy`` before its first snapshot (a resumed
        one has its own weights)."""
        if state is None and config.init_policy != "none":
            from rallysim.policies.registry import resolve
            from rallysim.train.export import load_actor

            load_actor(model, resolve(config.init_policy, "mono", config.player))
        return super().begin(config, model, out, state)


COMPETE_MONO = CompeteMonoStage()
