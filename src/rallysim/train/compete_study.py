"""The competitive study over several training seeds: champions, ratings, exploitability.

Per seed (``seed`` step, one process each, so seeds can run side by side):

1. the compete stage (``rallysim train compete``: self-play against its league) makes the
   champion, ``OUT/league_seed{S}/policy``;
2. the champion plays ``games`` games against the scripted controller and the cooperative HRL
   agent: point-win rates with 95 % intervals;
3. the ratings of the league's snapshots against the fixed ladder, in snapshot order;
4. a best response: the compete stage against the frozen champion alone
   (``league.opponents``) for ``br_budget`` turns; its point-win rate against the champion
   measures the champion's exploitability.

``report`` pools the seeds (a two-level bootstrap: seeds, then games), plays the cross-play
matrix of the reference ladder and the best seed's champion, draws the figures and writes
``OUT/compete_study.json``; ``docs`` renders that JSON's tables (docs/competitive.md holds them
between generated-block markers, checked by a test like docs/results.md's).

    python -m rallysim.train.compete_study seed --seed 0 --out runs/compete_study
    python -m rallysim.train.compete_study report --out runs/compete_study
"""

from __future__ import annotations

import argparse
import itertools
import json
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from rallysim.train.progress import say_stderr

EVAL_SEED = 20_000  # evaluation games' seeds: apart from every training seed
OPPONENTS = ("scripted", "hrl")
TARGETS = {"champion_vs_scripted": 0.8, "champion_vs_hrl": 0.8, "best_response": 0.6}


def _games(a: str, b: str, games: int, seed: int, max_decisions: int) -> dict[str, Any]:
    from rallysim.eval.agents import agent
    from rallysim.eval.competitive import play_games, summarise

    played = play_games(agent(a), agent(b), games, seed, max_decisions=max_decisions)
    out = summarise(played, seed=seed)
    out["per_game"] = {"won": played.points[:, 0].tolist(),
                       "points": played.points.sum(axis=1).tolist()}
    return out


def run_seed(seed: int, out: Path, budget: int, br_budget: int, games: int,
             max_decisions: int = 20_000, overrides: dict[str, Any] | None = None) -> Path:
    """One seed's champion, its games, its ratings and its best response (see the module);
    returns the seed's JSON."""
    from rallysim.train import checkpoint as ckpt
    from rallysim.train.config import load_config
    from rallysim.train.runner import train_stage

    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    league_dir = out / f"league_seed{seed}"
    base = {"seed": seed, "league.max_decisions": max_decisions, **(overrides or {})}
    train_stage(load_config("compete", overrides={**base, "budget": budget}), league_dir)
    champion = str(league_dir / "policy")
    league_s = time.perf_counter() - t0
    versus = {name: _games(champion, name, games, EVAL_SEED + i, max_decisions)
              for i, name in enumerate(OPPONENTS)}
    state = json.loads(ckpt.latest_checkpoint(league_dir).read_text())["stage_state"]
    ratings = [{"turns": h["turns"], "rating": h.get("rating")} for h in state["history"]]
    t1 = time.perf_counter()
    br_dir = out / f"best_response_seed{seed}"
    train_stage(load_config("compete", overrides={
        **base, "budget": br_budget, "league.opponents": champion}), br_dir)
    br_s = time.perf_counter() - t1
    best_response = _games(str(br_dir / "policy"), champion, games, EVAL_SEED + 10,
                           max_decisions)
    values = [r["rating"] for r in ratings if r["rating"] is not None]
    doc = {"seed": seed, "budget": budget, "br_budget": br_budget, "games": games,
           "max_decisions": max_decisions, "overrides": overrides or {},
           "champion": champion, "versus": versus, "ratings": ratings,
           "ratings_monotonic": bool(all(b >= a for a, b in itertools.pairwise(values))),
           "best_response": best_response,
           "wall_s": {"league": round(league_s, 1), "best_response": round(br_s, 1),
                      "total": round(time.perf_counter() - t0, 1)}}
    path = out / f"seed{seed}.json"
    path.write_text(json.dumps(doc, indent=1))
    return path


def pooled_rate(per_seed: list[dict[str, list[int]]], n_boot: int = 2000,
                seed: int = 0) -> dict[str, float]:
    """Points won over points played, pooled over seeds, with a 95 % interval from
    resampling seeds, then games within each."""
    rng = np.random.default_rng(seed)
    groups = [(np.asarray(g["won"], float), np.asarray(g["points"], float)) for g in per_seed]
    value = sum(w.sum() for w, _ in groups) / sum(p.sum() for _, p in groups)
    reps = np.empty(n_boot)
    for b in range(n_boot):
        won = played = 0.0
        for k in rng.integers(0, len(groups), len(groups)):
            w, p = groups[k]
            pick = rng.integers(0, len(w), len(w))
            won += w[pick].sum()
            played += p[pick].sum()
        reps[b] = won / played if played else np.nan
    low, high = np.nanpercentile(reps, [2.5, 97.5])
    return {"value": float(value), "low": float(low), "high": float(high)}


