"""Progress lines when output is not a terminal: at least one per interval, with the stage,
seed, phase, steps done, rate and ETA."""

from __future__ import annotations

import time

import pytest

from rallysim.train import progress
from rallysim.train.progress import Heartbeat, format_eta


def test_heartbeat_reports_steps_rate_and_eta():
    lines: list[str] = []
    with Heartbeat("[low seed 2]", 1000, lines.append, every=0.05) as beat:
        beat.set_phase("PPO")
        beat.update(250)
        time.sleep(0.3)
    assert len(lines) >= 3  # about one per 0.05 s
    last = lines[-1]
    assert last.startswith("[low seed 2] PPO: 250/1,000 steps, ")
    rate = float(last.split("steps, ")[1].split("/s")[0].replace(",", ""))
    assert 250 / 0.5 < rate < 250 / 0.05  # 250 steps over the 0.05-0.5 s since the phase began
    assert "ETA 0:0" in last  # 750 steps to go at that rate: seconds
    with pytest.raises(ValueError):
        Heartbeat("x", 1, every=0)


def test_eta_format():
    assert format_eta(float("nan")) == "?"
    assert format_eta(75) == "1:15"
    assert format_eta(3 * 3600 + 62) == "3:01:02"


@pytest.mark.slow  # trains
def test_training_without_a_terminal_prints_progress_lines(tmp_path, monkeypatch):
    pytest.importorskip("stable_baselines3")
    from rallysim.train.config import load_config
    from rallysim.train.runner import train_stage

    monkeypatch.setattr(progress, "HEARTBEAT_S", 0.2)
    config = load_config("low", None, {"seed": 5, "ppo.n_envs": 32, "ppo.n_steps": 16,
                                       "ppo.batch_size": 256, "budget": 16384,
                                       "eval.every": 0, "eval.episodes": 16,
                                       "checkpoint_every": 10**6})
    lines: list[str] = []
    train_stage(config, tmp_path, progress=False, say=lines.append)
    beats = [line for line in lines if line.startswith("[low seed 5] PPO: ")]
    assert beats, lines
    done = [int(b.split(": ")[1].split("/")[0].replace(",", "")) for b in beats]
    assert done == sorted(done) and all(d <= 16384 for d in done)
    assert all("/s, ETA " in b for b in beats)
    assert all(" decisions, " in b for b in beats)  # counted in the stage's budget unit


@pytest.mark.slow  # trains
def test_the_warm_start_counts_its_epochs_then_ppo_its_decisions(tmp_path, monkeypatch):
    pytest.importorskip("stable_baselines3")
    from rallysim.train.config import load_config
    from rallysim.train.runner import train_stage

    monkeypatch.setattr(progress, "HEARTBEAT_S", 0.05)
    config = load_config("low", None, {"seed": 5, "warm_start.teacher": "scripted",
                                       "warm_start.decisions": 8192, "warm_start.epochs": 8,
                                       "warm_start.batch_size": 256, "ppo.n_envs": 32,
                                       "ppo.n_steps": 16, "ppo.batch_size": 256,
                                       "budget": 4096, "eval.every": 0, "eval.episodes": 16,
                                       "checkpoint_every": 10**6})
    lines: list[str] = []
    train_stage(config, tmp_path, progress=False, say=lines.append)
    warm = [line for line in lines if line.startswith("[low seed 5] warm start ")]
    fitted = [int(w.split(": ")[1].split("/")[0]) for w in warm]
    assert all("/8 epochs, " in w for w in warm) and fitted == sorted(fitted), warm
    assert fitted[-1] >= 4  # the count moves while the clone is fitted
    ppo = [line for line in lines if line.startswith("[low seed 5] PPO: ")]
    assert all("/4,096 decisions, " in line for line in ppo)


@pytest.mark.slow  # trains
@pytest.mark.parametrize("tty", [False, True])
def test_progress_lines_only_without_a_terminal(tmp_path, monkeypatch, capsys, tty):
    """``train`` (progress on): a bar on a terminal; heartbeat lines on stderr otherwise."""
    pytest.importorskip("stable_baselines3")
    import sys

    from rallysim.train.config import load_config
    from rallysim.train.runner import train_stage

    monkeypatch.setattr(progress, "HEARTBEAT_S", 0.2)
    monkeypatch.setattr(sys.stderr, "isatty", lambda: tty)
    config = load_config("low", None, {"seed": 6, "ppo.n_envs": 32, "ppo.n_steps": 16,
                                       "ppo.batch_size": 256, "budget": 16384,
                                       "eval.every": 0, "eval.episodes": 16,
                                       "checkpoint_every": 10**6})
    train_stage(config, tmp_path, progress=True)
    err = capsys.readouterr().err
    assert ("[low seed 6] PPO: " in err) is not tty
