"""Probe: a low-level task that also rewards a shot the opponent can meet (issue 36).

The 10-seed study loses its rallies in the first exchange, on returns of deep serves that no
base position meets (docs/research-log/reproduce.md); for up to two thirds of those shots the
hitter had one the opponent could have met. The SIMPLE low-level task scores only the landing's
depth. This probe trains the low level with the task's ``returnable`` reward (``--bonus``, on
the decision in which the player hits, when ``ShotPlanner.returnable`` finds that the opponent
can meet the shot at full speed from some base position). Everything else is the default
reproduction's: the low stage (the clone of the scripted controller, then PPO), the high stage
over it, and HRL's 200 evaluation rallies at cap 50 from the reproduction's evaluation seed, so
that each seed's mean compares with the same seed of ``rallysim reproduce --seeds 10``.

    python -m experiments.returnable_probe --out probe --seeds 0,1,2,3,4 --bonus 0.5

Each seed's result is written to ``OUT/seed{N}.json`` as soon as it is played; a rerun skips
the seeds already there. ``--report FILE`` then pools the seeds in ``OUT`` into FILE (JSON):
HRL's mean with its 95 % interval (seeds, then rallies, resampled), per seed, the worst seed,
and with ``--compare STUDY/results.json`` the paired difference from that study's seeds.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np


def run_seed(seed: int, out: Path, bonus: float, ready: float = 0.0) -> dict[str, Any]:
    from rallysim.eval.rally_eval import PAPER_CAP, rally_lengths_turns, rules_for_cap
    from rallysim.policies.registry import resolve
    from rallysim.train.reproduce import BUDGETS, evaluation_seed, train_seed_stage

    default, curves = BUDGETS["default"], {}
    extra = (("returnable", bonus),) + ((("ready", ready),) if ready else ())
    budget = replace(default, low_extra=(*default.low_extra, *extra))
    t = time.perf_counter()
    for stage in ("low", "high"):
        curves[stage] = train_seed_stage(seed, stage, budget, out, curves)
    runs = out / "runs"
    low = resolve(str(runs / f"low_seed{seed}" / "policy"), "rally_low")
    high = resolve(str(runs / f"high_seed{seed}" / "policy"), "high")
    lengths = rally_lengths_turns(high, low, budget.rallies, evaluation_seed(seed),
                                  rules_for_cap(PAPER_CAP))
    return {"seed": seed, "hrl_mean": float(np.mean(lengths)), "lengths": lengths.tolist(),
            "low_final": curves["low"]["final"], "high_final": curves["high"]["final"],
            "wall_s": round(time.perf_counter() - t, 1)}


def report(out: Path, compare: Path | None) -> dict[str, Any]:
    """The pooled summary of the seeds in ``out`` (see the module docstring)."""
    from rallysim.eval.stats import estimate, mean, over_seeds

    seeds = sorted((json.loads(p.read_text()) for p in out.glob("seed*.json")),
                   key=lambda r: r["seed"])
    if not seeds:
        raise SystemExit(f"no seed*.json in {out}")
    terms = {(r["bonus"], r.get("ready", 0.0)) for r in seeds}
    if len(terms) > 1:
        raise SystemExit(f"{out} holds seeds of several probes (bonus, ready): {sorted(terms)}")
    per_seed = {str(r["seed"]): r["hrl_mean"] for r in seeds}
    doc: dict[str, Any] = {
        "bonus": seeds[0]["bonus"], "ready": seeds[0].get("ready", 0.0), "per_seed": per_seed,
        "pooled": asdict(estimate([np.array(r["lengths"]) for r in seeds], mean)),
        "worst_seed": min(per_seed.items(), key=lambda kv: kv[1]),
        "seeds_at_40_or_more": sum(v >= 40.0 for v in per_seed.values()),
        "lengths": {str(r["seed"]): r["lengths"] for r in seeds}}
    if compare is not None:
        study = json.loads(compare.read_text())["methods_per_seed"]["HRL"]
        before = {s: study[s]["mean"]["value"] for s in per_seed if s in study}
        doc["compared_with"] = {"study": str(compare), "per_seed": before,
                                "paired_difference": over_seeds(
                                    [per_seed[s] - before[s] for s in before])}
    return doc


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--out", type=Path, required=True)
    parser.add_argument("--seeds", default="0,1,2,3,4,5,6,7,8,9")
    parser.add_argument("--bonus", type=float, default=0.5)
    parser.add_argument("--ready", type=float, default=0.0,
                        help="the task's ready reward too (0: off)")
    parser.add_argument("--report", type=Path, help="pool the seeds in --out into this JSON")
    parser.add_argument("--compare", type=Path, help="a study's results.json (--report)")
    args = parser.parse_args(argv)
    if args.report is not None:
        doc = report(args.out, args.compare)
        args.report.write_text(json.dumps(doc, indent=1) + "\n")
        print(json.dumps({k: v for k, v in doc.items() if k not in ("compared_with", "lengths")},
                         indent=1))
        return
    args.out.mkdir(parents=True, exist_ok=True)
    for seed in (int(s) for s in args.seeds.split(",")):
        path = args.out / f"seed{seed}.json"
        if path.exists():
            done = json.loads(path.read_text())
            if (done["bonus"], done.get("ready", 0.0)) != (args.bonus, args.ready):
                raise SystemExit(f"{path} was played with bonus {done['bonus']}, ready "
                                 f"{done.get('ready', 0.0)}: use another --out")
            continue
        result = {"bonus": args.bonus, "ready": args.ready,
                  **run_seed(seed, args.out, args.bonus, args.ready)}
        path.write_text(json.dumps(result, indent=1))
        print(f"seed {seed}: HRL {result['hrl_mean']:.2f} ({result['wall_s']:.0f} s)",
              flush=True)


if __name__ == "__main__":
    main()
