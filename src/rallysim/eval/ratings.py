"""OpenSkill ratings of competitive players from the points they played.

**Each point (rally) is one two-player match** of OpenSkill's Plackett-Luce model, its winner
first (``rate_points``). Rating whole games instead saturates: a player that wins every game
against a ladder gets the same rating however many points it concedes, so snapshots that all
win every rating game cannot be told apart. Points never saturate (a low level that misses
now and then concedes some), and a game gives some 20 to 40 of them. ``Ratings.update(...,
unit="game")`` still rates games (a game stopped unfinished counts by its score: the leader
wins, a level score is a draw; one stopped before any point is left out).

Every player RallySim rates is a frozen policy, whose skill cannot drift between its points:
the model's dynamics ``tau`` is 0 (OpenSkill's default 25/300 would make a rating forget its
early points). Matches are rated one at a time, which makes the result depend slightly on
their order: ``rate_points`` takes the points of several pairings interleaved (the first point
of each pairing in turn, then the second, ...), so that no opponent's points come last.

Ratings are deterministic: a player is known by its name only (OpenSkill's rating objects
carry random ids; they are made afresh for every match and never stored). ``Ratings.to_json``
and ``from_json`` round-trip every float exactly (JSON writes a float's shortest repr), so a
training run that resumes carries on with the same numbers.

``REFERENCE_LADDER`` names the fixed players (random goals, the scripted controller, the
shipped HRL and Monolithic agents, and a fixed deep goal over the shipped low level, a rung as
strong as a trained champion) that a learner is rated against. ``calibrate`` rates the ladder
first, by a round-robin of its players; ``rate_against`` then plays a player against each rung
and moves that player's rating only, so the calibrated ladder stays the fixed yardstick that
makes ordinals comparable over a run and between runs.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Iterable, Mapping, Sequence
from itertools import combinations
from typing import Any

import numpy as np
from openskill.models import PlackettLuce

from rallysim.eval.agents import Agent, agent
from rallysim.eval.competitive import DEFAULT_MAX_DECISIONS, Games, play_games
from rallysim.players import PlayerSpec
from rallysim.policies.types import LowLevel

MODEL = "PlackettLuce"
# openskill 6's defaults (mu 25, sigma mu/3, beta sigma/2) but no dynamics (tau 0; openskill's
# is mu/300): the players rated are frozen policies (see the module). Written into every JSON
# document, so that a later openskill with other defaults rates a resumed run alike
DEFAULTS = {"mu": 25.0, "sigma": 25.0 / 3.0, "beta": 25.0 / 6.0, "tau": 0.0}

A_WON, B_WON, DRAW, NO_RESULT = 0, 1, -1, -2
UNITS = ("point", "game")

REFERENCE_LADDER: tuple[str, ...] = ("random", "scripted", "hrl", "mono", "fixed:6")

Say = Callable[[str], None]


def game_outcomes(games: Games) -> np.ndarray:
    """Per game: ``A_WON``, ``B_WON``, ``DRAW`` (stopped with a level score) or ``NO_RESULT``
    (stopped before any point)."""
    a, b = games.points[:, 0], games.points[:, 1]
    by_score = np.where(a > b, A_WON, np.where(b > a, B_WON, DRAW))
    by_score[(a + b) == 0] = NO_RESULT
    return np.where(games.winner >= 0, games.winner, by_score).astype(np.int64)


def point_outcomes(games: Games) -> np.ndarray:
    """Per point, in the order played: ``A_WON`` or ``B_WON``."""
    return np.where(games.point_a_won, A_WON, B_WON).astype(np.int64)


def outcomes(games: Games, unit: str = "point") -> np.ndarray:
    """The matches ``games`` holds: its points or its games (see the module)."""
    if unit not in UNITS:
        raise ValueError(f"unit must be one of {UNITS}, got {unit!r}")
    return point_outcomes(games) if unit == "point" else game_outcomes(games)


class Ratings:
    """Name -> (mu, sigma); a name never rated has the model's defaults."""

    def __init__(self, players: Mapping[str, tuple[float, float]] | None = None,
                 model: Mapping[str, float] | None = None) -> None:
        self.model = dict(DEFAULTS if model is None else model)
        if set(self.model) != set(DEFAULTS):
            raise ValueError(f"rating model parameters must be {sorted(DEFAULTS)}, got "
                             f"{sorted(self.model)}")
        self._openskill = PlackettLuce(**self.model)
        self.players: dict[str, tuple[float, float]] = {}
        for name, (mu, sigma) in (players or {}).items():
            self.players[name] = (float(mu), float(sigma))

    def __contains__(self, name: str) -> bool:
        return name in self.players

    def __eq__(self, other: object) -> bool:
        return (isinstance(other, Ratings) and self.model == other.model
                and self.players == other.players)

    def __repr__(self) -> str:
        return f"Ratings({self.players!r})"

    def get(self, name: str) -> tuple[float, float]:
        return self.players.get(name, (self.model["mu"], self.model["sigma"]))

    def mu(self, name: str) -> float:
        return self.get(name)[0]

    def sigma(self, name: str) -> float:
        return self.get(name)[1]

    def ordinal(self, name: str) -> float:
        """mu - 3 sigma: a rating the player very likely has at least (what a ladder sorts)."""
        mu, sigma = self.get(name)
        return mu - 3.0 * sigma

    def rate(self, a: str, b: str, outcome: int, fixed: Collection[str] = ()) -> None:
        """One match of ``a`` and ``b`` (``A_WON``, ``B_WON`` or ``DRAW``); the names in
        ``fixed`` keep their ratings (anchors)."""
        if a == b:
            raise ValueError(f"a player cannot be rated against itself ({a!r}); give the two "
                             "sides different names")
        if outcome == NO_RESULT:
            return
        if outcome not in (A_WON, B_WON, DRAW):
            raise ValueError(f"outcome must be A_WON, B_WON, DRAW or NO_RESULT, got {outcome}")
        # fresh rating objects per match: their random ids never reach the stored numbers
        ra = self._openskill.rating(*self.get(a))
        rb = self._openskill.rating(*self.get(b))
        ranks = {A_WON: [1, 2], B_WON: [2, 1], DRAW: [1, 1]}[outcome]
        [[na], [nb]] = self._openskill.rate([[ra], [rb]], ranks=ranks)
        for name, new in ((a, na), (b, nb)):
            if name not in fixed:
                self.players[name] = (float(new.mu), float(new.sigma))

    def update(self, a: str, b: str, games: Games, fixed: Collection[str] = (),
               unit: str = "point") -> None:
        """Rate ``play_games(a, b)``: every point in the order played (``unit="point"``), or
        every game in order (``unit="game"``; see the module)."""
        for outcome in outcomes(games, unit):
            self.rate(a, b, int(outcome), fixed)

    def table(self, names: Iterable[str] | None = None) -> list[dict[str, Any]]:
        """``{name, mu, sigma, ordinal}`` per player, best ordinal first (ties by name)."""
        rows = [{"name": n, "mu": self.mu(n), "sigma": self.sigma(n), "ordinal": self.ordinal(n)}
                for n in (self.players if names is None else names)]
        return sorted(rows, key=lambda r: (-r["ordinal"], r["name"]))

    def to_json(self) -> dict[str, Any]:
        """A plain JSON object (names sorted, so equal ratings write equal files)."""
        return {"model": MODEL, "parameters": dict(self.model),
                "players": {n: {"mu": mu, "sigma": sigma}
                            for n, (mu, sigma) in sorted(self.players.items())}}

    @classmethod
    def from_json(cls, doc: Any) -> Ratings:
        """The ratings ``to_json`` wrote; a malformed document is a ValueError saying where."""
        if not isinstance(doc, dict) or doc.get("model") != MODEL:
            raise ValueError(f"ratings must be a JSON object with model {MODEL!r}")
        params, players = doc.get("parameters"), doc.get("players")
        if not isinstance(params, dict) or not isinstance(players, dict):
            raise ValueError("ratings need the objects 'parameters' and 'players'")
        model = {k: _number(v, f"parameters.{k}") for k, v in params.items()}
        table = {}
        for name, entry in players.items():
            if not isinstance(entry, dict) or set(entry) != {"mu", "sigma"}:
                raise ValueError(f"ratings: players.{name} must be an object with mu and sigma")
            table[name] = (_number(entry["mu"], f"players.{name}.mu"),
                           _number(entry["sigma"], f"players.{name}.sigma"))
        return cls(table, model)


