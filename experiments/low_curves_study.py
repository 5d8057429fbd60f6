"""Learning curves of the SIMPLE low level: reinforcement learning alone beside the cloned path.

Two ways to train the low level, each exactly as ``rallysim reproduce`` trains it (the same
stage settings, so a seed here is that budget's seed there):

``cloned``
    ``--budget default``: behaviour cloning of the scripted controller, then PPO on
    ``RallySim/SimpleReturn-v0`` (not the paper's method).
``rl``
    ``--budget rl``: PPO alone from a random start on ``RallySim/SimpleReturn-v1`` (goals the
    serve makes reachable); no teacher anywhere.

The stage evaluates its deterministic policy every eighth of its budget on the same fresh
serves (v0's goals; ``rallysim.train.stages.low``): mean episode reward, median landing error
and the correlation of landing depth with the goal over reachable goals. The x axis counts
every decision training used: the teacher's cloned decisions first, then PPO's.

    python -m experiments.low_curves_study seed --method rl --seed 0 --out runs/low_curves
    python -m experiments.low_curves_study report --out runs/low_curves

``report`` writes ``OUT/low_curves.json`` (docs/rl-alone.md renders it: a generated block,
``rallysim.train.study_tables``, checked by a test) and the figure ``OUT/low_curves.png``: each
seed's curve, and the mean over seeds with its 95 % bootstrap interval (seeds resampled).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path
from typing import Any

import numpy as np

from rallysim.eval.stats import over_seeds
from rallysim.train.study_tables import LOW_CURVE_METRICS as METRICS
from rallysim.train.study_tables import render_low_curves as render

KIND = "low_curves"
METHODS = {"cloned": "default", "rl": "rl"}  # method -> the reproduce budget it trains as
LABELS = {"cloned": "cloned, then PPO (default)", "rl": "RL alone (--budget rl)"}
def run_seed(method: str, seed: int, out: Path) -> dict[str, Any]:
    """Train one seed's low level the way ``method`` does; return its curve."""
    from rallysim.train.reproduce import BUDGETS, train_seed_stage

    return train_seed_stage(seed, "low", BUDGETS[METHODS[method]], out / method, {})


def seed_points(curve: dict[str, Any]) -> list[dict[str, Any]]:
    """A run's evaluations against the decisions used so far (cloned ones first)."""
    cloned = int((curve.get("warm_start") or {}).get("samples", 0))
    return [{"decisions": cloned + int(e["steps"]),
             **{key: e.get(key) for key, _, _ in METRICS}, "hit_rate": e["hit_rate"]}
            for e in curve["evals"]]


def collect(out: Path, seeds: int) -> dict[str, Any]:
    """The curves of every method's seeds under ``out``, pooled point by point."""
    methods: dict[str, Any] = {}
    for method, budget in METHODS.items():
        per_seed = {}
        for s in range(seeds):
            path = out / method / "runs" / f"low_seed{s}" / "curve.json"
            if not path.is_file():
                raise FileNotFoundError(f"{path}: run the seed step first "
                                        f"(seed --method {method} --seed {s})")
            per_seed[str(s)] = seed_points(json.loads(path.read_text()))
        lengths = {len(points) for points in per_seed.values()}
        if len(lengths) != 1:
            raise ValueError(f"{method}: seeds evaluated a different number of times")
        pooled = []
        for i in range(lengths.pop()):
            row = [per_seed[str(s)][i] for s in range(seeds)]
            pooled.append({"decisions": int(np.mean([r["decisions"] for r in row])),
                           **{key: over_seeds([r[key] for r in row]) for key, _, _ in METRICS}})
        methods[method] = {"budget": budget, "label": LABELS[method], "seeds": per_seed,
                           "pooled": pooled}
    return {"kind": KIND, "seeds": seeds, "methods": methods}


def figure(doc: dict[str, Any], path: Path) -> None:
    """Each seed's curve (thin) and the mean over seeds with its 95 % interval (band)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, len(METRICS), figsize=(13, 3.6))
    for colour, m in zip(("tab:blue", "tab:orange"), doc["methods"].values(), strict=False):
        for points in m["seeds"].values():
            xs = [p["decisions"] / 1e6 for p in points]
            for ax, (key, _, _) in zip(axes, METRICS, strict=True):
                ax.plot(xs, [np.nan if p[key] is None else p[key] for p in points],
                        color=colour, lw=0.7, alpha=0.5)
        xs = [p["decisions"] / 1e6 for p in m["pooled"]]
        for ax, (key, _, _) in zip(axes, METRICS, strict=True):
            vals = [p[key] or {"value": np.nan, "low": np.nan, "high": np.nan}
                    for p in m["pooled"]]
            ax.plot(xs, [v["value"] for v in vals], color=colour, lw=2, marker="o",
                    label=m["label"])
            ax.fill_between(xs, [v["low"] for v in vals], [v["high"] for v in vals],
                            color=colour, alpha=0.2)
    for ax, (_, title, _) in zip(axes, METRICS, strict=True):
        ax.set_title(title)
        ax.set_xlabel("training decisions (M): cloned, then PPO's")
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="command", required=True)
    seed = sub.add_parser("seed", help="train one seed's low level one way")
    seed.add_argument("--method", choices=sorted(METHODS), required=True)
    seed.add_argument("--seed", type=int, required=True)
    seed.add_argument("--out", type=Path, required=True)
    report = sub.add_parser("report", help="pool the seeds: JSON and figure")
    report.add_argument("--out", type=Path, required=True)
    report.add_argument("--seeds", type=int, default=3)
    args = parser.parse_args(argv)
    if args.command == "seed":
        run_seed(args.method, args.seed, args.out)
        return 0
    doc = collect(args.out, args.seeds)
    (args.out / f"{KIND}.json").write_text(json.dumps(doc, indent=1) + "\n")
    figure(doc, args.out / f"{KIND}.png")
    print(render(doc))
    print(f"wrote {args.out / (KIND + '.json')} and {args.out / (KIND + '.png')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
