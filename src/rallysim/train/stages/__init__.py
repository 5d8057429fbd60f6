"""The three training stages of the paper's method (docs/reference.md §8), one object each:

- ``low`` (``LOW``, ``rallysim.train.stages.low``): the player's return task; budget in
  decisions; the only stage with a warm start;
- ``high`` (``HIGH``, ``.high``): the turn-based rally over a frozen low level; budget in turns;
- ``mono`` (``MONO``, ``.mono``): the rally at the physics rate; budget in player-decisions;
- ``compete`` (``COMPETE``, ``.compete``): the competitive high level by self-play against a
  league of its snapshots (``rallysim.train.league``); budget in turns;
- ``compete_mono`` (``COMPETE_MONO``, ``.compete_mono``): the flat competitive baseline, one
  network acting every decision, by self-play in the same league; budget in decisions.

Each holds its env factory, evaluation, export and player table (``rallysim.train.stages.base.
Stage``); both runners (SB3 and RLlib) run any of them the same way. The functions below take a
``TrainConfig`` and ask its stage, for callers that hold only the config.
"""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

from rallysim.train.stages.base import Stage, rally_result
from rallysim.train.stages.compete import COMPETE
from rallysim.train.stages.compete_mono import COMPETE_MONO
from rallysim.train.stages.high import HIGH
from rallysim.train.stages.low import LOW
from rallysim.train.stages.mono import MONO

if TYPE_CHECKING:
    from rallysim.policies.types import Policy
    from rallysim.train.config import TrainConfig
    from rallysim.train.sb3_vec import NativeVecEnv

__all__ = ["COMPETE", "COMPETE_MONO", "HIGH", "LOW", "MONO", "NAMES", "STAGES", "Stage", "by_name",
           "evaluate", "export_env", "goal_mapping", "headline",
           "make_env", "of", "rally_result", "score"]

STAGES: dict[str, Stage] = {stage.name: stage
                            for stage in (LOW, HIGH, MONO, COMPETE, COMPETE_MONO)}
NAMES: tuple[str, ...] = tuple(STAGES)


def by_name(name: str) -> Stage:
    try:
        return STAGES[name]
    except KeyError:
        raise ValueError(f"unknown stage {name!r}; valid: {', '.join(NAMES)}") from None


def of(config: TrainConfig) -> Stage:
    """The stage ``config`` trains."""
    return by_name(config.stage)


def make_env(config: TrainConfig) -> NativeVecEnv:
    return of(config).make_env(config)


def evaluate(config: TrainConfig, act: Policy, rallies: int | None = None) -> dict[str, Any]:
    return of(config).evaluate(config, act, rallies)


def headline(config: TrainConfig, result: dict[str, Any]) -> str:
    return of(config).headline(config, result)


def score(config: TrainConfig, result: dict[str, Any]) -> float:
    """The number a learning curve plots for this stage."""
    return result[of(config).score_key]


def goal_mapping(config: TrainConfig) -> str | None:
    return of(config).goal_mapping(config)


def export_env(config: TrainConfig) -> str:
    return of(config).export_env(config)