def _number(value: Any, where: str) -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) or not math.isfinite(value):
        raise ValueError(f"ratings: {where} must be a finite number, got {value!r}")
    return float(value)


Match = tuple[str, str, Games]


def rate_points(ratings: Ratings, matches: Sequence[Match], fixed: Collection[str] = (),
                unit: str = "point") -> None:
    """Rate the points (or games) of several pairings ``(a, b, games)``, interleaved: the
    first point of each pairing in turn, then the second, and so on (see the module); the
    names in ``fixed`` keep their ratings."""
    streams = [(a, b, outcomes(games, unit)) for a, b, games in matches]
    longest = max((len(o) for _, _, o in streams), default=0)
    for k in range(longest):
        for a, b, o in streams:
            if k < len(o):
                ratings.rate(a, b, int(o[k]), fixed)


def calibrate(ladder: Iterable[str] = REFERENCE_LADDER, games: int = 16, seed: int = 0,
              max_decisions: int = DEFAULT_MAX_DECISIONS, shuttle: str = "paper",
              low: LowLevel | str = "pretrained", player: str | PlayerSpec = "simple",
              say: Say | None = None, played: Mapping[tuple[str, str], Games] | None = None,
              unit: str = "point") -> tuple[Ratings, dict[tuple[str, str], Games]]:
    """Rate the ladder among itself: every pair of its players plays ``games`` games (each
    pair with ``seed``, as ``crossplay`` plays them; a pair found in ``played`` is not played
    again), and all their points are rated together, from OpenSkill's defaults. A ladder of
    one player keeps the defaults. Returns the ratings (every rung in them) and the games."""
    ladder = list(ladder)
    if len(set(ladder)) != len(ladder):
        raise ValueError(f"each ladder player may appear once, got {ladder}")
    games_by_pair = dict(played or {})
    for a, b in combinations(ladder, 2):
        if (a, b) not in games_by_pair:
            if say:
                say(f"[ratings] calibrating the ladder: {a} vs {b}, {games} games")
            games_by_pair[a, b] = play_games(agent(a, player, low=low), agent(b, player, low=low),
                                             games, seed, shuttle, max_decisions)
    ratings = Ratings()
    rate_points(ratings, [(a, b, games_by_pair[a, b]) for a, b in combinations(ladder, 2)],
                unit=unit)
    for name in ladder:  # rung never rated (a ladder of one): the defaults, stored
        ratings.players.setdefault(name, ratings.get(name))
    return ratings, {pair: games_by_pair[pair] for pair in combinations(ladder, 2)}


