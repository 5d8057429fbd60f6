"""The HUMAN-LIKE low level's learning curves (the paper's Fig. 8): hit rate, angle error and
speed error of deterministic evaluations against training decisions, for one or more runs of
``rallysim train low --player humanlike``, with issue 5's targets drawn in.

Run: ``python benchmarks/humanlike_learning_curve.py RUN_DIR[=LABEL] ... --out PNG``

Each run folder's ``curve.json`` gives the evaluations: a warm start's after the clone and
after each DAgger round (x: the decisions the teacher labelled so far), then PPO's every
``eval_every`` decisions (x: those decisions, after the labelled ones).
"""

from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt

PANELS = (("hit_rate", "hit rate", 0.9, "above"), ("mean_angle_error", "mean angle error (deg)",
                                                     5.0, "below"),
          ("mean_abs_speed_error", "mean |speed error|", 0.10, "below"))


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("runs", nargs="+", help="run folder, optionally =label")
    parser.add_argument("--out", required=True, help="PNG to write")
    args = parser.parse_args()
    fig, axes = plt.subplots(1, 3, figsize=(13, 3.6))
    for spec in args.runs:
        folder, _, label = spec.partition("=")
        curve = json.loads((Path(folder) / "curve.json").read_text())
        rounds = curve.get("warm_start", {}).get("rounds", [])
        labelled = rounds[-1]["labelled_decisions"] if rounds else 0
        points = [(r["labelled_decisions"], r) for r in rounds]
        if curve["steps"] > 0 or not rounds:  # PPO's evaluations (a clone alone has just one)
            points += [(labelled + e["steps"], e) for e in curve["evals"]]
        points.sort(key=lambda p: p[0])
        for ax, (key, _, _, _) in zip(axes, PANELS, strict=True):
            ax.plot([x / 1e6 for x, _ in points], [e[key] for _, e in points], marker="o",
                    label=label or folder)
    for ax, (_, title, target, side) in zip(axes, PANELS, strict=True):
        ax.axhline(target, color="red", ls="--", lw=1, label=f"target ({side})")
        ax.set_xlabel("decisions: labelled by the teacher, then PPO's (millions)")
        ax.set_title(title)
        ax.grid(alpha=0.3)
    axes[1].set_yscale("log")
    axes[2].set_yscale("log")
    axes[0].legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(args.out, dpi=110)
    print(f"wrote {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
