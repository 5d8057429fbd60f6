"""The flat (Monolithic) competitive baseline over several training seeds, beside the
hierarchical champion.

Per seed (``seed`` step, one process each, so seeds can run side by side): the compete_mono
stage (``rallysim train compete_mono``: one network acting every decision, self-play against
its league, the actor started from the cooperative ``simple_mono``) makes the flat champion,
``OUT/flat_seed{S}/policy``; it then plays ``games`` games against each of ``OPPONENTS``: the
scripted controller, the cooperative HRL and Monolithic agents and the shipped hierarchical
champion ``simple_compete``. Its snapshots' ratings are those the league logged against the
calibrated ladder. ``report`` pools the seeds (seeds, then games: ``compete_study.pooled_rate``)
into ``OUT/compete_flat.json``, which docs/competitive.md renders (a generated block,
``rallysim.train.study_tables``, checked by a test).

    python -m experiments.compete_flat_study seed --seed 0 --out runs/compete_flat
    python -m experiments.compete_flat_study report --out runs/compete_flat
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from pathlib import Path
from typing import Any

from experiments.compete_study import EVAL_SEED, league_history, play_summary, pooled_rate
from rallysim.train.study_tables import render_compete_flat as render

OPPONENTS = ("scripted", "hrl", "mono", "simple_compete")
KIND = "compete_flat"


def run_seed(seed: int, out: Path, budget: int, games: int, max_decisions: int = 20_000,
             overrides: dict[str, Any] | None = None) -> Path:
    """One seed's flat champion, its games and its snapshots' ratings; returns its JSON."""
    from rallysim.train.config import load_config
    from rallysim.train.runner import train_stage

    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    run = out / f"flat_seed{seed}"
    config = load_config("compete_mono", overrides={
        "seed": seed, "budget": budget, "league.max_decisions": max_decisions,
        **(overrides or {})})
    curve = train_stage(config, run)
    train_s = time.perf_counter() - t0
    champion = str(run / "policy")
    versus = {name: play_summary(champion, name, games, EVAL_SEED + i, max_decisions)
              for i, name in enumerate(OPPONENTS)}
    doc = {"seed": seed, "budget": budget, "games": games, "max_decisions": max_decisions,
           "overrides": overrides or {}, "init_policy": config.init_policy,
           "champion": champion, "versus": versus,
           "ratings": [{"decisions": h["turns"], "rating": h["rating"]}
                       for h in league_history(run)],
           "decisions_per_s": curve["steps_per_s"],
           "wall_s": {"league": round(train_s, 1),
                      "total": round(time.perf_counter() - t0, 1)}}
    path = out / f"flat_seed{seed}.json"
    path.write_text(json.dumps(doc, indent=1))
    return path


def report(out: Path) -> dict[str, Any]:
    """Pool the seeds' JSON in ``out`` and write ``out/compete_flat.json``."""
    seeds = [json.loads(p.read_text()) for p in sorted(out.glob("flat_seed*.json"))]
    if not seeds:
        raise FileNotFoundError(f"no flat_seed*.json in {out}: run the seed step first")
    pooled = {name: pooled_rate([s["versus"][name]["per_game"] for s in seeds])
              for name in OPPONENTS}
    first = seeds[0]
    result = {
        "kind": KIND, "opponents": list(OPPONENTS), "pooled": pooled,
        "settings": {k: first[k] for k in ("budget", "games", "max_decisions", "overrides",
                                           "init_policy")},
        "seeds": [{"seed": s["seed"], "champion": s["champion"], "ratings": s["ratings"],
                   "wall_s": s["wall_s"],
                   **{f"vs_{n}": s["versus"][n]["point_win_rate"] for n in OPPONENTS},
                   "game_win_vs_scripted": s["versus"]["scripted"]["game_win_rate"]}
                  for s in seeds],
    }
    (out / f"{KIND}.json").write_text(json.dumps(result, indent=1))
    return result


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="step", required=True)
    one = sub.add_parser("seed", help="one seed's flat champion and its games")
    one.add_argument("--seed", type=int, required=True)
    one.add_argument("--budget", type=int, default=4_000_000, help="decisions")
    one.add_argument("--games", type=int, default=32)
    one.add_argument("--max-decisions", type=int, default=20_000)
    one.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE")
    rep = sub.add_parser("report", help="pool the seeds into compete_flat.json")
    for p in (one, rep):
        p.add_argument("--out", type=Path, required=True)
    args = parser.parse_args(argv)
    if args.step == "seed":
        from rallysim.train.config import parse_overrides

        path = run_seed(args.seed, args.out, args.budget, args.games, args.max_decisions,
                        parse_overrides(args.set))
        print(f"wrote {path}")
    else:
        print(render(report(args.out)))
    return 0


if __name__ == "__main__":
    sys.exit(main())
