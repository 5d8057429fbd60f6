"""OpenSkill ratings of competitive games (rallysim.eval.ratings): direction of updates,
points as matches (no saturation) and games by score, determinism, exact JSON round trip, the
ladder calibrated first and then held fixed."""

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
    REFERENCE_LADDER,
    Ratings,
    calibrate,
    game_outcomes,
    point_outcomes,
    rate_against,
    rate_points,
)


def make_games(points: list[list[int]], winner: list[int]) -> Games:
    """Games as ``play_games`` returns them; each game's points in a row (a's, then b's),
    the games one after another."""
    n = len(points)
    a_won = [won for a, b in points for won in [True] * a + [False] * b]
    game = [g for g, (a, b) in enumerate(points) for _ in range(a + b)]
    return Games(points=np.array(points, np.int64).reshape(n, 2), winner=np.array(winner),
                 decisions=np.ones(n, np.int64), lets=np.zeros(n, np.int64),
                 point_game=np.array(game, np.int64), point_hits=np.ones(len(game), np.int64),
                 point_a_won=np.array(a_won, bool))


def test_unseen_players_have_the_defaults_and_ordinal_is_mu_minus_three_sigma():
    r = Ratings()
    assert r.get("anyone") == (25.0, 25.0 / 3.0)
    assert r.ordinal("anyone") == pytest.approx(0.0, abs=1e-12)
    r = Ratings({"x": (30.0, 2.0)})
    assert r.ordinal("x") == 24.0
    assert "x" in r and "y" not in r


def test_winner_rises_loser_falls_and_both_become_surer():
    r = Ratings()
    r.update("a", "b", make_games([[21, 10]], [0]), unit="game")
    (mu_a, s_a), (mu_b, s_b) = r.get("a"), r.get("b")
    assert mu_a > 25.0 > mu_b
    assert mu_a - 25.0 == pytest.approx(25.0 - mu_b)  # equal priors: symmetric moves
    assert s_a < 25.0 / 3.0 and s_b < 25.0 / 3.0
    r2 = Ratings()
    r2.update("a", "b", make_games([[10, 21]], [1]), unit="game")
    assert r2.mu("b") == mu_a and r2.mu("a") == mu_b  # b winning mirrors a winning


def test_more_wins_move_further():
    one, three = Ratings(), Ratings()
    one.update("a", "b", make_games([[21, 3]], [0]), unit="game")
    three.update("a", "b", make_games([[21, 3]] * 3, [0, 0, 0]), unit="game")
    assert three.mu("a") > one.mu("a") > 25.0
    assert three.ordinal("a") > one.ordinal("a")


def test_unfinished_games_count_by_score_and_draws_by_ranks():
    g = make_games([[21, 5], [7, 3], [2, 9], [4, 4], [0, 0]], [0, -1, -1, -1, -1])
    assert game_outcomes(g).tolist() == [A_WON, A_WON, B_WON, DRAW, NO_RESULT]
    by_score, finished = Ratings(), Ratings()
    by_score.update("a", "b", make_games([[7, 3]], [-1]), unit="game")
    finished.update("a", "b", make_games([[21, 3]], [0]), unit="game")
    assert by_score == finished  # a leader of a stopped game counts as its winner
    draw = Ratings()
    draw.update("a", "b", make_games([[4, 4]], [-1]), unit="game")
    assert draw.mu("a") == draw.mu("b") == 25.0
    assert draw.sigma("a") < 25.0 / 3.0  # a draw is evidence too
    nothing = Ratings()
    nothing.update("a", "b", make_games([[0, 0]], [-1]), unit="game")
    assert nothing.players == {}  # stopped before any point: no evidence, no entry
    with pytest.raises(ValueError, match="unit"):
        nothing.update("a", "b", g, unit="rally")


def test_points_are_the_matches_by_default():
    g = make_games([[3, 1]], [0])
    assert point_outcomes(g).tolist() == [A_WON, A_WON, A_WON, B_WON]
    by_points, by_hand = Ratings(), Ratings()
    by_points.update("a", "b", g)
    for outcome in (A_WON, A_WON, A_WON, B_WON):
        by_hand.rate("a", "b", outcome)
    assert by_points == by_hand
    assert by_points.mu("a") > 25.0 > by_points.mu("b")


