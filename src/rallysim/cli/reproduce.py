"""``rallysim reproduce``: the whole pipeline, every stage and baseline, and the paper's
Table VII."""

from __future__ import annotations

import argparse
from pathlib import Path

from rallysim.cli.common import add_command, hits_cap, positive, require_train_extra
from rallysim.cli.paths import out_dir, require


def add_parser(sub: argparse._SubParsersAction) -> None:
    repro = add_command(sub, "reproduce", "the whole pipeline and the paper's Table VII")
    repro.add_argument("--budget", choices=("default", "quick", "scratch", "rl", "smoke"),
                       default="default",
                       help="default: 3 seeds, the default (its time on 2 cores: "
                            "docs/results.md); quick: a look in ~5 min; scratch: "
                            "the default with the low level trained from scratch; rl: no "
                            "teacher anywhere, the low level from scratch on "
                            "SimpleReturn-v1; smoke: a tiny run that checks that the pipeline "
                            "runs, not its numbers")
    repro.add_argument("--player", choices=("simple", "humanlike"), default="simple",
                       help="simple: the paper's 2-D players (Table VII); humanlike: the 3-D "
                            "HUMAN-LIKE players, the same three methods over the clone of "
                            "AimedSwing (budgets default, quick, smoke: docs/humanlike.md)")
    repro.add_argument("--out", type=out_dir, default="results",
                       help="folder of the runs, the report and its JSON")
    repro.add_argument("--workers", type=positive,
                       help="processes training and evaluating at once (default: one per CPU "
                            "core)")
    repro.add_argument("--seeds", type=positive,
                       help="training seeds (default: the budget's, 3; the seed-spread study "
                            "uses 5)")
    repro.add_argument("--cap", type=hits_cap, default=50,
                       help="rallies end at this many hits (default 50, the paper's; up to "
                            "100000): only a landing or the cap ends a rally")
    repro.set_defaults(run=run)


def run(args: argparse.Namespace) -> int:
    """Train every stage and baseline on the chosen budget and write the Table VII report."""
    require_train_extra()
    from rallysim.train.reproduce import budget_named, result_names, run_reproduce

    budget = budget_named(args.budget, args.player)  # (scratch and rl: SIMPLE only)
    for name in result_names(args.cap).values():
        require(Path(args.out) / name, "file")  # written after all the training
    results = run_reproduce(budget, Path(args.out), workers=args.workers, seeds=args.seeds,
                            cap=args.cap)
    print((Path(args.out) / result_names(args.cap)["report"]).read_text())
    return 0 if results else 1
