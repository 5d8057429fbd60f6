"""Competitive games between two agents (``rallysim.eval.agents``) and their honest summary.

``play_games(a, b, n)`` plays ``n`` batched games under badminton scoring (``RallyConfig(mode=
"competitive")``: +1/-1 per point, games to 21 won by 2, capped at 30, a rally reaching the hit
cap replayed as a let). Agent ``a`` plays player 0 in even games and player 1 in odd ones, so
neither gets the first serve's side more often. A game that has not ended after
``max_decisions`` decisions (two agents that never miss replay lets for ever) stops where it
is: its points count, it has no winner.

``summarise`` gives ``a``'s point-win rate, game-win rate and the mean rally length (hits per
point), each with a 95 % bootstrap interval over games (points of one game are not
independent: the winner serves next).
"""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np

from rallysim.core.tasks.rally import RallyConfig, RallyTask
from rallysim.eval.agents import Agent
from rallysim.eval.stats import Estimate

DEFAULT_MAX_DECISIONS = 200_000  # per game: over 4 h of play at 10 decisions per second


@dataclass
class Games:
    """What ``play_games`` saw, per game (rows) and per point."""

    points: np.ndarray  # (G, 2) points won by a, by b
    winner: np.ndarray  # (G,) 0: a won the game, 1: b won, -1: stopped unfinished
    decisions: np.ndarray  # (G,) decisions played
    lets: np.ndarray  # (G,) rallies replayed at the hit cap
    point_game: np.ndarray  # (P,) the game of each point
    point_hits: np.ndarray  # (P,) the rally length (hits) of each point
    point_a_won: np.ndarray  # (P,) whether a won it

    @property
    def n(self) -> int:
        return len(self.winner)

    @property
    def point_win_rate(self) -> float:
        """a's share of the points played (NaN: none played); ``summarise`` adds its interval."""
        return _ratio(self.points[:, 0], self.points.sum(axis=1))


class Match:
    """N games of agent ``a`` against agent ``b``, advanced one decision at a time: the one
    loop behind ``play_games``, recorded videos and the live viewer. ``side[g]`` is (a's
    player, b's player) in game g; ``live`` marks games still going. The games are played by
    the agents' kind of player (``Agent.player``), which must be the same for both."""

    def __init__(self, a: Agent, b: Agent, n_games: int, seed: int = 0,
                 config: RallyConfig | None = None) -> None:
        if not isinstance(n_games, int) or n_games < 1:
            raise ValueError(f"n_games must be a positive integer, got {n_games!r}")
        config = config or RallyConfig(mode="competitive")
        if config.mode != "competitive":
            raise ValueError("competitive games need RallyConfig(mode='competitive')")
        if a.player.name != b.player.name:
            raise ValueError(f"{a.name!r} is a {a.player.name} player and {b.name!r} a "
                             f"{b.player.name} one: a game needs two players of one kind")
        n = self.n = n_games
        self.a, self.b = a, b
        self.task = RallyTask(n, config, seed=seed, spec=a.player)
        self.task.reset(np.arange(n))
        g = np.arange(n) % 2
        self.side = np.stack([g, 1 - g], axis=1)
        a.start(n)
        b.start(n)
        self.live = np.ones(n, bool)
        self.actions = np.zeros((n, 2, self.task.action_size))

    def step(self) -> tuple[np.ndarray, dict[str, Any]]:
        """One decision of every live game: returns (games that ended, the rally core's
        info); ``info["point_winner"]`` is a player index (-1: no point)."""
        task, rows = self.task, np.flatnonzero(self.live)
        obs = task.observe()
        for who, agent in enumerate((self.a, self.b)):
            s = self.side[rows, who]
            self.actions[rows, s] = agent.act(obs[rows, s], task.turn_started[rows, s], rows)
        _, over, _, info = task.step(np.clip(self.actions, -1.0, 1.0), active=self.live)
        ended = self.live & over
        self.live &= ~over
        return ended, info


