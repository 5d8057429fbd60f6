"""`rallysim reproduce` and `rallysim evaluate` end to end on the smoke budget."""

from __future__ import annotations

import json

import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from rallysim.cli import main
from rallysim.train.reproduce import BUDGETS, run_reproduce

pytestmark = pytest.mark.slow  # every test reads the smoke reproduction (it trains 6 policies)


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
    # the CPU and numeric settings beside the table (the tests run pinned: tests/conftest.py)
    from rallysim.numerics import PINNED, cpu_model, pinned_here

    n = results["numerics"]
    assert n["cpu"] == cpu_model() and n["pinned"] == pinned_here()
    if pinned_here():
        assert n["environment"].items() >= PINNED.items() and "; pinned (" in report
    assert f"Numerics: CPU {cpu_model()} (" in report
    train = results["training"]["0"]
    # the Monolithic baseline got the hierarchy's budget in player-decisions
    assert train["mono"]["steps"] >= train["low"]["steps"] + 2 * train["high"][
        "decisions_simulated"]
    # how much each high level still climbed in its last third, and the check on it
    from rallysim.train.reproduce import CLIMB_TOLERANCE, last_climb

    climbs = results["high_last_climb"]
    assert set(climbs) == {"0", "1"}
    assert results["checks"]["no_high_level_still_climbing"] == all(
        c is None or c <= CLIMB_TOLERANCE * 50 for c in climbs.values())
    for seed, climb in climbs.items():  # None: the smoke high level's single evaluation
        assert climb == last_climb(json.loads((out / "runs" / f"high_seed{seed}" /
                                               "curve.json").read_text()))
    assert last_climb({"evals": [{"mean_rally": 30.0}, {"mean_rally": 38.5}]}) == 8.5
    assert last_climb({"evals": [{"mean_rally": 30.0}]}) is None
    again = run_reproduce(BUDGETS["smoke"], out, workers=1)  # everything trained: reused
    for seed, stages in results["training"].items():
        for stage, numbers in stages.items():
            assert again["training"][seed][stage]["steps"] == numbers["steps"]
    assert again["wall_s"]["training"] < 5


def test_each_seeds_evaluation_is_kept_and_taken_again(smoke_run, tmp_path, monkeypatch):
    """Every seed's evaluation is on disk as soon as it is played; a rerun reads it back
    rather than playing it, and a bad value in it is refused naming the seed and the method,
    leaving the evaluations where they were."""
    import shutil

    from rallysim.train import reproduce

    out, results = smoke_run
    from rallysim.policies.mlp import sha256_file

    for seed in (0, 1):
        doc = json.loads(reproduce.evaluation_path(out, seed, 50).read_text())
        settings = doc["settings"]
        assert settings["cap"] == 50 and settings["budget"]["rallies"] == 8
        assert settings["policies"]["high"] == sha256_file(
            out / "runs" / f"high_seed{seed}" / "policy.safetensors")
        assert doc["result"] == results["per_seed"][str(seed)]
    work = tmp_path / "copy"
    shutil.copytree(out, work)

    def refuse(*args, **kwargs):
        raise AssertionError("an evaluation on disk was played again")

    monkeypatch.setattr(reproduce, "evaluate_seed", refuse)
    again = run_reproduce(BUDGETS["smoke"], work, workers=1)
    assert again["per_seed"] == results["per_seed"]
    path = reproduce.evaluation_path(work, 1, 50)
    doc = json.loads(path.read_text())
    doc["result"]["lengths"]["Random High-level"][3] = 54
    path.write_text(json.dumps(doc))
    with pytest.raises(ValueError, match=r"seed 1, Random High-level: .*\[0, 50\], got \d+ "
                                         r"to 54 \(kept in .*seed1_cap50\.json; delete it"):
        run_reproduce(BUDGETS["smoke"], work, workers=1)
    assert reproduce.evaluation_path(work, 0, 50).is_file() and path.is_file()
    # other settings (more rallies, another warm start), a policy trained again or another
    # numeric setting play the evaluation again
    from dataclasses import replace

    smoke = BUDGETS["smoke"]
    assert reproduce.stored_evaluation(work, 0, smoke, 50) is not None
    assert reproduce.stored_evaluation(work, 0, replace(smoke, rallies=9), 50) is None
    assert reproduce.stored_evaluation(work, 0, replace(smoke, warm_start="scripted"), 50) is None
    monkeypatch.setenv("OMP_NUM_THREADS", "7")
    assert reproduce.stored_evaluation(work, 0, smoke, 50) is None
    monkeypatch.undo()
    weights = work / "runs" / "mono_seed0" / "policy.safetensors"
    weights.write_bytes(weights.read_bytes()[:-1] + b"\0")
    assert reproduce.stored_evaluation(work, 0, smoke, 50) is None


def _weight_hashes(out) -> dict[str, str]:
    from rallysim.policies.mlp import sha256_file

    return {p.parent.name: sha256_file(p) for p in sorted(out.glob("runs/*/policy.safetensors"))}


def test_training_is_deterministic_per_seed(smoke_run, tmp_path):
    """Same seeds and budget on the same machine: bit-identical weights and the same table,
    whether the seeds train one after another (the fixture) or in two worker processes."""
    out, results = smoke_run
    again = run_reproduce(BUDGETS["smoke"], tmp_path, workers=2)
    first, second = _weight_hashes(out), _weight_hashes(tmp_path)
    assert len(first) == 6  # low, high, mono x 2 seeds
    assert first == second
    for method, summary in results["methods"].items():
        assert again["methods"][method]["mean"] == summary["mean"]
    assert again["per_seed"] == results["per_seed"]


def test_cap_lets_only_hits_end_a_rally(smoke_run, tmp_path):
    """A reproduction re-evaluated at another cap keeps its training and writes its own files;
    a scripted hierarchy rallies past 50 hits once the cap allows it."""
    from dataclasses import replace

    import numpy as np

    from rallysim.eval.rally_eval import rally_lengths_turns, rules_for_cap

    out, _ = smoke_run
    results = run_reproduce(BUDGETS["smoke"], out, workers=1, cap=120)
    assert results["cap"] == 120 and (out / "results_cap120.json").is_file()
    assert (out / "report_cap120.md").read_text().count("reaching 120") == 2
    assert json.loads((out / "results.json").read_text())["cap"] == 50  # untouched
    assert len(results["methods"]["HRL"]["survival"]) == 121
    # scripted rallies take about 15 decisions a hit: 400 hits outlast the old 5,000-decision
    # guard, which cut such rallies; the cap's own guard cuts nothing
    goals = lambda obs: np.full(len(obs), 3.5)  # noqa: E731
    lengths = rally_lengths_turns(goals, "scripted", 4, 5, rules_for_cap(400))
    assert (lengths == 400).all()
    with pytest.raises(RuntimeError, match="decision limit"):
        rally_lengths_turns(goals, "scripted", 4, 5, replace(rules_for_cap(400),
                                                             max_decisions=5000))
    with pytest.raises(ValueError, match="cap"):
        rules_for_cap(0)
    with pytest.raises(ValueError, match="cap"):
        run_reproduce(BUDGETS["smoke"], out, cap=10**6)


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
