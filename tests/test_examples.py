"""Every script in examples/ runs as ``python examples/x.py --smoke`` and gives its seeded numbers.

Each script runs in a fresh interpreter, exactly as a user would start it, with ``--smoke`` and
nothing else (the step counts are the scripts' own smoke settings), and its ``result:`` lines
are parsed. A script whose optional dependency is missing is skipped, naming the package (see
``pytest -rs``).

What is checked, for each script:

- bounds that hold on any machine: the step counts asked for, rates in [0, 1] with in-court
  <= hit, and for the two PPO scripts, which learn within their smoke runs, a hit rate and a
  mean reward well above any untrained policy's (random actions and untrained networks hit
  5-17 % of these 64 evaluation serves, mean reward -0.4 to 0.1);
- for scripts that train with torch, that a second run of the same command gives the same
  ``result:`` line (``check_repeatable``): their seeds reach everything, on any machine. Their
  exact numbers are not pinned: torch's kernels (ATen, MKL) round differently on other CPUs,
  and no setting makes a training run bit-identical across CPUs (docs/numerics.md);
- for scripts whose numbers come from the SIMPLE simulator under random actions alone, those
  numbers, each held to its pinned value (``check_pinned``) within one unit of the printed
  precision: they hold on other CPUs' numerics too (checked unpinned on an Intel CPU with
  AVX-512 and under NumPy's baseline code).
  A pin fails when the physics, the rules, an env or the evaluator changes its results, or a
  seed stops being passed through; a deliberate change re-pins from the printed ``result:``
  line.
"""

from __future__ import annotations

import math
import os
import subprocess
import sys
from pathlib import Path

import pytest

EXAMPLES = Path(__file__).resolve().parent.parent / "examples"
# each example runs in a fresh interpreter (torch, Ray...); most of them train
pytestmark = pytest.mark.slow


def run_example(name: str, *args: str, cwd: Path, quiet: bool = False,
                env: dict[str, str] | None = None) -> list[dict[str, str]]:
    """Run ``examples/name --smoke args``; its ``result:`` lines as key=value dicts.
    ``quiet``: the script must also print nothing to stderr (no warnings). ``env``: extra
    environment variables."""
    proc = subprocess.run([sys.executable, str(EXAMPLES / name), "--smoke", *args],
                          capture_output=True, text=True, timeout=400, cwd=cwd,
                          env={**os.environ, **(env or {})})
    assert proc.returncode == 0, f"{name} failed:\n{proc.stdout[-2000:]}\n{proc.stderr[-4000:]}"
    assert not (quiet and proc.stderr), f"{name} printed to stderr:\n{proc.stderr[-4000:]}"
    results = [dict(kv.split("=", 1) for kv in line.split()[1:])
               for line in proc.stdout.splitlines() if line.startswith("result:")]
    assert results, f"{name} printed no result line:\n{proc.stdout[-2000:]}"
    assert any(line.startswith("speed:") for line in proc.stdout.splitlines())
    return results


def number(result: dict[str, str], key: str) -> float:
    value = float(result[key])
    assert math.isfinite(value), f"{key}={result[key]}"
    return value


def check_pinned(name: str, r: dict[str, str], pinned: dict[str, tuple[float, float]]) -> None:
    """Every pinned number within its band; all that are not are named at once."""
    off = {key: f"{r[key]} (pinned {value} +- {tol})" for key, (value, tol) in pinned.items()
           if not abs(number(r, key) - value) <= tol}
    assert not off, (f"{name}: seeded smoke results moved: {off}. If the physics, the env or "
                     "the example changed on purpose, re-pin from its result line.")


def check_repeatable(name: str, r: dict[str, str] | list[dict[str, str]], *args: str,
                     cwd: Path, env: dict[str, str] | None = None) -> None:
    """A second run of ``examples/name --smoke args`` prints the same results as ``r``, bit
    for bit (``speed`` and timing keys aside): seeded training is deterministic on a machine."""
    again = run_example(name, *args, cwd=cwd, env=env)
    first = r if isinstance(r, list) else [r]

    def kept(rows: list[dict[str, str]]) -> list[dict[str, str]]:
        return [{k: v for k, v in row.items() if not k.endswith(("_s", "per_s"))}
                for row in rows]

    assert kept(again) == kept(first), f"{name}: a second seeded run gave other results"


