"""`rallysim reproduce` and `rallysim evaluate` end to end on the smoke budget."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from rallysim.cli import main
from rallysim.train.reproduce import BUDGETS, run_reproduce


@pytest.fixture(scope="module")
def smoke_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("repro")
    results = run_reproduce(BUDGETS["smoke"], out, workers=1)
    return out, results


def test_reproduce_writes_the_report_json_and_plots(smoke_run):
    out, results = smoke_run
    for name in ("report.md", "results.json", "learning_curves.png", "survival.png"):
        assert (out / name).stat().st_size > 200
    assert set(results["methods"]) == {"HRL", "Random High-level", "Monolithic"}
    hrl = results["methods"]["HRL"]
    assert hrl["n_rallies"] == 2 * 8 and hrl["n_seeds"] == 2
    assert hrl["mean"]["low"] <= hrl["mean"]["value"] <= hrl["mean"]["high"]
    report = (out / "report.md").read_text()
    assert "| HRL |" in report and "20.25" in report  # beside the paper's number
    train = results["training"]["0"]
    # the Monolithic baseline got the hierarchy's budget in player-decisions
    assert train["mono"]["steps"] >= train["low"]["steps"] + 2 * train["high"][
        "decisions_simulated"]
    again = run_reproduce(BUDGETS["smoke"], out, workers=1)  # everything trained: reused
    for seed, stages in results["training"].items():
        for stage, numbers in stages.items():
            assert again["training"][seed][stage]["steps"] == numbers["steps"]
    assert again["wall_s"]["training"] < 5


def test_evaluate_command_with_given_policies(smoke_run, tmp_path, capsys):
    out, _ = smoke_run
    runs = out / "runs"
    path = tmp_path / "eval.json"
    code = main(["evaluate", "--low", str(runs / "low_seed0" / "policy"), "--high",
                 str(runs / "high_seed0" / "policy"), "--mono",
                 str(runs / "mono_seed0" / "policy"), "--rallies", "4", "--seeds", "2",
                 "--json", str(path)])
    assert code == 0
    data = json.loads(path.read_text())
    assert data["methods"]["HRL"]["n_rallies"] == 8
    assert len(data["lengths"]["Monolithic"]) == 2
    assert "Random High-level" in capsys.readouterr().out
    assert main(["evaluate", "--low", str(tmp_path / "missing")]) == 2
