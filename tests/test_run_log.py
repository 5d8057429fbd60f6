"""The run record both backends keep (``rallysim.train.run_log.RunLog``): the evaluation and
checkpoint schedule in the stage's budget unit, a resumed run's continuation, the evaluation
rows and lines, ``curve.json`` as the mark of a finished run, the exported policy's metadata."""

from __future__ import annotations

import json

import numpy as np
import pytest

pytest.importorskip("yaml")

from rallysim.train.config import load_config
from rallysim.train.run_log import RunLog, finished


def test_schedule_is_in_budget_units_and_a_resumed_run_continues_it(tmp_path):
    config = load_config("high", None, {"eval.every": 1000, "checkpoint_every": 400})
    log = RunLog(config, tmp_path, "rollouts")
    log.start_clock()
    updates = range(300, 3001, 300)  # one check per update of 300 turns
    assert [d for d in updates if log.eval_due(d)] == [1200, 2100, 3000]
    log.start_clock()
    assert [d for d in updates if log.checkpoint_due(d)] == [600, 900, 1200, 1800, 2100, 2400,
                                                            3000]
    # resumed at 1,500 turns with 12.5 s of training behind it
    log.adopt({"stage": "high", "decisions": 1500, "train_wall_s": 12.5})
    log.start_clock()
    assert (log.next_eval, log.next_ckpt) == (2000, 1600)
    assert 12.5 <= log.train_wall() < 14.0
    assert log.curve["evals"] == [] and log.curve["rollouts"] == []
    # no evaluations in between (eval.every 0): only the final one
    quiet = RunLog(load_config("high", None, {"eval.every": 0}), tmp_path, "iterations")
    quiet.start_clock()
    assert not any(quiet.eval_due(d) for d in range(0, 10**6, 50_000))


def test_evaluations_final_record_and_metadata(tmp_path):
    config = load_config("low", None, {"eval.episodes": 8, "seed": 4})
    lines: list[str] = []
    log = RunLog(config, tmp_path, "rollouts", say=lines.append)
    log.start_clock()
    log.write_config()
    still = lambda obs: np.zeros((len(obs), 3), np.float32)  # noqa: E731
    row = log.evaluate(512, still)
    # a racket held still meets one of the 8 serves the evaluation seed draws
    assert (row["steps"], row["episodes"], row["hit_rate"]) == (512, 8, 0.125)
    assert lines == [f"[low seed 4]        512 decisions: reward {row['mean_reward']:.3f} "
                     f"hit 0.125 err {row['median_error']:.2f} m"]
    assert log.evaluation_at(512) is row and log.evaluation_at(1024) is None
    log.record_update({"steps": 512, "wall_s": 0.1, "ep_rew_mean": 0.0})
    curve = log.finish(row, 512, decisions_simulated=512)
    assert (curve["steps"], curve["final"], curve["decisions_simulated"]) == (512, row, 512)
    assert finished(tmp_path, 512) is None  # not written yet
    log.write_curve()
    assert finished(tmp_path, 512)["rollouts"] == curve["rollouts"]
    assert finished(tmp_path, 513) is None  # a larger budget: not finished
    meta = log.policy_metadata(512, row, {"backend": "test"})
    assert (meta["stage"], meta["player"], meta["budget_unit"], meta["backend"]) == (
        "low", "simple", "decisions", "test")
    assert meta["config"]["eval"]["episodes"] == 8
    written = (tmp_path / "config.yaml").read_text()
    assert "budget_unit: decisions" in written and load_config("low", tmp_path / "config.yaml"
                                                               ) == config
    assert json.loads((tmp_path / "curve.json").read_text())["stage"] == "low"