def rate_against(ratings: Ratings, name: str, player: Agent,
                 ladder: Iterable[str] = REFERENCE_LADDER, games: int = 16, seed: int = 0,
                 max_decisions: int = DEFAULT_MAX_DECISIONS, shuttle: str = "paper",
                 say: Say | None = None, low: LowLevel | str = "pretrained",
                 spec: str | PlayerSpec = "simple", unit: str = "point") -> dict[str, Games]:
    """Play ``player`` (rated as ``name``) against each ladder player in order, ``games``
    games each with ``seed`` (the games ``crossplay`` plays for that pair), the rungs'
    hierarchical players over the low level ``low``; rate all those points interleaved
    (``rate_points``) and move ``name``'s rating only: the ladder's ratings are the fixed
    anchors, and must be in ``ratings`` already (``calibrate`` them first). Returns each
    opponent's ``Games``."""
    ladder = list(ladder)
    missing = [n for n in ladder if n not in ratings]
    if missing:
        raise ValueError(f"the ladder players {missing} have no rating yet: rate the ladder "
                         "first (calibrate), then rate against it")
    if name in ladder:
        raise ValueError(f"{name!r} is a ladder player: give the rated player another name")
    results = {}
    for opponent in ladder:
        if say:
            say(f"[ratings] {name} vs {opponent}: {games} games")
        results[opponent] = play_games(player, agent(opponent, spec, low=low), games, seed,
                                       shuttle, max_decisions)
    rate_points(ratings, [(name, o, g) for o, g in results.items()], fixed=ladder, unit=unit)
    return results


def counts(games: Games) -> dict[str, Any]:
    """The first player's points (won, lost), games won and lost, and point-win rate (None:
    no point played)."""
    rate = games.point_win_rate
    return {"points": games.points.sum(axis=0).tolist(),
            "games_won": int((games.winner == 0).sum()),
            "games_lost": int((games.winner == 1).sum()),
            "point_win_rate": rate if math.isfinite(rate) else None}
