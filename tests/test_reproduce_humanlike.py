"""`rallysim reproduce --player humanlike`: the 3-D Table VII's pipeline end to end on the
smoke budget, and its budgets' rules."""

from __future__ import annotations

import json
from dataclasses import asdict, replace

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from rallysim.cli import main
from rallysim.train import reproduce
from rallysim.train.reproduce import BUDGETS, HUMANLIKE_BUDGETS, budget_named, run_reproduce


def test_budgets_by_player():
    assert budget_named("default") is BUDGETS["default"]
    hl = budget_named("default", "humanlike")
    assert hl.player == "humanlike" and hl.low_decisions == 0  # the clone is the low level
    assert hl.overrides("low")["player"] == "humanlike"
    assert "goals" not in hl.overrides("low")  # (a SIMPLE task setting)
    quick = budget_named("quick", "humanlike").overrides("low")
    assert quick["warm_start.dagger"] == 0 and quick["warm_start.rally_dagger"] == 4
    with pytest.raises(ValueError, match="no budget 'scratch'; valid: 'default'"):
        budget_named("scratch", "humanlike")
    with pytest.raises(ValueError, match="unknown player"):
        budget_named("default", "robot")
    # a SIMPLE budget without low-stage options stores what runs before HUMAN-LIKE budgets
    # wrote, so that their evaluations on disk are taken again; one with options stores them,
    # so that a run of another recipe is not
    for b in BUDGETS.values():
        old = {k: v for k, v in asdict(b).items() if k not in ("player", "low_extra")}
        if b.low_extra:
            old |= {"player": "simple", "low_extra": [list(x) for x in b.low_extra]}
        assert b.settings() == old
    assert BUDGETS["default"].overrides("low")["incoming"] == "mixed"
    assert "incoming" not in BUDGETS["scratch"].overrides("low")  # the paper's task
    assert HUMANLIKE_BUDGETS["smoke"].settings()["low_extra"][0] == ["warm_start.decisions",
                                                                      8192]


def test_the_command_refuses_a_simple_only_budget(capsys):
    assert main(["reproduce", "--player", "humanlike", "--budget", "scratch"]) == 2
    assert "no budget 'scratch'" in capsys.readouterr().err


@pytest.mark.slow  # trains 6 small policies (about 30 s)
def test_humanlike_reproduce_end_to_end(tmp_path):
    out = tmp_path / "hl"
    smoke = HUMANLIKE_BUDGETS["smoke"]
    results = run_reproduce(smoke, out, workers=1)
    assert results["player"] == "humanlike" and results["paper"] is None
    for name in ("report.md", "results.json", "learning_curves.png", "survival.png"):
        assert (out / name).stat().st_size > 200
    for method, lengths in results["per_seed"]["0"]["lengths"].items():
        assert len(lengths) == smoke.rallies and 0 <= min(lengths) <= max(lengths) <= 50, method
    # each stage trained the HUMAN-LIKE player's policy
    env_ids = {stage: json.loads((out / "runs" / f"{stage}_seed0" / "policy.json").read_text()
                                 )["env_id"] for stage in ("low", "high", "mono")}
    assert env_ids["low"] == "RallySim/HumanLikeReturn-v0"
    assert env_ids["high"] == "RallySim/HumanLikeRallyTurn-v0"
    assert env_ids["mono"] == "rallysim.envs.humanlike_rally_v0:HumanLikeRallyVectorEnv"
    # Monolithic got the hierarchy's budget: the teacher's labelled decisions and two
    # player-decisions per rally decision of the high stage
    train = results["training"]["0"]
    cloned = train["low"]["warm_start"]["samples"]
    assert cloned > 0 and train["low"]["steps"] == 0
    # the clone's one round inside the rally: 2,048 decisions labelled, counted in the budget
    rounds = train["low"]["warm_start"]["rounds"]
    assert [r["round"] for r in rounds] == [0, 1]
    assert rounds[1]["labelled_decisions"] - rounds[0]["labelled_decisions"] == 2048
    assert train["mono"]["steps"] >= cloned + 2 * train["high"]["decisions_simulated"]
    low = results["low_level"]
    assert set(low) >= {"mean_angle_error", "mean_abs_speed_error", "hit_rate"}
    assert "every_seed_hrl_mean_at_least_45" in results["checks"]
    report = (out / "report.md").read_text()
    assert report.startswith("# RallySim's Table VII for the HUMAN-LIKE players")
    assert "paper: mean" not in report and "mean angle error" in report
    # a rerun trains and plays nothing again, and gives the same numbers
    again = run_reproduce(smoke, out, workers=1)
    assert json.dumps(again["per_seed"]) == json.dumps(results["per_seed"])  # (NaN too)
    assert reproduce.stored_evaluation(out, 0, smoke, 50) is not None
    assert reproduce.stored_evaluation(out, 0, replace(smoke, rallies=9), 50) is None
    assert np.isfinite(results["methods"]["HRL"]["mean"]["value"])
