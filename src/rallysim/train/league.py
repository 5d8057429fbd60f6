"""The compete stage's league: who the learner plays, when it is copied, how copies are rated.

The pool (after ML-Agents' ghost trainer): frozen snapshots of the learner, exported as policy
files (``RUN/pool/snapshot_{N:012d}.{safetensors,json}``, N the units of the stage's budget
done: turns for compete, decisions for compete_mono; the records call them ``turns``). A game
draws its opponent:

- the latest snapshot with probability ``league.latest_ratio``;
- one of the ``league.anchors`` (fixed agents of ``rallysim.eval.agents``, e.g. the scripted
  controller) with probability ``league.anchor_ratio``, uniformly;
- otherwise one of the ``league.window`` snapshots before the latest, uniformly (the latest
  when there are none yet).

A snapshot is taken when the run starts (the untrained learner), every
``league.snapshot_every`` units, and early once the learner has won ``league.win_threshold``
of the last ``league.win_points`` or more training points against the pool. The agents of
``league.ladder`` are first rated among themselves (``rallysim.eval.ratings.calibrate``: a
round-robin of ``league.rating_games`` games per pair); then each new snapshot plays
``league.rating_games`` games against every one of them and is rated with the ladder held
fixed (``rallysim.eval.ratings.rate_against``, each point a match, the function the study
and ``rallysim evaluate`` use too). The ratings go to the run's TensorBoard log and its
checkpoints. With ``league.opponents`` set, the pool is those agents alone, fixed: the stage
then trains a best response (exploitability) and takes no snapshots.

Everything the league holds is saved in the stage's checkpoints as JSON (snapshot files,
ratings, the env's opponent stream), so a resumed run (after ``kill -9``) continues the same
league.
"""

from __future__ import annotations

from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from rallysim.eval.agents import agent
from rallysim.policies.registry import resolve
from rallysim.policies.types import Agent

if TYPE_CHECKING:
    from rallysim.envs.compete_turn import CompeteSeat
    from rallysim.train.config import TrainConfig
    from rallysim.train.stages.base import Stage

POOL = "pool"


