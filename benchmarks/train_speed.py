"""Training throughput of every stage end to end, beside the raw env in the same run.

Run: ``python benchmarks/train_speed.py [--quick]``

Each stage trains from scratch for a fixed budget with its packaged config (evaluations off),
through ``rallysim.train.runner.train_stage``: rollouts, PPO updates, checkpoints. Reported:
SB3 steps/s, and player-decisions/s (the high stage's turns each span many decisions of both
players). The reference is the raw batched low-level env under random actions at the low stage's
N, measured in the same run, since the machine is shared and noisy.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

import numpy as np

from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv
from rallysim.train.config import load_config
from rallysim.train.runner import train_stage


def raw_env_rate(n: int, seconds: float) -> float:
    env = SimpleReturnVectorEnv(n, seed=0, autoreset_mode="same_step")
    env.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (32, n, 3))
    env.step(actions[-1])  # not timed: a first step may compile the kernels
    done, start, k = 0, time.perf_counter(), 0
    while time.perf_counter() - start < seconds:
        env.step(actions[k % 32])
        done, k = done + n, k + 1
    return done / (time.perf_counter() - start)


def stage_rate(stage: str, steps: int, folder: Path) -> tuple[float, float]:
    overrides = {"budget": steps, "eval.every": 0, "eval.episodes": 16,
                 "checkpoint_every": 10**9}
    if stage == "high":
        overrides["low_policy"] = "scripted"
    config = load_config(stage, None, overrides)
    curve = train_stage(config, folder / stage, progress=False)
    wall = curve["train_wall_s"]
    decisions = 2 * curve["decisions_simulated"] if stage == "high" else curve["steps"]
    return curve["steps"] / wall, decisions / wall


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true")
    args = parser.parse_args()
    scale = 0.1 if args.quick else 1.0
    budgets = {"low": int(400_000 * scale), "high": int(6_000 * scale),
               "mono": int(400_000 * scale)}
    low_n = load_config("low").ppo.n_envs
    ref = raw_env_rate(low_n, 1.0 if args.quick else 3.0)
    print(f"reference: raw SimpleReturnVectorEnv at N = {low_n}, random actions: "
          f"{ref:,.0f} decisions/s\n")
    print("| stage | budget (SB3 steps) | SB3 steps/s | player-decisions/s | ratio to raw env |")
    print("|---|---:|---:|---:|---:|")
    with tempfile.TemporaryDirectory() as tmp:
        for stage, steps in budgets.items():
            rate, decisions = stage_rate(stage, steps, Path(tmp))
            print(f"| {stage} | {steps:,} | {rate:,.0f} | {decisions:,.0f} | "
                  f"{decisions / ref:.2f} |")
    print("\n(high: one SB3 step is one turn; its low level here is the scripted controller)")


if __name__ == "__main__":
    main()
