"""The learning curves of RL alone beside the cloned path (docs/rl-alone.md): pooled from each
seed's low-stage curve."""

from __future__ import annotations

import json

import pytest

from experiments.low_curves_study import collect, main, render, seed_points
from rallysim.train.reproduce import BUDGETS


def _curve(seed: int, cloned: bool) -> dict:
    evals = [{"steps": s, "mean_reward": 1.0 + 0.1 * k + 0.01 * seed, "hit_rate": 0.9,
              "median_error": 1.0 - 0.1 * k, "goal_correlation": None if k == 0 else 0.5 + seed
              * 0.1} for k, s in enumerate((1000, 2000))]
    out = {"evals": evals}
    if cloned:
        out["warm_start"] = {"samples": 500.0}
    return out


def _write(root, seeds=3):
    for method in ("cloned", "rl"):
        for s in range(seeds):
            run = root / method / "runs" / f"low_seed{s}"
            run.mkdir(parents=True)
            (run / "curve.json").write_text(json.dumps(_curve(s, method == "cloned")))


def test_points_count_the_cloned_decisions_first():
    points = seed_points(_curve(0, True))
    assert [p["decisions"] for p in points] == [1500, 2500]
    assert [p["decisions"] for p in seed_points(_curve(0, False))] == [1000, 2000]


def test_collect_pools_seeds_point_by_point(tmp_path):
    _write(tmp_path)
    doc = collect(tmp_path, 3)
    methods = doc["methods"]
    assert methods["cloned"]["budget"] == "default" and methods["rl"]["budget"] == "rl"
    last = doc["methods"]["rl"]["pooled"][-1]
    assert last["mean_reward"]["value"] == pytest.approx(1.11)
    assert last["goal_correlation"]["value"] == pytest.approx(0.6)
    assert last["goal_correlation"]["low"] <= 0.6 <= last["goal_correlation"]["high"]
    assert doc["methods"]["rl"]["pooled"][0]["goal_correlation"] is None  # undefined on a seed
    table = render(doc)
    assert "| RL alone (--budget rl) | 0.00 | 1.010 [" in table and "—" in table
    assert "| cloned, then PPO (default) | 2 | 1.120 | 0.90 | 0.700 | 0.900 |" in table


def test_report_writes_json_and_figure(tmp_path, capsys):
    _write(tmp_path)
    assert main(["report", "--out", str(tmp_path)]) == 0
    assert json.loads((tmp_path / "low_curves.json").read_text())["kind"] == "low_curves"
    assert (tmp_path / "low_curves.png").stat().st_size > 10_000
    (tmp_path / "rl" / "runs" / "low_seed2" / "curve.json").unlink()
    with pytest.raises(FileNotFoundError, match="seed --method rl --seed 2"):
        main(["report", "--out", str(tmp_path)])


def test_methods_train_as_their_reproduce_budgets():
    assert BUDGETS["default"].overrides("low")["warm_start.teacher"] == "scripted"
    rl = BUDGETS["rl"].overrides("low")
    assert rl["warm_start.teacher"] == "none" and rl["goals"] == "reachable"
