"""OpenSkill ratings of competitive players from the games they played.

Each game is one two-player match of OpenSkill's Plackett-Luce model, winner first. A game
stopped unfinished (``Games.winner == -1``: two players that never miss replay lets until
``max_decisions``) counts by its score: the leader wins, a level score is a draw; one stopped
before any point was scored says nothing about either player and is left out.

Ratings are deterministic: games are rated one at a time in their order in ``Games``, and a
player is known by its name only (OpenSkill's rating objects carry random ids; they are made
afresh for every match and never stored). ``Ratings.to_json`` and ``from_json`` round-trip
every float exactly (JSON writes a float's shortest repr), so a training run that resumes
carries on with the same numbers.

``REFERENCE_LADDER`` names the fixed players (random goals, the scripted controller, the
shipped HRL and Monolithic agents) that a learner is rated against; ``rate_against`` plays a
player against them and moves its rating only, so the ladder stays the fixed yardstick that
makes the learner's ordinal comparable over a run.
"""

from __future__ import annotations

import math
from collections.abc import Callable, Collection, Iterable, Mapping
from typing import Any

import numpy as np
from openskill.models import PlackettLuce

from rallysim.eval.agents import Agent, agent
from rallysim.eval.competitive import DEFAULT_MAX_DECISIONS, Games, play_games

MODEL = "PlackettLuce"
# the models' defaults (openskill 6): mu 25, sigma mu/3, beta sigma/2, tau mu/300. Written into
# every JSON document so that a later openskill with other defaults rates a resumed run alike
DEFAULTS = {"mu": 25.0, "sigma": 25.0 / 3.0, "beta": 25.0 / 6.0, "tau": 25.0 / 300.0}

A_WON, B_WON, DRAW, NO_RESULT = 0, 1, -1, -2

REFERENCE_LADDER: tuple[str, ...] = ("random", "scripted", "hrl", "mono")

Say = Callable[[str], None]


def game_outcomes(games: Games) -> np.ndarray:
    """Per game: ``A_WON``, ``B_WON``, ``DRAW`` (stopped with a level score) or ``NO_RESULT``
    (stopped before any point)."""
    a, b = games.points[:, 0], games.points[:, 1]
    by_score = np.where(a > b, A_WON, np.where(b > a, B_WON, DRAW))
    by_score[(a + b) == 0] = NO_RESULT
    return np.where(games.winner >= 0, games.winner, by_score).astype(np.int64)


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

    def update(self, a: str, b: str, games: Games, fixed: Collection[str] = ()) -> None:
        """Rate every game of ``play_games(a, b)``, in order (see the module)."""
        for outcome in game_outcomes(games):
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


def rate_against(ratings: Ratings, name: str, player: Agent,
                 ladder: Iterable[str] = REFERENCE_LADDER, games: int = 16, seed: int = 0,
                 max_decisions: int = DEFAULT_MAX_DECISIONS, shuttle: str = "paper",
                 say: Say | None = None) -> dict[str, dict[str, Any]]:
    """Play ``player`` (rated as ``name``) against each ladder player in order, ``games``
    games each, and update ``name``'s rating only: the ladder's ratings are the fixed anchors,
    and must be in ``ratings`` already (rate the ladder once, e.g. with
    ``rallysim.eval.crossplay.crossplay(list(REFERENCE_LADDER), ...)["ratings"]``). Returns
    each opponent's ``Games`` point and game counts."""
    ladder = list(ladder)
    missing = [n for n in ladder if n not in ratings]
    if missing:
        raise ValueError(f"the ladder players {missing} have no rating yet: rate the ladder "
                         "first (crossplay of the ladder), then rate against it")
    if name in ladder:
        raise ValueError(f"{name!r} is a ladder player: give the rated player another name")
    results = {}
    for opponent in ladder:
        if say:
            say(f"[ratings] {name} vs {opponent}: {games} games")
        played = play_games(player, agent(opponent), games, seed, shuttle, max_decisions)
        ratings.update(name, opponent, played, fixed=ladder)
        results[opponent] = {"points": played.points.sum(axis=0).tolist(),
                             "games_won": int((played.winner == 0).sum()),
                             "games_lost": int((played.winner == 1).sum())}
    return results