def test_winning_every_game_does_not_saturate_points_tell_the_margins_apart():
    # two learners win all 8 games against the same fixed anchor, one 21-5, one 21-17: rated
    # by games they are equal (the old saturation), by points the wider margin rates higher
    anchor = {"anchor": (25.0, 1.0)}
    wide, narrow = make_games([[21, 5]] * 8, [0] * 8), make_games([[21, 17]] * 8, [0] * 8)
    rng = np.random.default_rng(0)
    for g in (wide, narrow):  # batched games' points come mixed, not a game's in a row
        rng.shuffle(g.point_a_won)
    by_game, by_point = Ratings(anchor), Ratings(anchor)
    for r, unit in ((by_game, "game"), (by_point, "point")):
        r.update("wide", "anchor", wide, fixed=anchor, unit=unit)
        r.update("narrow", "anchor", narrow, fixed=anchor, unit=unit)
    assert by_game.get("wide") == by_game.get("narrow")
    assert by_point.ordinal("wide") > by_point.ordinal("narrow") + 3.0
    assert by_point.mu("narrow") > 25.0  # 21-17: still better than the anchor


def test_rate_points_interleaves_the_pairings():
    g1, g2 = make_games([[2, 1]], [0]), make_games([[0, 3]], [1])
    r = Ratings({"p": (20.0, 2.0), "q": (30.0, 2.0)})
    rate_points(r, [("x", "p", g1), ("x", "q", g2)], fixed=["p", "q"])
    by_hand = Ratings({"p": (20.0, 2.0), "q": (30.0, 2.0)})
    for opponent, outcome in (("p", A_WON), ("q", B_WON), ("p", A_WON), ("q", B_WON),
                              ("p", B_WON), ("q", B_WON)):
        by_hand.rate("x", opponent, outcome, fixed=["p", "q"])
    assert r == by_hand
    assert r.get("p") == (20.0, 2.0) and r.get("q") == (30.0, 2.0)


def test_interleaving_makes_the_order_of_the_opponents_irrelevant():
    # 100 points against each of two anchors (0.85 of them won against the weak one, 0.40
    # against the strong one): rated one opponent after the other, the result depends on which
    # comes first by about a sigma; interleaved (rate_points), by a hundredth of one
    rng = np.random.default_rng(0)
    anchors = {"weak": (20.0, 0.5), "strong": (30.0, 0.5)}
    games = {n: make_games([[k, 100 - k]], [0]) for n, k in (("weak", 85), ("strong", 40))}
    for g in games.values():
        rng.shuffle(g.point_a_won)
    blocked, mixed = [], []
    for order in (("weak", "strong"), ("strong", "weak")):
        r = Ratings(anchors)
        for n in order:
            r.update("x", n, games[n], fixed=anchors)
        blocked.append(r.get("x"))
        r = Ratings(anchors)
        rate_points(r, [("x", n, games[n]) for n in order], fixed=anchors)
        mixed.append(r.get("x"))
    sigma = mixed[0][1]
    assert abs(blocked[0][0] - blocked[1][0]) > 0.8 * sigma
    assert abs(mixed[0][0] - mixed[1][0]) < 0.02 * sigma
    assert 25.0 < mixed[0][0] < 32.0  # between the anchors, nearer the strong one


def test_frozen_players_do_not_drift():
    # tau 0: a frozen policy's skill does not drift, so its uncertainty keeps shrinking with
    # every point (about 1/sqrt(points)); openskill's default tau (25/300) would hold it up
    g = make_games([[1200, 800]], [0])
    np.random.default_rng(0).shuffle(g.point_a_won)
    anchor = {"anchor": (25.0, 0.5)}
    frozen, drifting = Ratings(anchor), Ratings(anchor, {**DEFAULTS, "tau": 25.0 / 300.0})
    for r in (frozen, drifting):
        r.update("x", "anchor", g, fixed=anchor)
    assert DEFAULTS["tau"] == 0.0
    assert frozen.sigma("x") < 0.75 * drifting.sigma("x")
    assert frozen.mu("x") > 25.0


