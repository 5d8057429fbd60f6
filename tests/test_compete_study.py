"""The competitive study (``experiments/compete_study.py``) on a tiny budget: one seed's
champion, games, ratings and best response, the pooled report, and its rendered tables; and
docs/competitive.md's generated tables match the committed JSON."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from experiments import compete_study as study
from rallysim.train.results_doc import regenerate

ROOT = Path(__file__).resolve().parents[1]
TINY = {"ppo.n_envs": 8, "ppo.n_steps": 64, "ppo.batch_size": 256, "ppo.n_epochs": 1,
        "checkpoint_every": 512, "eval.every": 0, "eval.episodes": 1,
        "league.snapshot_every": 512, "league.rating_games": 1, "league.ladder": "scripted",
        "league.rating_decisions": 1500}  # (the default 5,000 took most of the time)


def test_pooled_rate_is_points_won_over_points_played():
    seeds = [{"won": [3, 5], "points": [10, 10]}, {"won": [8], "points": [10]}]
    r = study.pooled_rate(seeds, n_boot=500)
    assert r["value"] == pytest.approx(16 / 30)
    assert r["low"] <= r["value"] <= r["high"]
    # one seed of identical games: no spread at all
    assert study.pooled_rate([{"won": [4, 4], "points": [8, 8]}], n_boot=50) == {
        "value": 0.5, "low": 0.5, "high": 0.5}


@pytest.mark.slow  # trains
def test_a_tiny_study(tmp_path, monkeypatch):
    monkeypatch.setattr(study, "OPPONENTS", ("scripted",))
    path = study.run_seed(0, tmp_path, budget=512, br_budget=512, games=2,
                          max_decisions=1500, overrides=TINY)
    doc = json.loads(path.read_text())
    assert [r["turns"] for r in doc["ratings"]] == [0, 512]
    per_game = doc["versus"]["scripted"]["per_game"]
    assert len(per_game["won"]) == 2
    assert doc["versus"]["scripted"]["points_won"] == sum(per_game["won"])
    assert (tmp_path / "best_response_seed0" / "policy.json").is_file()
    # the best response trained against the champion alone: no pool of its own
    assert not list((tmp_path / "best_response_seed0").glob("pool/*.json"))

    # the summary: the seed's games pooled and its ratings as logged, no game played
    light = study.summary(tmp_path)
    assert light["kind"] == "compete_summary" and light["player"] == "simple"
    assert light["pooled"]["scripted"]["value"] == pytest.approx(
        sum(per_game["won"]) / sum(per_game["points"]))
    assert light["seeds"][0]["ratings"] == doc["ratings"]
    assert [r["name"] for r in light["ladder"]] == ["scripted"]  # TINY's one-rung ladder
    assert json.loads((tmp_path / "compete_summary.json").read_text()) == light
    text = study.render_summary(light)
    assert "`simple` player" in text and "best response 512 turns" in text
    assert f"{light['seeds'][0]['vs_scripted']['value']:.3f}" in text
    # a seed of another study is refused, not pooled
    other = tmp_path / "seed9.json"
    other.write_text(json.dumps({**doc, "seed": 9, "budget": 1024}))
    with pytest.raises(ValueError, match="differ in budget"):
        study.summary(tmp_path)
    other.unlink()

    # the report: a two-rung ladder calibrated, then the seed's snapshots and champion rated
    # against it and played against each other, in one cross-play matrix
    monkeypatch.setattr("rallysim.eval.ratings.REFERENCE_LADDER", ("mono", "scripted"))
    monkeypatch.setattr(study, "_checks", lambda seeds, pooled, rows: {"ran": True})
    result = study.report(tmp_path, games=2, max_decisions=1500, figures=tmp_path / "fig",
                          crossplay_games=1)
    assert result["pooled"]["champion_vs_scripted"]["value"] == pytest.approx(
        sum(per_game["won"]) / sum(per_game["points"]))
    snaps = [str(tmp_path / "league_seed0" / "pool" / f"snapshot_{t:012d}") for t in (0, 512)]
    champion = str(tmp_path / "league_seed0" / "policy")
    cp = result["crossplay"]
    assert cp["players"] == ["mono", "scripted", *snaps, champion]
    n = len(cp["players"])
    # one seed: every pair played (a cell is null only where its game ended no point: players
    # over the shipped low level can rally through a short game)
    assert len(cp["pairs"]) == n * (n - 1) // 2
    for p in cp["pairs"]:
        i, j = cp["players"].index(p["a"]), cp["players"].index(p["b"])
        assert (cp["point_win_rate"][i][j] is None) == (p["points"] == 0)
    ladder = result["ladder"]
    assert set(ladder["players"]) == {"mono", "scripted"}
    assert ladder["players"]["scripted"]["mu"] > ladder["players"]["mono"]["mu"]
    assert json.loads((tmp_path / "ladder_ratings.json").read_text()) == ladder
    # the snapshots were rated against the ladder held fixed; their ratings are the matrix's
    row = result["seeds"][0]
    assert [r["turns"] for r in row["ratings"]] == [0, 512]
    for name in ("mono", "scripted"):
        assert cp["ratings"]["players"][name] == ladder["players"][name]
    for r, m in zip(row["ratings"], row["snapshots"], strict=True):
        mu, sigma = cp["ratings"]["players"][m["name"]].values()
        assert r["rating"] == pytest.approx(mu - 3 * sigma)
        assert set(m["versus"]) == {"mono", "scripted"}
    assert row["ratings_monotonic"] == (row["ratings"][1]["rating"] >= row["ratings"][0]["rating"])
    assert row["ratings_training"] == doc["ratings"]  # as the league logged them
    assert (tmp_path / "fig" / "compete_crossplay_seed0.png").stat().st_size > 10_000
    text = study.render(result)
    assert f"{result['pooled']['best_response']['value']:.3f}" in text
    assert "champion s0" in text and f"{row['ratings'][1]['rating']:.2f}" in text
    assert np.isfinite(result["seeds"][0]["vs_scripted"]["value"])

    # drawn again, the report replays no game (they are kept) and gives the same numbers
    def no_games(*args, **kwargs):
        raise AssertionError("a game was played again")

    monkeypatch.setattr("rallysim.eval.crossplay.play_games", no_games)
    monkeypatch.setattr("rallysim.eval.ratings.play_games", no_games)
    again = study.report(tmp_path, games=2, max_decisions=1500, crossplay_games=1)
    assert again["seeds"] == result["seeds"] and again["ladder"] == ladder
    assert {**again["crossplay"], "wall_s": 0} == {**cp, "wall_s": 0}


@pytest.mark.slow  # trains
def test_a_seed_without_best_response_is_summarised_not_reported(tmp_path, monkeypatch):
    monkeypatch.setattr(study, "OPPONENTS", ("scripted",))
    doc = json.loads(study.run_seed(0, tmp_path, budget=512, br_budget=0, games=1,
                                    max_decisions=600, overrides=TINY).read_text())
    assert doc["best_response"] is None and doc["player"] == "simple"
    assert not (tmp_path / "best_response_seed0").exists()
    with pytest.raises(ValueError, match="no best response"):
        study.report(tmp_path, games=1)
    light = study.summary(tmp_path)
    assert light["settings"]["br_budget"] == 0
    assert "no best response" in study.render_summary(light)


def test_the_docs_tables_match_the_committed_study():
    doc = (ROOT / "docs" / "competitive.md").read_text()
    assert "<!-- BEGIN GENERATED: compete_study -->" in doc
    assert regenerate(doc, ROOT / "docs" / "data") == doc, (
        "run: python -m rallysim.train.results_doc --doc docs/competitive.md")


def test_the_committed_study_rates_every_snapshot_against_the_calibrated_ladder():
    import itertools

    result = json.loads((ROOT / "docs" / "data" / "compete_study.json").read_text())
    ladder = result["ladder"]
    # calibrated, not the defaults: the deep fixed goal on top, the cooperative Monolithic last
    assert [r["name"] for r in ladder["table"]] == ["fixed:6", "random", "hrl", "scripted",
                                                     "mono"]
    assert all(p["sigma"] < 1.5 for p in ladder["players"].values())
    assert json.loads((ROOT / "docs" / "data" / "ladder_ratings.json").read_text()) == ladder
    cp = result["crossplay"]
    for name, rating in ladder["players"].items():  # held fixed while the snapshots were rated
        assert cp["ratings"]["players"][name] == rating
    for s in result["seeds"]:
        members = [m["name"] for m in s["snapshots"]] + [s["champion"]]
        assert len(s["snapshots"]) >= 5 and set(members) <= set(cp["players"])
        for m in members:  # every snapshot played every rung in the matrix
            i = cp["players"].index(m)
            assert all(cp["point_win_rate"][i][cp["players"].index(r)] for r in ladder["players"])
        values = [r["rating"] for r in s["ratings"]]
        assert s["ratings_monotonic"] == all(b >= a for a, b in itertools.pairwise(values))
        assert values[-1] > values[0] + 5.0  # no saturation: trained beats untrained by far
    assert result["checks"]["ratings_monotonic_in_2_of_3"] == (
        sum(s["ratings_monotonic"] for s in result["seeds"]) >= 2)
