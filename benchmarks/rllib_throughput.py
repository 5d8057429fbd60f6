"""Training throughput of the RLlib backend beside the single-machine SB3 path, in one run.

Run: ``python benchmarks/rllib_throughput.py [--quick] [--stage low|mono] [--runners 1 2]``

Each row trains the stage from scratch for the same budget with its packaged config
(evaluations off; the reported rate is decisions over training wall time, start-up and the
final evaluation excluded): SB3 through ``rallysim.train.runner.train_stage``, RLlib through
``rallysim.rllib.runner.train_stage_rllib`` on a local Ray with 0 (the driver samples), 1 and 2
env runners. The SB3 row is measured in the same run because the machine is shared and noisy.
"""

from __future__ import annotations

import argparse
import tempfile
import time
from pathlib import Path

from rallysim.rllib.runner import train_stage_rllib
from rallysim.train.config import load_config
from rallysim.train.runner import train_stage


def stage_config(stage: str, decisions: int):
    return load_config(stage, None, {"budget": decisions, "eval.every": 0,
                                     "eval.episodes": 16, "checkpoint_every": 10**9})


def measure(stage: str, decisions: int, backend: str, runners: int, folder: Path) -> dict:
    config = stage_config(stage, decisions)
    start = time.perf_counter()
    if backend == "sb3":
        curve = train_stage(config, folder / f"{stage}_sb3", progress=False)
    else:
        curve = train_stage_rllib(config, folder / f"{stage}_rllib{runners}",
                                  env_runners=runners, progress=False)
    return {"backend": backend, "runners": runners, "steps": curve["steps"],
            "rate": curve["steps"] / curve["train_wall_s"],
            "wall": time.perf_counter() - start}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="a tenth of the budget")
    parser.add_argument("--stage", choices=("low", "mono"), default="low")
    parser.add_argument("--runners", type=int, nargs="+", default=[0, 1, 2])
    args = parser.parse_args()
    decisions = int((400_000 if args.stage == "low" else 200_000) * (0.1 if args.quick else 1))
    config = stage_config(args.stage, decisions)
    ppo = config.ppo
    print(f"stage {args.stage}, {decisions:,} decisions, n_envs {ppo.n_envs}, n_steps "
          f"{ppo.n_steps}, batch {ppo.batch_size}, {ppo.n_epochs} epochs\n")
    with tempfile.TemporaryDirectory() as tmp:
        rows = [measure(args.stage, decisions, "sb3", 0, Path(tmp))]
        rows += [measure(args.stage, decisions, "rllib", k, Path(tmp)) for k in args.runners]
    base = rows[0]["rate"]
    print("| backend | env runners | decisions | decisions/s (training) | ratio to SB3 "
          "| wall incl. start-up (s) |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        runners = "—" if r["backend"] == "sb3" else str(r["runners"])
        print(f"| {r['backend']} | {runners} | {r['steps']:,} | {r['rate']:,.0f} | "
              f"{r['rate'] / base:.2f} | {r['wall']:.0f} |")


if __name__ == "__main__":
    main()
