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

``--ready`` adds the task's ``ready`` reward, ``--incoming mixed`` trains the low level on
recorded rally shots as well as serves. Each seed also records the low level's band: its mean
rally at fixed goals of 2, 2.5, ..., 6 m for both players (48 rallies each); ``--bands`` adds
it to the seeds of an earlier probe in ``--out``.

Each seed's result is written to ``OUT/seed{N}.json`` as soon as it is played; a rerun skips
the seeds already there. ``--report FILE`` then pools the seeds in ``OUT`` into FILE (JSON):
HRL's mean with its 95 % interval (seeds, then rallies, resampled), per seed, the worst seed,
the bands, and with ``--compare`` (a study's results.json or another probe's report) the
paired difference from its seeds.
"""

from __future__ import annotations

import argparse
import json
import time
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import numpy as np

BAND_SEED = 777  # the evaluation seed of the research log's fixed-goal tables
BAND_POINTS, BAND_RALLIES = 9, 48  # goals 2, 2.5, ..., 6 m; rallies at each


def run_seed(seed: int, out: Path, bonus: float, ready: float = 0.0,
             incoming: str = "serve") -> dict[str, Any]:
    from rallysim.eval.rally_eval import PAPER_CAP, rally_lengths_turns, rules_for_cap
    from rallysim.policies.registry import resolve
    from rallysim.train.reproduce import BUDGETS, evaluation_seed, train_seed_stage

    default, curves = BUDGETS["default"], {}
    extra = (("returnable", bonus),) + ((("ready", ready),) if ready else ()) \
        + ((("incoming", incoming),) if incoming != "serve" else ())
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
            "band": band_of(low), "low_final": curves["low"]["final"],
            "high_final": curves["high"]["final"],
            "wall_s": round(time.perf_counter() - t, 1)}


def band_of(low: Any) -> list[float]:
    """The low level's band: its mean rally at fixed goals of 2, 2.5, ..., 6 m for both
    players, 48 rallies each."""
    from rallysim.players import SIMPLE
    from rallysim.train.goal_sweep import sweep_goals

    return sweep_goals(SIMPLE, low, BAND_POINTS, BAND_RALLIES, BAND_SEED)["mean_rally"]


def band_goals() -> list[float]:
    """The goals of ``band_of``, in metres."""
    from rallysim.players import SIMPLE
    from rallysim.train.goal_sweep import action_grid

    return [float(g) for g in SIMPLE.goal.from_action(action_grid(BAND_POINTS, 1)).ravel()]


def terms_of(doc: dict[str, Any]) -> tuple[float, float, str]:
    """A probe seed's task terms (bonus, ready, incoming), as earlier probes' JSON gives them."""
    return doc["bonus"], doc.get("ready", 0.0), doc.get("incoming", "serve")


def add_bands(out: Path) -> None:
    """Measure the band of each seed in ``out`` that has none (seeds of an earlier probe)."""
    from rallysim.policies.registry import resolve

    for path in sorted(out.glob("seed*.json")):
        doc = json.loads(path.read_text())
        if "band" not in doc:
            low = resolve(str(out / "runs" / f"low_seed{doc['seed']}" / "policy"), "rally_low")
            doc["band"] = band_of(low)
            path.write_text(json.dumps(doc, indent=1))
            print(f"seed {doc['seed']}: band {[round(v, 1) for v in doc['band']]}", flush=True)


def report(out: Path, compare: Path | None) -> dict[str, Any]:
    """The pooled summary of the seeds in ``out`` (see the module docstring)."""
    from rallysim.eval.stats import estimate, mean, over_seeds

    seeds = sorted((json.loads(p.read_text()) for p in out.glob("seed*.json")),
                   key=lambda r: r["seed"])
    if not seeds:
        raise SystemExit(f"no seed*.json in {out}")
    terms = {terms_of(r) for r in seeds}
    if len(terms) > 1:
        raise SystemExit(f"{out} holds seeds of several probes (bonus, ready, incoming): "
                         f"{sorted(terms)}")
    per_seed = {str(r["seed"]): r["hrl_mean"] for r in seeds}
    doc: dict[str, Any] = {
        **dict(zip(("bonus", "ready", "incoming"), terms_of(seeds[0]), strict=True)),
        "per_seed": per_seed,
        "pooled": asdict(estimate([np.array(r["lengths"]) for r in seeds], mean)),
        "worst_seed": min(per_seed.items(), key=lambda kv: kv[1]),
        "seeds_at_40_or_more": sum(v >= 40.0 for v in per_seed.values()),
        "lengths": {str(r["seed"]): r["lengths"] for r in seeds}}
    bands = {str(r["seed"]): r["band"] for r in seeds if "band" in r}
    if bands:  # the goals (2, 2.5, ..., 6 m) at which the low level sustains 40 hits or more
        doc["bands"] = bands
        goals = band_goals()
        doc["band_goals_at_40"] = {s: [g for g, v in zip(goals, b, strict=True) if v >= 40.0]
                                   for s, b in bands.items()}
    if compare is not None:
        other = json.loads(compare.read_text())
        if "per_seed" in other:  # another probe's report
            before = {s: other["per_seed"][s] for s in per_seed if s in other["per_seed"]}
        else:  # a study's results.json
            study = other["methods_per_seed"]["HRL"]
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
    parser.add_argument("--incoming", default="serve", choices=("serve", "mixed", "rally"),
                        help="the low-level task's incoming shots")
    parser.add_argument("--report", type=Path, help="pool the seeds in --out into this JSON")
    parser.add_argument("--compare", type=Path,
                        help="a study's results.json or another probe's report (--report)")
    parser.add_argument("--bands", action="store_true",
                        help="only measure the bands of the seeds in --out that have none")
    args = parser.parse_args(argv)
    if args.bands:
        add_bands(args.out)
        return
    if args.report is not None:
        doc = report(args.out, args.compare)
        args.report.write_text(json.dumps(doc, indent=1) + "\n")
        shown = {k: v for k, v in doc.items()
                 if k not in ("compared_with", "lengths", "bands")}
        print(json.dumps(shown, indent=1))
        return
    args.out.mkdir(parents=True, exist_ok=True)
    for seed in (int(s) for s in args.seeds.split(",")):
        path = args.out / f"seed{seed}.json"
        if path.exists():
            done = json.loads(path.read_text())
            terms = terms_of(done)
            if terms != (args.bonus, args.ready, args.incoming):
                raise SystemExit(f"{path} was played with (bonus, ready, incoming) {terms}: "
                                 f"use another --out")
            continue
        result = {"bonus": args.bonus, "ready": args.ready, "incoming": args.incoming,
                  **run_seed(seed, args.out, args.bonus, args.ready, args.incoming)}
        path.write_text(json.dumps(result, indent=1))
        print(f"seed {seed}: HRL {result['hrl_mean']:.2f} ({result['wall_s']:.0f} s)",
              flush=True)


if __name__ == "__main__":
    main()