def report(out: Path, games: int, max_decisions: int = 20_000,
           figures: Path | None = None) -> dict[str, Any]:
    """Pool the seeds' JSON in ``out``, play the cross-play matrix, draw the figures, write
    ``out/compete_study.json``."""
    from rallysim.eval.crossplay import crossplay, heatmap

    seeds = [json.loads(p.read_text()) for p in sorted(out.glob("seed*.json"))]
    if not seeds:
        raise FileNotFoundError(f"no seed*.json in {out}: run the seed step first")
    pooled = {f"champion_vs_{name}": pooled_rate([s["versus"][name]["per_game"]
                                                  for s in seeds]) for name in OPPONENTS}
    pooled["best_response"] = pooled_rate([s["best_response"]["per_game"] for s in seeds])
    best = max(seeds, key=lambda s: s["versus"]["scripted"]["point_win_rate"]["value"])
    names = ["random", "scripted", "hrl", "mono", best["champion"]]
    t0 = time.perf_counter()
    matrix = crossplay(names, games, EVAL_SEED + 100, max_decisions, say=say_stderr)
    result = {
        "kind": "compete_study", "opponents": list(OPPONENTS),
        "seeds": [_seed_row(s) for s in seeds], "pooled": pooled,
        "targets": TARGETS, "best_seed": best["seed"],
        "checks": _checks(seeds, pooled),
        "crossplay": {**matrix, "wall_s": round(time.perf_counter() - t0, 1)},
        "settings": {k: seeds[0][k] for k in ("budget", "br_budget", "games",
                                               "max_decisions", "overrides")},
    }
    (out / "compete_study.json").write_text(json.dumps(result, indent=1))
    if figures is not None:
        figures.mkdir(parents=True, exist_ok=True)
        heatmap(matrix, figures / "compete_crossplay.png")
        _rating_figure(seeds, figures / "compete_ratings.png")
        _exploitability_figure(seeds, pooled, figures / "compete_exploitability.png")
    return result


def _seed_row(s: dict[str, Any]) -> dict[str, Any]:
    return {"seed": s["seed"], "champion": s["champion"],
            **{f"vs_{n}": s["versus"][n]["point_win_rate"] for n in OPPONENTS},
            "game_win_vs_scripted": s["versus"]["scripted"]["game_win_rate"],
            "best_response": s["best_response"]["point_win_rate"],
            "ratings": s["ratings"], "ratings_monotonic": s["ratings_monotonic"],
            "wall_s": s["wall_s"]}


def _checks(seeds: list[dict[str, Any]], pooled: dict[str, Any]) -> dict[str, bool]:
    worst = {n: min(s["versus"][n]["point_win_rate"]["value"] for s in seeds)
             for n in OPPONENTS}
    return {
        "champion_wins_80pct_vs_scripted_pooled": pooled["champion_vs_scripted"]["value"] >= 0.8,
        "champion_wins_80pct_vs_hrl_pooled": pooled["champion_vs_hrl"]["value"] >= 0.8,
        "every_seed_80pct_vs_scripted": worst["scripted"] >= 0.8,
        "every_seed_80pct_vs_hrl": worst["hrl"] >= 0.8,
        "best_response_at_most_60pct": pooled["best_response"]["value"] <= 0.6,
        "ratings_monotonic_in_2_of_3": sum(s["ratings_monotonic"] for s in seeds) >= 2,
    }


def _figure(width: float, height: float) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=100)
    FigureCanvasAgg(fig)
    return fig


def _rating_figure(seeds: list[dict[str, Any]], path: Path) -> None:
    fig = _figure(6, 3.6)
    ax = fig.add_subplot()
    for s in seeds:
        rows = [r for r in s["ratings"] if r["rating"] is not None]
        ax.plot([r["turns"] / 1000 for r in rows], [r["rating"] for r in rows], marker="o",
                label=f"seed {s['seed']}")
    ax.set_xlabel("learner turns when snapshotted (thousands)")
    ax.set_ylabel("OpenSkill ordinal vs the ladder")
    ax.set_title("Snapshot ratings against the fixed ladder")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)


