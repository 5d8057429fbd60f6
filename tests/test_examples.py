"""Every script in examples/ runs in its smoke mode and reports sane numbers.

Each runs in a fresh interpreter, exactly as a user would start it (``python examples/x.py
--smoke``), and its ``result:`` line is parsed. A script whose optional dependency is missing
is skipped, naming the package (see ``pytest -rs``).
"""

from __future__ import annotations

import math
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"


def run_example(name: str, *args: str, cwd: Path) -> list[dict[str, str]]:
    """Run ``examples/name --smoke args``; its ``result:`` lines as key=value dicts."""
    proc = subprocess.run([sys.executable, str(EXAMPLES / name), "--smoke", *args],
                          capture_output=True, text=True, timeout=400, cwd=cwd)
    assert proc.returncode == 0, f"{name} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}"
    results = [dict(kv.split("=", 1) for kv in line.split()[1:])
               for line in proc.stdout.splitlines() if line.startswith("result:")]
    assert results, f"{name} printed no result line:\n{proc.stdout[-2000:]}"
    assert any(line.startswith("speed:") for line in proc.stdout.splitlines())
    return results


def number(result: dict[str, str], key: str) -> float:
    value = float(result[key])
    assert math.isfinite(value), f"{key}={result[key]}"
    return value


def check_low_level(r: dict[str, str], steps: int) -> None:
    """The low-level task's evaluation numbers: 64 seeded episodes of the trained policy."""
    assert int(r["steps"]) == steps
    assert int(r["episodes"]) == 64
    assert number(r, "steps_per_s") > 0
    # a mean episode reward lies between the all-bad shaping of a long episode (-0.75) and a
    # hit (+1) with a perfect landing (+1) plus shaping
    assert -1.0 < number(r, "mean_reward") < 2.2
    hit, in_court = number(r, "hit_rate"), number(r, "in_court")
    assert 0.0 <= in_court <= hit <= 1.0  # landing in court needs a hit
    assert hit > 0.0  # some serves fall onto the racket even before training (10 %)


def test_sb3_ppo_and_its_export(tmp_path):
    pytest.importorskip("stable_baselines3")
    [r] = run_example("sb3_ppo.py", "--steps", "8192", "--save", str(tmp_path / "ppo"),
                      cwd=tmp_path)
    check_low_level(r, 8192)
    # The exported actor (safetensors + JSON, no pickle) is the policy the script evaluated.
    from rallysim.eval.low_eval import evaluate_return
    from rallysim.policies.mlp import load_policy

    again = evaluate_return(load_policy(tmp_path / "ppo"), episodes=64, seed=12345)
    assert f"{again.mean_reward:.3f}" == r["mean_reward"]
    assert f"{again.hit_rate:.3f}" == r["hit_rate"]


def test_sb3_sac(tmp_path):
    pytest.importorskip("stable_baselines3")
    [r] = run_example("sb3_sac.py", "--steps", "3072", cwd=tmp_path)
    check_low_level(r, 3072)


def test_cleanrl_style_ppo(tmp_path):
    pytest.importorskip("torch")
    [r] = run_example("cleanrl_ppo.py", "--steps", "8192", cwd=tmp_path)
    check_low_level(r, 8192)
    assert number(r, "train_return") > -1.0


def test_torchrl_rollouts(tmp_path):
    pytest.importorskip("torchrl")
    single, batched, rally = run_example("torchrl_rollout.py", "--steps", "150", cwd=tmp_path)
    assert [r["env"] for r in (single, batched, rally)] == [
        "GymEnv", "GymWrapper-make_vec-x64", "PettingZooWrapper-simple_rally_v0"]
    assert all(int(r["steps"]) == 150 for r in (single, batched, rally))
    assert [int(r["env_steps"]) for r in (single, batched, rally)] == [150, 150 * 64, 150]
    # a serve lands within about 2 s (20 decisions): episodes end throughout the rollouts
    assert int(single["episodes"]) >= 3 and int(batched["episodes"]) >= 3 * 64
    assert int(rally["episodes"]) >= 1
    for r in (single, batched):  # random swings: shaping (-0.005 per physics step) and hits
        assert -0.03 < number(r, "mean_step_reward") < 0.3
    assert 0.0 <= number(rally, "mean_step_reward") < 0.2  # +0.2 per hit, never negative


def test_supersuit_sb3_rally(tmp_path):
    pytest.importorskip("supersuit")
    pytest.importorskip("stable_baselines3")
    [r] = run_example("supersuit_sb3.py", "--steps", "2048", cwd=tmp_path)
    assert int(r["steps"]) == 2048 and int(r["rallies"]) == 16
    assert int(r["episodes"]) > 0  # a rally of untrained players ends within ~2 s
    assert 0.0 <= number(r, "train_return") < 1.0  # +0.2 per hit to both players
    assert 0.0 <= number(r, "mean_rally") < 50.0


def test_rllib_rally(tmp_path):
    pytest.importorskip("ray")
    [r] = run_example("rllib_rally.py", "--steps", "1024", cwd=tmp_path)
    # RLlib samples whole batches of 1,024 agent steps (rounded up to whole env steps)
    assert int(r["requested"]) == 1024 <= int(r["steps"]) < 1024 + 64
    assert int(r["rallies"]) == 16
    assert 0.0 <= number(r, "train_return") < 1.0
    assert 0.0 <= number(r, "mean_rally") < 50.0
