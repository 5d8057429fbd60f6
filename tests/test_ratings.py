"""OpenSkill ratings of competitive games (rallysim.eval.ratings): direction of updates,
unfinished games by score, determinism, exact JSON round trip, the fixed ladder."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rallysim.eval.agents import agent
from rallysim.eval.competitive import Games
from rallysim.eval.ratings import (
    A_WON,
    B_WON,
    DEFAULTS,
    DRAW,
    NO_RESULT,
    Ratings,
    game_outcomes,
    rate_against,
)


def make_games(points: list[list[int]], winner: list[int]) -> Games:
    """Games as ``play_games`` returns them, with the per-point arrays left empty (ratings
    read the points per game and the winners only)."""
    n = len(points)
    return Games(points=np.array(points, np.int64).reshape(n, 2), winner=np.array(winner),
                 decisions=np.ones(n, np.int64), lets=np.zeros(n, np.int64),
                 point_game=np.zeros(0, np.int64), point_hits=np.zeros(0, np.int64),
                 point_a_won=np.zeros(0, bool))


def test_unseen_players_have_the_defaults_and_ordinal_is_mu_minus_three_sigma():
    r = Ratings()
    assert r.get("anyone") == (25.0, 25.0 / 3.0)
    assert r.ordinal("anyone") == pytest.approx(0.0, abs=1e-12)
    r = Ratings({"x": (30.0, 2.0)})
    assert r.ordinal("x") == 24.0
    assert "x" in r and "y" not in r


def test_winner_rises_loser_falls_and_both_become_surer():
    r = Ratings()
    r.update("a", "b", make_games([[21, 10]], [0]))
    (mu_a, s_a), (mu_b, s_b) = r.get("a"), r.get("b")
    assert mu_a > 25.0 > mu_b
    assert mu_a - 25.0 == pytest.approx(25.0 - mu_b)  # equal priors: symmetric moves
    assert s_a < 25.0 / 3.0 and s_b < 25.0 / 3.0
    r2 = Ratings()
    r2.update("a", "b", make_games([[10, 21]], [1]))
    assert r2.mu("b") == mu_a and r2.mu("a") == mu_b  # b winning mirrors a winning


def test_more_wins_move_further():
    one, three = Ratings(), Ratings()
    one.update("a", "b", make_games([[21, 3]], [0]))
    three.update("a", "b", make_games([[21, 3]] * 3, [0, 0, 0]))
    assert three.mu("a") > one.mu("a") > 25.0
    assert three.ordinal("a") > one.ordinal("a")


def test_unfinished_games_count_by_score_and_draws_by_ranks():
    g = make_games([[21, 5], [7, 3], [2, 9], [4, 4], [0, 0]], [0, -1, -1, -1, -1])
    assert game_outcomes(g).tolist() == [A_WON, A_WON, B_WON, DRAW, NO_RESULT]
    by_score, finished = Ratings(), Ratings()
    by_score.update("a", "b", make_games([[7, 3]], [-1]))
    finished.update("a", "b", make_games([[21, 3]], [0]))
    assert by_score == finished  # a leader of a stopped game counts as its winner
    draw = Ratings()
    draw.update("a", "b", make_games([[4, 4]], [-1]))
    assert draw.mu("a") == draw.mu("b") == 25.0
    assert draw.sigma("a") < 25.0 / 3.0  # a draw is evidence too
    nothing = Ratings()
    nothing.update("a", "b", make_games([[0, 0]], [-1]))
    assert nothing.players == {}  # stopped before any point: no evidence, no entry


def test_games_are_rated_in_order_and_reproducibly():
    g = make_games([[21, 19], [15, 21], [21, 17], [9, 9], [21, 2]], [0, 1, 0, -1, 0])
    runs = []
    for _ in range(2):
        r = Ratings()
        r.update("a", "b", g)
        r.update("b", "c", g)
        runs.append(r.to_json())
    assert runs[0] == runs[1]  # identical floats, not approximately
    one_by_one = Ratings()
    for outcome in game_outcomes(g):
        one_by_one.rate("a", "b", int(outcome))
    first = Ratings()
    first.update("a", "b", g)
    assert one_by_one == first


def test_json_round_trip_is_exact_and_resumes_identically():
    r = Ratings()
    r.update("a", "b", make_games([[21, 19], [15, 21], [21, 17]], [0, 1, 0]))
    r.update("c", "a", make_games([[3, 21], [21, 23]], [1, 1]))
    text = json.dumps(r.to_json())
    back = Ratings.from_json(json.loads(text))
    assert back == r and back.to_json() == r.to_json()
    assert all(back.get(n) == r.get(n) for n in "abc")
    more = make_games([[21, 11]], [0])
    r.update("b", "c", more)
    back.update("b", "c", more)  # a resumed run goes on with exactly the same numbers
    assert back == r
    assert json.loads(text)["parameters"] == DEFAULTS


@pytest.mark.parametrize("doc, word", [
    ([], "model"), ({"model": "Elo"}, "model"),
    ({"model": "PlackettLuce", "parameters": DEFAULTS}, "players"),
    ({"model": "PlackettLuce", "parameters": DEFAULTS, "players": {"a": {"mu": 1}}}, "players.a"),
    ({"model": "PlackettLuce", "parameters": DEFAULTS,
      "players": {"a": {"mu": "x", "sigma": 1}}}, "players.a.mu"),
    ({"model": "PlackettLuce", "parameters": {**DEFAULTS, "mu": float("nan")}, "players": {}},
     "parameters.mu"),
    ({"model": "PlackettLuce", "parameters": {"mu": 25.0}, "players": {}}, "parameters"),
])
def test_malformed_ratings_json_is_a_clear_error(doc, word):
    with pytest.raises(ValueError, match=word):
        Ratings.from_json(doc)


def test_anchors_keep_their_ratings_and_self_play_is_refused():
    r = Ratings({"ladder": (30.0, 1.5)})
    r.update("learner", "ladder", make_games([[21, 3]], [0]), fixed=["ladder"])
    assert r.get("ladder") == (30.0, 1.5)
    assert r.mu("learner") > 25.0
    with pytest.raises(ValueError, match="itself"):
        r.update("x", "x", make_games([[21, 3]], [0]))


def test_table_sorts_by_ordinal():
    r = Ratings({"low": (20.0, 1.0), "high": (30.0, 1.0), "unsure": (31.0, 8.0)})
    assert [row["name"] for row in r.table()] == ["high", "low", "unsure"]
    assert r.table(["high", "new"])[1] == {"name": "new", "mu": 25.0, "sigma": 25.0 / 3.0,
                                           "ordinal": pytest.approx(0.0, abs=1e-12)}


def test_rate_against_the_ladder_moves_the_learner_only():
    with pytest.raises(ValueError, match="no rating yet"):
        rate_against(Ratings(), "learner", agent("random"), ladder=["scripted"])
    anchored = Ratings({"scripted": (30.0, 2.0)})
    with pytest.raises(ValueError, match="ladder player"):
        rate_against(anchored, "scripted", agent("random"), ladder=["scripted"])
    lines: list[str] = []
    out = rate_against(anchored, "learner", agent("random"), ladder=["scripted"], games=2,
                       seed=1, max_decisions=800, say=lines.append)
    assert anchored.get("scripted") == (30.0, 2.0)
    lost, won = out["scripted"]["points"][1], out["scripted"]["points"][0]
    assert lost > won  # random goals lose to the scripted centre goal (~0.2 of points)
    assert anchored.mu("learner") < 25.0
    assert len(lines) == 1 and "learner vs scripted" in lines[0]