def check_low_level(r: dict[str, str], steps: int) -> None:
    """Machine-independent bounds on the low-level task's evaluation numbers (64 episodes)."""
    assert int(r["steps"]) == steps
    assert int(r["episodes"]) == 64
    hit, in_court = number(r, "hit_rate"), number(r, "in_court")
    assert 0.0 <= in_court <= hit <= 1.0  # landing in court needs a hit


def check_learned(r: dict[str, str]) -> None:
    """A smoke run of PPO (131,072 steps) learns to hit: seeds 0 and 1 hit 61-95 % with a mean
    reward of 0.60-0.92, untrained policies 5-17 % (mean reward at most 0.1)."""
    assert number(r, "hit_rate") >= 0.4, r
    assert number(r, "mean_reward") >= 0.3, r


def test_sb3_ppo_and_its_export(tmp_path):
    pytest.importorskip("stable_baselines3")
    # quiet: the documented example prints no warning (no DeprecationWarning for an old id)
    [r] = run_example("sb3_ppo.py", "--save", str(tmp_path / "ppo"), cwd=tmp_path, quiet=True)
    check_low_level(r, 131_072)
    check_learned(r)
    short = run_example("sb3_ppo.py", "--steps", "8192", cwd=tmp_path)
    check_repeatable("sb3_ppo.py", short, "--steps", "8192", cwd=tmp_path)
    # The exported actor (safetensors + JSON, no pickle) is the policy the script evaluated.
    from rallysim.eval.low_eval import evaluate_return
    from rallysim.policies.mlp import load_policy

    again = evaluate_return(load_policy(tmp_path / "ppo"), episodes=64, seed=12345)
    assert f"{again.mean_reward:.3f}" == r["mean_reward"]
    assert f"{again.hit_rate:.3f}" == r["hit_rate"]


def test_sb3_sac(tmp_path):
    pytest.importorskip("stable_baselines3")
    [r] = run_example("sb3_sac.py", cwd=tmp_path)
    check_low_level(r, 3072)
    # 3,072 steps: SAC has not learned yet, but its seeded run repeats exactly
    check_repeatable("sb3_sac.py", r, cwd=tmp_path)


def test_cleanrl_style_ppo(tmp_path):
    pytest.importorskip("torch")
    [r] = run_example("cleanrl_ppo.py", cwd=tmp_path)
    check_low_level(r, 131_072)
    check_learned(r)
    short = run_example("cleanrl_ppo.py", "--steps", "8192", cwd=tmp_path)
    check_repeatable("cleanrl_ppo.py", short, "--steps", "8192", cwd=tmp_path)


def test_cleanrl_style_ppo_rounds_steps_up_to_whole_rollouts_and_says_so(tmp_path):
    pytest.importorskip("torch")
    proc = subprocess.run([sys.executable, str(EXAMPLES / "cleanrl_ppo.py"), "--steps", "100",
                           "--num-envs", "4", "--num-steps", "8", "--minibatches", "2",
                           "--epochs", "1"], capture_output=True, text=True, timeout=200,
                          cwd=tmp_path, check=True)
    assert "training 128 env steps (100 rounded up to whole rollouts): 4 updates" in proc.stdout
    assert "result: steps=128 " in proc.stdout


@pytest.mark.parametrize(("script", "steps"), [
    ("sb3_ppo.py", "0"), ("sb3_sac.py", "0"), ("cleanrl_ppo.py", "0"), ("cleanrl_ppo.py", "-5"),
    ("torchrl_rollout.py", "0"), ("supersuit_sb3.py", "0"), ("pettingzoo_random.py", "0"),
    ("rllib_rally.py", "0"),
])
def test_non_positive_steps_are_refused(script, steps, tmp_path):
    """``--steps 0`` is refused with argparse's usage error (exit 2), not taken as the default.
    (Parsing happens before any work; rllib_rally.py without Ray exits 2 as well, first.)"""
    proc = subprocess.run([sys.executable, str(EXAMPLES / script), "--steps", steps],
                          capture_output=True, text=True, timeout=120, cwd=tmp_path)
    assert proc.returncode == 2, proc.stderr[-2000:]
    if "needs Ray RLlib" not in proc.stderr:
        assert f"argument --steps: must be a positive integer, got {steps}" in proc.stderr, (
            proc.stderr)