def play_games(a: Agent, b: Agent, n_games: int, seed: int = 0, shuttle: str = "paper",
               max_decisions: int = DEFAULT_MAX_DECISIONS,
               config: RallyConfig | None = None) -> Games:
    """Play ``n_games`` games of ``a`` against ``b`` (see the module)."""
    match = Match(a, b, n_games, seed, config or RallyConfig(shuttle=shuttle,
                                                              mode="competitive"))
    n, side = match.n, match.side
    out = Games(points=np.zeros((n, 2), np.int64), winner=np.full(n, -1),
                decisions=np.zeros(n, np.int64), lets=np.zeros(n, np.int64),
                point_game=np.zeros(0, np.int64), point_hits=np.zeros(0, np.int64),
                point_a_won=np.zeros(0, bool))
    games, hits, a_won = [], [], []
    while match.live.any():
        live = match.live.copy()
        ended, info = match.step()
        out.decisions += live
        winner = info["point_winner"]
        scored = live & (winner >= 0)
        if scored.any():
            g = np.flatnonzero(scored)
            won = winner[g] == side[g, 0]
            out.points[g, 0] += won
            out.points[g, 1] += ~won
            games.append(g)
            hits.append(info["rally_length"][g])
            a_won.append(won)
        out.lets += live & info["rally_over"] & (winner < 0)
        if ended.any():
            g = np.flatnonzero(ended)
            out.winner[g] = np.where(out.points[g, 0] > out.points[g, 1], 0, 1)
        match.live &= out.decisions < max_decisions
    if games:
        out.point_game = np.concatenate(games)
        out.point_hits = np.concatenate(hits)
        out.point_a_won = np.concatenate(a_won)
    return out


def _bootstrap(per_game: list[np.ndarray], statistic: Any, n_boot: int,
               rng: np.random.Generator) -> Estimate:
    """``statistic(*columns)`` with a 95 % interval from resampling games."""
    value = float(statistic(*per_game))
    m = len(per_game[0])
    picks = rng.integers(0, m, (n_boot, m))
    reps = np.array([statistic(*(c[p] for c in per_game)) for p in picks])
    reps = reps[np.isfinite(reps)]
    if not len(reps):
        return Estimate(value, float("nan"), float("nan"))
    low, high = np.percentile(reps, [2.5, 97.5])
    return Estimate(value, float(low), float(high))


def _ratio(numerator: np.ndarray, denominator: np.ndarray) -> float:
    total = denominator.sum()
    return float(numerator.sum() / total) if total else float("nan")


def summarise(games: Games, n_boot: int = 2000, seed: int = 0) -> dict[str, Any]:
    """``a``'s point-win rate, game-win rate (finished games) and the mean rally length in
    hits per point, each ``{"value", "low", "high"}`` (95 % bootstrap over games), with the
    counts behind them."""
    rng = np.random.default_rng(seed)
    points = games.points
    per_game_hits = np.bincount(games.point_game, games.point_hits, minlength=games.n)
    per_game_points = points.sum(axis=1)
    finished = games.winner >= 0
    point_rate = _bootstrap([points[:, 0], per_game_points], _ratio, n_boot, rng)
    rally = _bootstrap([per_game_hits, per_game_points], _ratio, n_boot, rng)
    if finished.any():
        wins = (games.winner[finished] == 0).astype(np.float64)
        game_rate = _bootstrap([wins, np.ones_like(wins)], _ratio, n_boot, rng)
    else:
        game_rate = Estimate(float("nan"), float("nan"), float("nan"))
    return {
        "point_win_rate": _as_dict(point_rate),
        "game_win_rate": _as_dict(game_rate),
        "mean_rally": _as_dict(rally),
        "games": games.n,
        "games_finished": int(finished.sum()),
        "points": int(per_game_points.sum()),
        "points_won": int(points[:, 0].sum()),
        "lets": int(games.lets.sum()),
        "decisions": int(games.decisions.sum()),
    }


def _as_dict(e: Estimate) -> dict[str, float]:
    return {"value": e.value, "low": e.low, "high": e.high}