class League:
    """The pool and ratings of one compete run (see the module)."""

    def __init__(self, config: TrainConfig, out: Path, env: CompeteSeat, stage: Stage) -> None:
        self.config, self.out, self.env = config, Path(out), env
        self.stage = stage  # the learner's kind: its snapshots' agents and exports
        settings = config.league
        self.fixed = settings.names(settings.opponents)
        self.anchor_names = [] if self.fixed else settings.names(settings.anchors)
        self.low = resolve(config.low_policy, "rally_low", config.player)
        self.anchors = [self._agent(n) for n in (self.fixed or self.anchor_names)]
        self.snapshots: list[dict[str, Any]] = []  # {"name", "turns"}, oldest first
        self._agents: dict[str, Agent] = {}
        self.last_snapshot = 0
        self.tally = np.zeros(2, np.int64)  # training points won, lost since the last snapshot
        self.ratings: dict[str, Any] = {}
        self.history: list[dict[str, Any]] = []  # per snapshot: turns, rating

    @property
    def self_play(self) -> bool:
        return not self.fixed

    def _agent(self, name: str) -> Agent:
        return agent(name, self.config.player, seed=self.config.seed, low=self.low)

    def snapshot_agent(self, name: str) -> Agent:
        if name not in self._agents:
            self._agents[name] = self.stage.snapshot_agent(self.config, self.out / POOL / name,
                                                           name, self.low)
        return self._agents[name]

    # -- the pool -------------------------------------------------------------------------------
    def opponents(self) -> tuple[list[Agent], list[float]]:
        """The agents games are drawn from and their weights."""
        s = self.config.league
        if not self.self_play:
            return self.anchors, [1.0] * len(self.anchors)
        latest = self.snapshot_agent(self.snapshots[-1]["name"])
        window = [self.snapshot_agent(x["name"]) for x in self.snapshots[-1 - s.window:-1]]
        agents: list[Agent] = [latest]
        weights = [s.latest_ratio]
        rest = 1.0 - s.latest_ratio - (s.anchor_ratio if self.anchors else 0.0)
        if window:
            agents += window
            weights += [rest / len(window)] * len(window)
        else:
            weights[0] += rest
        if self.anchors:
            agents += self.anchors
            weights += [s.anchor_ratio / len(self.anchors)] * len(self.anchors)
        return agents, weights

    def refresh(self) -> None:
        self.env.set_opponents(*self.opponents())

    def record_points(self) -> None:
        """Take the points the env counted since the last call."""
        self.tally += self.env.take_tally()

    def snapshot_due(self, turns: int) -> bool:
        if not self.self_play:
            return False
        s = self.config.league
        if turns - self.last_snapshot >= s.snapshot_every:
            return True
        played = int(self.tally.sum())
        return played >= s.win_points and self.tally[0] / played >= s.win_threshold

    def add_snapshot(self, model: Any, turns: int) -> dict[str, Any]:
        """Export the learner as a new snapshot, rate it against the ladder, refresh the pool.
        Returns the snapshot's record."""
        from rallysim.train.export import save_policy

        name = f"snapshot_{turns:012d}"
        won, lost = (int(v) for v in self.tally)
        save_policy(model, self.out / POOL / name, env_id=self.stage.export_env(self.config),
                    metadata={"stage": self.config.stage, "player": self.config.player,
                              "seed": self.config.seed, "steps": turns,
                              "goal_mapping": self.stage.goal_mapping(self.config)})
        record = {"name": name, "turns": turns, "train_points_won": won,
                  "train_points_lost": lost}
        self.snapshots.append(record)
        self.last_snapshot = turns
        self.tally[:] = 0
        record.update(self.rate(name))
        self.history.append(dict(record))
        self.refresh()
        return record

    def rate(self, name: str) -> dict[str, Any]:
        """Snapshot ``name``'s games against the ladder, rated by
        ``rallysim.eval.ratings.rate_against`` (each point a match) with the calibrated
        ladder held fixed: its rating and its point-win rate against each ladder agent. The
        first call calibrates the ladder (``calibrate``: a round-robin of its agents); the
        calibrated ratings are kept with the snapshots' in ``self.ratings``."""
        s = self.config.league
        if not s.rating_games:
            return {}
        from rallysim.eval.ratings import Ratings, calibrate, rate_against

        ladder = s.names(s.ladder)
        common = {"games": s.rating_games, "seed": self.config.eval.seed,
                  "max_decisions": s.rating_decisions, "shuttle": self.config.shuttle,
                  "low": self.low}
        ratings = Ratings.from_json(self.ratings) if self.ratings else Ratings()
        if any(rung not in ratings for rung in ladder):
            calibrated, _ = calibrate(ladder, player=self.config.player, **common)
            for rung in ladder:
                ratings.players[rung] = calibrated.get(rung)
        played = rate_against(ratings, name, self.snapshot_agent(name), ladder,
                              spec=self.config.player, **common)
        self.ratings = ratings.to_json()
        return {"rating": ratings.ordinal(name),
                "point_win_rate": {other: g.point_win_rate for other, g in played.items()}}

    # -- resume ---------------------------------------------------------------------------------
    def state(self) -> dict[str, Any]:
        return {"snapshots": self.snapshots, "last_snapshot": self.last_snapshot,
                "tally": self.tally.tolist(), "ratings": self.ratings,
                "history": self.history, "rng": self.env.rng.bit_generator.state}

    def restore(self, state: dict[str, Any]) -> None:
        self.snapshots = list(state["snapshots"])
        self.last_snapshot = int(state["last_snapshot"])
        self.tally = np.asarray(state["tally"], np.int64)
        self.ratings = dict(state["ratings"])
        self.history = list(state["history"])
        missing = [x["name"] for x in self.snapshots
                   if not (self.out / POOL / f"{x['name']}.json").is_file()]
        if missing:
            raise FileNotFoundError(f"the league's snapshot(s) {', '.join(missing)} are "
                                    f"missing from {self.out / POOL}; restart the run")
        self.refresh()
        self.env.resume_opponent_stream(state["rng"])
