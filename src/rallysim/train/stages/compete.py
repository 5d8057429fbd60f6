"""The compete stage: the hierarchical player's high level learns where to send the shuttle to
win points (badminton scoring), over a frozen low level, by self-play against a league of its
own frozen snapshots (``rallysim.train.league``); one SB3 step is one of its turns.

Judged by its point-win rate against ``league.eval_opponents`` (default: the scripted
controller and the cooperative HRL agent). SIMPLE and HUMAN-LIKE (``--player humanlike``:
``configs/compete_humanlike.yaml``, whose goal is the 3-D racket velocity).
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any, ClassVar

from rallysim.policies.types import Agent, LowLevel, Policy
from rallysim.train.stages.base import Stage

if TYPE_CHECKING:
    from rallysim.envs.compete_turn import CompeteSeat
    from rallysim.train.config import TrainConfig
    from rallysim.train.sb3_vec import NativeVecEnv

EXPORT_ENV = "rallysim.envs.compete_turn:CompeteTurnVectorEnv"


class CompeteStage(Stage):
    name: ClassVar[str] = "compete"
    unit: ClassVar[str] = "turns"
    title: ClassVar[str] = "compete"
    players: ClassVar[tuple[str, ...]] = ("simple", "humanlike")
    score_key: ClassVar[str] = "point_win_rate"

    def make_env(self, config: TrainConfig) -> NativeVecEnv:
        from rallysim.eval.agents import agent
        from rallysim.train.sb3_vec import NativeVecEnv

        # a placeholder opponent until the league sets the pool (begin)
        return NativeVecEnv(self.seat(config, [agent("scripted", config.player)]))

    def seat(self, config: TrainConfig, opponents: list[Agent]) -> CompeteSeat:
        """The learner's seat in ``config.ppo.n_envs`` games: it plays turns over the frozen
        low level."""
        from rallysim.envs.compete_turn import CompeteTurnVectorEnv
        from rallysim.players import get_player

        return CompeteTurnVectorEnv(
            config.ppo.n_envs, opponents, low_level=config.low_policy, seed=config.seed,
            max_decisions=config.league.max_decisions, shuttle=config.shuttle,
            player_spec=get_player(config.player))

    def env_options(self, config: TrainConfig) -> dict[str, Any]:
        return {"shuttle": config.shuttle, "low_policy": config.low_policy}

    def evaluate(self, config: TrainConfig, act: Policy, rallies: int | None = None
                 ) -> dict[str, Any]:
        from rallysim.eval.agents import agent
        from rallysim.eval.competitive import play_games, summarise
        from rallysim.players import get_player
        from rallysim.policies.registry import resolve

        p = get_player(config.player)
        low = resolve(config.low_policy, "rally_low", p)
        me = self.learner(config, act, low)
        games = rallies or config.eval.episodes
        result: dict[str, Any] = {"games": games}
        names = config.league.names(config.league.eval_opponents)
        for i, name in enumerate(names):
            played = play_games(me, agent(name, p, seed=config.eval.seed, low=low), games,
                                seed=config.eval.seed + i, shuttle=config.shuttle,
                                max_decisions=config.league.max_decisions)
            result[f"vs_{name}"] = summarise(played, n_boot=500)
        first = result[f"vs_{names[0]}"] if names else None
        result["point_win_rate"] = first["point_win_rate"]["value"] if first else float("nan")
        return result

    def learner(self, config: TrainConfig, act: Policy, low: LowLevel) -> Agent:
        """The learner's deterministic policy ``act`` as a player: its goals for the frozen
        low level ``low``."""
        from rallysim.eval.agents import Hierarchical
        from rallysim.players import get_player
        from rallysim.policies.callables import Composed

        p = get_player(config.player)
        return Hierarchical(Composed(p.goal.from_action, act), low, "learner", p)

    def snapshot_agent(self, config: TrainConfig, prefix: Path, name: str,
                       low: LowLevel) -> Agent:
        """A frozen snapshot of the learner (the policy exported at ``prefix``) as a player,
        over the league's low level ``low``."""
        from rallysim.eval.agents import Hierarchical
        from rallysim.players import get_player
        from rallysim.policies.registry import resolve

        p = get_player(config.player)
        return Hierarchical(resolve(str(prefix), "high", p), low, name, p)

    def headline(self, config: TrainConfig, result: dict[str, Any]) -> str:
        parts = [f"{key[3:]} {value['point_win_rate']['value']:.3f}"
                 for key, value in result.items() if key.startswith("vs_")]
        return "point-win rate " + ", ".join(parts)

    def export_env(self, config: TrainConfig) -> str:
        return EXPORT_ENV

    def goal_mapping(self, config: TrainConfig) -> str | None:
        from rallysim.players import get_player

        return get_player(config.player).goal.mapping

    def decisions_simulated(self, vec_env: NativeVecEnv, steps: int) -> int:
        return int(getattr(vec_env.venv, "decisions_simulated", 0))

    # -- the league (rallysim.train.runner calls these) ------------------------------------------
    def begin(self, config: TrainConfig, model: Any, out: Path,
              state: dict[str, Any] | None) -> Any:
        """The run's league: restored from a checkpoint's ``state``, else a new one whose
        first snapshot is the untrained learner."""
        from rallysim.train.league import League

        league = League(config, out, model.get_env().venv, self)
        if state is not None:
            league.restore(state)
        elif league.self_play:
            league.add_snapshot(model, 0)
        else:
            league.refresh()
        return league

    def rollout_end(self, league: Any, model: Any, say: Any) -> None:
        """After each rollout: count the points, take a snapshot when one is due and log the
        league's numbers to TensorBoard."""
        turns = int(model.num_timesteps)
        league.record_points()
        if league.snapshot_due(turns):
            record = league.add_snapshot(model, turns)
            if say is not None and "rating" in record:
                rates = ", ".join(f"{k} {v:.2f}" for k, v in record["point_win_rate"].items())
                say(f"snapshot {len(league.snapshots)} at {turns:,} {self.unit}: rating "
                    f"{record['rating']:.2f}; point-win rate {rates}")
            logger = getattr(model, "_logger", None)
            if logger is not None and "rating" in record:
                logger.record("league/rating", record["rating"])
                logger.record("league/snapshots", len(league.snapshots))
                for other, rate in record["point_win_rate"].items():
                    logger.record(f"league/point_win_rate_{other}", rate)


COMPETE = CompeteStage()
