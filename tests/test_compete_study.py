"""The competitive study (``rallysim.train.compete_study``) on a tiny budget: one seed's
champion, games, ratings and best response, the pooled report, and its rendered tables; and
docs/competitive.md's generated tables match the committed JSON."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from rallysim.train import compete_study as study
from rallysim.train.results_doc import regenerate

ROOT = Path(__file__).resolve().parents[1]
TINY = {"ppo.n_envs": 8, "ppo.n_steps": 64, "ppo.batch_size": 256, "ppo.n_epochs": 1,
        "checkpoint_every": 512, "eval.every": 0, "eval.episodes": 1,
        "league.snapshot_every": 512, "league.rating_games": 1, "league.ladder": "scripted"}


def test_pooled_rate_is_points_won_over_points_played():
    seeds = [{"won": [3, 5], "points": [10, 10]}, {"won": [8], "points": [10]}]
    r = study.pooled_rate(seeds, n_boot=500)
    assert r["value"] == pytest.approx(16 / 30)
    assert r["low"] <= r["value"] <= r["high"]
    # one seed of identical games: no spread at all
    assert study.pooled_rate([{"won": [4, 4], "points": [8, 8]}], n_boot=50) == {
        "value": 0.5, "low": 0.5, "high": 0.5}


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

    monkeypatch.setattr(study, "_checks", lambda seeds, pooled: {"ran": True})
    monkeypatch.setattr("rallysim.eval.crossplay.crossplay", lambda names, *a, **k: {
        "players": names, "games": 1,
        "point_win_rate": [[None if i == j else {"value": 0.5, "low": 0.4, "high": 0.6}
                            for j in range(len(names))] for i in range(len(names))]})
    result = study.report(tmp_path, games=2, max_decisions=1500)
    assert result["pooled"]["champion_vs_scripted"]["value"] == pytest.approx(
        sum(per_game["won"]) / sum(per_game["points"]))
    text = study.render(result)
    assert f"{result['pooled']['best_response']['value']:.3f}" in text
    assert "champion (seed 0)" in text
    assert np.isfinite(result["seeds"][0]["vs_scripted"]["value"])


def test_the_docs_tables_match_the_committed_study():
    doc = (ROOT / "docs" / "competitive.md").read_text()
    assert "<!-- BEGIN GENERATED: compete_study -->" in doc
    assert regenerate(doc, ROOT / "docs" / "data") == doc, (
        "run: python -m rallysim.train.results_doc --doc docs/competitive.md")
