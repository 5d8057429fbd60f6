"""What a picture of a competitive game between two agents says and draws: the HUD's score
line (both players' names with their points, the rally length, who won the last point) and
each hierarchical player's held goal.

Shared by the recorded videos (``rallysim.render.record.record_match``) and the live viewer
(``rallysim.render.play.play_match``). It reads a ``rallysim.eval.competitive.Match`` only
through its attributes (``a``, ``b``, ``side``, ``task.spec``) and the rally core's ``info``,
and imports neither: the drawing side of ``rallysim.render`` stays free of the env modules.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def player_names(a: str, b: str, side: np.ndarray) -> tuple[str, str]:
    """The names of players 0 and 1 of a game where agent ``a`` plays ``side[0]`` and ``b``
    ``side[1]``; two agents of the same name are told apart as (A) and (B), the order of
    ``--players``."""
    if a == b:
        a, b = f"{a} (A)", f"{b} (B)"
    return (a, b) if side[0] == 0 else (b, a)


class Scoreboard:
    """The score of one game (game ``game`` of a batch) between two named players, kept from
    the rally core's ``info`` after each decision, and the HUD text that shows it.

    ``names`` are by player index: player 0 is named first, as it stands on the left of the
    side camera's picture. ``point_winners`` lists the player index of every point won, across
    games; ``games`` the final score (player 0, player 1) of each finished game."""

    def __init__(self, names: tuple[str, str], game: int = 0) -> None:
        self.names, self.game = names, game
        self.score = np.zeros(2, np.int64)
        self.point_winners: list[int] = []
        self.games: list[tuple[int, int]] = []
        self.last = ""  # the line about the last point ("" before the first)

    def update(self, info: dict[str, Any], ended: bool = False) -> None:
        """Take one decision's ``info`` (the rally core's, as ``Match.step`` returns it);
        ``ended``: the game ended at this decision."""
        g = self.game
        winner = int(info["point_winner"][g])
        if winner >= 0:
            self.score = np.asarray(info["score"][g], np.int64).copy()
            self.point_winners.append(winner)
            self.last = f"last point: {self.names[winner]} ({_hits(info['rally_length'][g])})"
        elif info["rally_over"][g]:
            # a rally that reached the hit cap is replayed, nobody scores
            self.last = f"last rally: a let at {_hits(info['rally_length'][g])}, replayed"
        if ended:
            self.games.append((int(self.score[0]), int(self.score[1])))

    def new_game(self) -> None:
        """The next game starts at 0-0 (the points and finished games are kept)."""
        self.score = np.zeros(2, np.int64)
        self.last = ""

    @property
    def score_line(self) -> str:
        """``"hrl 3 - 5 scripted"``: player 0's name and points, then player 1's."""
        (n0, n1), (s0, s1) = self.names, self.score
        return f"{n0} {s0} - {s1} {n1}"

    def result(self, score: Any = None) -> str:
        """``"scripted 21-3"``: the leader of ``score`` (player 0's, player 1's points;
        default the current game's) and the score, the leader's points first."""
        s0, s1 = (int(v) for v in (self.score if score is None else score))
        return f"{self.names[0] if s0 > s1 else self.names[1]} {max(s0, s1)}-{min(s0, s1)}"

    def text(self, first_line: str, rally_length: int) -> str:
        """The HUD: ``first_line``, the score with the current rally's length, the last
        point."""
        lines = [first_line, f"{self.score_line}   rally length {rally_length}"]
        if self.last:
            lines.append(self.last)
        return "\n".join(lines)


def _hits(n: Any) -> str:
    return "1 hit" if int(n) == 1 else f"{int(n)} hits"


def held_goals(match: Any, game: int = 0) -> np.ndarray:
    """The goal each player of game ``game`` holds, by player index (2, *goal shape): a
    hierarchical agent's (its ``goals``), NaN for an agent that holds none (a Monolithic
    player, a person at the keyboard), which hides its marker
    (``rallysim.render.markers.goal_markers``)."""
    goals = np.full((2, *match.task.spec.goal.shape), np.nan)
    for who, agent in enumerate((match.a, match.b)):
        held = getattr(agent, "goals", None)
        if held is not None and len(held) > game:
            goals[int(match.side[game, who])] = held[game]
    return goals