def _exploitability_figure(seeds: list[dict[str, Any]], pooled: dict[str, Any],
                           path: Path) -> None:
    fig = _figure(6, 3.6)
    ax = fig.add_subplot()
    rows = [(f"seed {s['seed']}", s["best_response"]["point_win_rate"]) for s in seeds]
    rows.append(("pooled", pooled["best_response"]))
    for i, (_, e) in enumerate(rows):
        ax.errorbar(i, e["value"], yerr=[[e["value"] - e["low"]], [e["high"] - e["value"]]],
                    fmt="o", capsize=4)
    ax.axhline(0.6, color="red", linestyle="--", label="target: at most 0.6")
    ax.axhline(0.5, color="grey", linestyle=":", label="even")
    ax.set_xticks(range(len(rows)), [r[0] for r in rows])
    ax.set_ylim(0, 1)
    ax.set_ylabel("best response's point-win rate")
    ax.set_title("Exploitability: a best response against each champion")
    ax.legend()
    fig.tight_layout()
    fig.savefig(path)


# -- docs ---------------------------------------------------------------------------------------
def _cell(e: dict[str, float] | None) -> str:
    return "—" if e is None or e.get("value") is None else (
        f"{e['value']:.3f} [{e['low']:.3f}, {e['high']:.3f}]")


def render(result: dict[str, Any]) -> str:
    """The study's tables for docs/competitive.md."""
    st, opponents = result["settings"], result["opponents"]
    lines = [
        f"{len(result['seeds'])} training seeds; league budget {st['budget']:,} turns, best "
        f"response {st['br_budget']:,} turns; {st['games']} evaluation games per pair; games "
        f"stopped after {st['max_decisions']:,} decisions.",
        "",
        "| seed | " + " | ".join(f"champion vs {n}" for n in opponents)
        + " | best response vs champion | snapshot ratings rise |",
        "|---|" + "---|" * (len(opponents) + 2),
    ]
    for s in result["seeds"]:
        lines.append(f"| {s['seed']} | " + " | ".join(_cell(s[f"vs_{n}"]) for n in opponents)
                     + f" | {_cell(s['best_response'])} | "
                     f"{'yes' if s['ratings_monotonic'] else 'no'} |")
    p = result["pooled"]
    lines.append("| pooled | " + " | ".join(_cell(p[f"champion_vs_{n}"]) for n in opponents)
                 + f" | {_cell(p['best_response'])} | |")
    lines += ["", "Snapshot ratings (OpenSkill ordinal against the fixed ladder), oldest first:",
              ""]
    strict = 0
    for s in result["seeds"]:
        values = [r["rating"] for r in s["ratings"] if r["rating"] is not None]
        strict += all(b > a for a, b in itertools.pairwise(values))
        lines.append(f"- seed {s['seed']}: {', '.join(f'{v:.2f}' for v in values)}")
    lines += ["", f"Never falling on {sum(s['ratings_monotonic'] for s in result['seeds'])} of "
              f"{len(result['seeds'])} seeds; strictly rising on {strict}."]
    cp = result["crossplay"]
    names = [_short(n, result) for n in cp["players"]]
    lines += ["", f"Cross-play (point-win rate of row against column, {cp['games']} games per "
              "pair):", "", "| | " + " | ".join(names) + " |",
              "|---|" + "---|" * len(names)]
    for i, row in enumerate(cp["point_win_rate"]):
        lines.append(f"| {names[i]} | " + " | ".join(_cell(c) for c in row) + " |")
    lines += ["", "Checks: " + ", ".join(f"`{k}` **{'yes' if v else 'no'}**"
                                         for k, v in result["checks"].items()) + ".", ""]
    return "\n".join(lines)


def _short(name: str, result: dict[str, Any]) -> str:
    return f"champion (seed {result['best_seed']})" if "/" in name else name


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="step", required=True)
    one = sub.add_parser("seed", help="one seed's champion, ratings and best response")
    one.add_argument("--seed", type=int, required=True)
    rep = sub.add_parser("report", help="pool the seeds, cross-play, figures, JSON")
    rep.add_argument("--figures", type=Path, default=None)
    for p in (one, rep):
        p.add_argument("--out", type=Path, required=True)
        p.add_argument("--games", type=int, default=32)
        p.add_argument("--max-decisions", type=int, default=20_000)
    one.add_argument("--budget", type=int, default=200_000)
    one.add_argument("--br-budget", type=int, default=230_000,
                     help="best response turns (about 5M decisions at ~22 per turn)")
    one.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE")
    args = parser.parse_args(argv)
    if args.step == "seed":
        from rallysim.train.config import parse_overrides

        path = run_seed(args.seed, args.out, args.budget, args.br_budget, args.games,
                        args.max_decisions, parse_overrides(args.set))
        print(f"wrote {path}")
    else:
        result = report(args.out, args.games, args.max_decisions, args.figures)
        print(render(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