def test_games_are_rated_in_order_and_reproducibly():
    g = make_games([[21, 19], [15, 21], [21, 17], [9, 9], [21, 2]], [0, 1, 0, -1, 0])
    assert len(point_outcomes(g)) == 155
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
    first.update("a", "b", g, unit="game")
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


@pytest.fixture(scope="module")
def ladder() -> tuple[Ratings, dict]:
    # three rungs of known order (point-win rates in the competitive study's cross-play, 16
    # games: fixed:6 wins 0.93 of points against scripted and 0.96 against mono, scripted 0.91
    # against mono)
    return calibrate(["mono", "scripted", "fixed:6"], games=4, seed=1, max_decisions=1500)


@pytest.mark.slow
def test_calibration_rates_the_ladder_in_its_order(ladder):
    ratings, played = ladder
    assert list(played) == [("mono", "scripted"), ("mono", "fixed:6"), ("scripted", "fixed:6")]
    assert [row["name"] for row in ratings.table()] == ["fixed:6", "scripted", "mono"]
    assert ratings.mu("fixed:6") > ratings.mu("scripted") + 3.0 > ratings.mu("mono") + 6.0
    assert all(ratings.sigma(n) < 0.6 * DEFAULTS["sigma"] for n in ratings.players)
    assert ratings.mu("scripted") != DEFAULTS["mu"]
    again, _ = calibrate(["mono", "scripted", "fixed:6"], games=4, seed=1, max_decisions=1500,
                         played=played)  # the same games: the same floats
    assert again == ratings
    alone, none = calibrate(["scripted"])  # one rung: the defaults, stored, no game
    assert alone.players == {"scripted": (DEFAULTS["mu"], DEFAULTS["sigma"])} and none == {}
    assert "fixed:6" in REFERENCE_LADDER


@pytest.mark.slow
def test_a_stronger_player_rates_higher_against_the_fixed_ladder(ladder):
    calibrated, _ = ladder
    ratings = Ratings.from_json(calibrated.to_json())
    kw = {"games": 4, "seed": 2, "max_decisions": 1500}
    # the cooperative Monolithic policy loses most points to the scripted centre goal (measured
    # here 7 of 60); always-deep goals (fixed:6) win most against both rungs (79 of 82, 26 of 26)
    weak = rate_against(ratings, "weak", agent("mono"), ["mono", "scripted"], **kw)
    strong = rate_against(ratings, "strong", agent("fixed:6"), ["mono", "scripted"], **kw)
    assert weak["scripted"].point_win_rate < 0.5 < strong["scripted"].point_win_rate
    assert ratings.ordinal("strong") > ratings.ordinal("weak") + 5.0
    assert ratings.ordinal("strong") > ratings.ordinal("scripted")
    assert all(ratings.get(n) == calibrated.get(n) for n in calibrated.players)  # held fixed


def test_rate_against_the_ladder_moves_the_learner_only():
    with pytest.raises(ValueError, match="no rating yet"):
        rate_against(Ratings(), "learner", agent("random"), ladder=["scripted"])
    anchored = Ratings({"scripted": (30.0, 2.0)})
    with pytest.raises(ValueError, match="ladder player"):
        rate_against(anchored, "scripted", agent("random"), ladder=["scripted"])
    lines: list[str] = []
    out = rate_against(anchored, "learner", agent("mono"), ladder=["scripted"], games=2,
                       seed=1, max_decisions=800, say=lines.append)
    assert anchored.get("scripted") == (30.0, 2.0)
    won, lost = out["scripted"].points.sum(axis=0)
    assert lost > won  # the cooperative Monolithic policy loses to scripted (~0.1 of points)
    assert anchored.mu("learner") < 25.0
    assert len(lines) == 1 and "learner vs scripted" in lines[0]