def test_torchrl_rollouts(tmp_path):
    pytest.importorskip("torchrl")
    single, batched, rally = run_example("torchrl_rollout.py", cwd=tmp_path)
    assert all(int(r["steps"]) == 200 for r in (single, batched, rally))
    assert [int(r["env_steps"]) for r in (single, batched, rally)] == [200, 200 * 64, 200]
    # the three rollouts' numbers checked together, so that every one that moved is named
    every = {f"{r['env']}.{key}": value
             for r in (single, batched, rally) for key, value in r.items()}
    check_pinned("torchrl_rollout.py", every, {
        "GymEnv.episodes": (10, 0), "GymEnv.mean_step_reward": (-0.0012, 1e-4),
        "GymWrapper-make_vec-x64.episodes": (564, 0),
        "GymWrapper-make_vec-x64.mean_step_reward": (0.0027, 1e-4),
        "PettingZooWrapper-simple_rally_v0.episodes": (7, 0),
        "PettingZooWrapper-simple_rally_v0.mean_step_reward": (0.0030, 1e-4)})


@pytest.mark.parametrize("vec", ["supersuit", "native"])
def test_supersuit_sb3_rally(vec, tmp_path):
    pytest.importorskip("stable_baselines3")
    if vec == "supersuit":
        pytest.importorskip("supersuit")
    # quiet: no warnings, SB3's "render_mode attribute is not defined" included
    [r] = run_example("supersuit_sb3.py", "--vec", vec, cwd=tmp_path, quiet=True)
    assert int(r["steps"]) == 2048 and int(r["rallies"]) == 16
    assert 0.0 <= number(r, "mean_rally") <= 50.0 and number(r, "train_return") >= 0.0
    check_repeatable("supersuit_sb3.py", r, "--vec", vec, cwd=tmp_path)


def test_pettingzoo_random(tmp_path):
    [r] = run_example("pettingzoo_random.py", cwd=tmp_path)
    assert int(r["steps"]) == 500
    check_pinned("pettingzoo_random.py", r, {"rallies": (22, 0), "mean_rally": (0.273, 0.001)})


def test_rllib_rally(tmp_path):
    pytest.importorskip("ray")
    # a seeded RLlib run also depends on Python's string hashing: with PYTHONHASHSEED unset,
    # runs give one of two results (see the script's docstring)
    [r] = run_example("rllib_rally.py", cwd=tmp_path, env={"PYTHONHASHSEED": "0"})
    # RLlib samples whole batches of 1,024 agent steps (rounded up to whole env steps)
    assert int(r["requested"]) == 2048 <= int(r["steps"]) < 2048 + 64
    assert int(r["rallies"]) == 16
    assert 0.0 <= number(r, "mean_rally") <= 50.0 and number(r, "train_return") >= 0.0
    check_repeatable("rllib_rally.py", r, cwd=tmp_path, env={"PYTHONHASHSEED": "0"})


def test_rllib_rally_without_ray_names_the_extra(tmp_path):
    """Without Ray (hidden here, whether installed or not): one line, exit status 2."""
    code = ("import runpy, sys; sys.modules['ray'] = None; "
            f"sys.argv = ['rllib_rally.py', '--smoke']; "
            f"runpy.run_path({str(EXAMPLES / 'rllib_rally.py')!r}, run_name='__main__')")
    proc = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                          timeout=120, cwd=tmp_path)
    assert proc.returncode == 2
    assert proc.stdout == "" and proc.stderr.count("\n") == 1, proc.stderr
    assert 'pip install torch==2.13.0 && pip install "rallysim[ray]"' in proc.stderr
