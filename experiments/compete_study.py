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

``report`` pools the seeds (a two-level bootstrap: seeds, then games); calibrates the reference
ladder (``rallysim.eval.ratings.calibrate``) and rates every seed's snapshots and champion
against it held fixed (``rate_against``, each point a match), from the league's pool on disk,
not the ratings logged during training; plays the cross-play matrix of the ladder and every
seed's snapshots and champion (within a seed every pair; across seeds, champion against
champion); draws the figures and writes ``OUT/compete_study.json`` and
``OUT/ladder_ratings.json``; the library renders that JSON's tables
(``rallysim.train.study_tables``: docs/competitive.md holds them between generated-block
markers, checked by a test like docs/results.md's).

    python -m experiments.compete_study seed --seed 0 --out runs/compete_study
    python -m experiments.compete_study report --out runs/compete_study

``seed --player humanlike`` trains HUMAN-LIKE players (``--br-budget 0``: no best response);
``summary`` pools such seeds without the cross-play (``compete_summary.json``).
"""

from __future__ import annotations

import argparse
import itertools
import json
import math
import pickle
import sys
import time
from pathlib import Path
from typing import Any

import numpy as np

from rallysim.train.progress import say_stderr
from rallysim.train.study_tables import render_compete_study as render
from rallysim.train.study_tables import render_compete_summary as render_summary

EVAL_SEED = 20_000  # evaluation games' seeds: apart from every training seed
OPPONENTS = ("scripted", "hrl")
TARGETS = {"champion_vs_scripted": 0.8, "champion_vs_hrl": 0.8, "best_response": 0.6}


def play_summary(a: str, b: str, games: int, seed: int, max_decisions: int,
                 player: str = "simple") -> dict[str, Any]:
    """``games`` games of agent ``a`` against ``b`` (players of the kind ``player``):
    ``summarise``'s rates with 95 % intervals, and per game the points ``a`` won and the
    points played (``per_game``, what ``pooled_rate`` pools)."""
    from rallysim.eval.agents import agent
    from rallysim.eval.competitive import play_games, summarise

    played = play_games(agent(a, player), agent(b, player), games, seed,
                        max_decisions=max_decisions)
    out = summarise(played, seed=seed)
    out["per_game"] = {"won": played.points[:, 0].tolist(),
                       "points": played.points.sum(axis=1).tolist()}
    return out


def run_seed(seed: int, out: Path, budget: int, br_budget: int, games: int,
             max_decisions: int = 20_000, overrides: dict[str, Any] | None = None,
             player: str = "simple") -> Path:
    """One seed's champion, its games, its ratings and its best response (see the module;
    ``br_budget`` 0: none), for players of the kind ``player``; returns the seed's JSON."""
    from rallysim.train.config import load_config
    from rallysim.train.runner import train_stage

    out.mkdir(parents=True, exist_ok=True)
    t0 = time.perf_counter()
    league_dir = out / f"league_seed{seed}"
    base = {"seed": seed, "player": player, "league.max_decisions": max_decisions,
            **(overrides or {})}
    train_stage(load_config("compete", overrides={**base, "budget": budget}), league_dir)
    champion = str(league_dir / "policy")
    league_s = time.perf_counter() - t0
    versus = {name: play_summary(champion, name, games, EVAL_SEED + i, max_decisions, player)
              for i, name in enumerate(OPPONENTS)}
    ratings = [{"turns": h["turns"], "rating": h["rating"]} for h in league_history(league_dir)]
    t1 = time.perf_counter()
    best_response = None
    if br_budget:
        br_dir = out / f"best_response_seed{seed}"
        train_stage(load_config("compete", overrides={
            **base, "budget": br_budget, "league.opponents": champion}), br_dir)
    br_s = time.perf_counter() - t1
    if br_budget:
        best_response = play_summary(str(br_dir / "policy"), champion, games, EVAL_SEED + 10,
                                     max_decisions, player)
    values = [r["rating"] for r in ratings if r["rating"] is not None]
    doc = {"seed": seed, "player": player, "budget": budget, "br_budget": br_budget, "games": games,
           "max_decisions": max_decisions, "overrides": overrides or {},
           "champion": champion, "versus": versus, "ratings": ratings,
           "ratings_monotonic": bool(all(b >= a for a, b in itertools.pairwise(values))),
           "best_response": best_response,
           "wall_s": {"league": round(league_s, 1), "best_response": round(br_s, 1),
                      "total": round(time.perf_counter() - t0, 1)}}
    path = out / f"seed{seed}.json"
    path.write_text(json.dumps(doc, indent=1))
    return path


def league_history(run: Path) -> list[dict[str, Any]]:
    """A league run's snapshots as its newest checkpoint records them, oldest first: their
    ``turns`` (units of the stage's budget) and ``rating`` (None when unrated)."""
    return [{"turns": h["turns"], "rating": h.get("rating")}
            for h in league_state(run)["history"]]


def league_state(run: Path) -> dict[str, Any]:
    """What a league run's newest checkpoint holds of its league (``League.state``)."""
    from rallysim.train import checkpoint as ckpt

    return json.loads(ckpt.latest_checkpoint(run).read_text())["stage_state"]


def load_seeds(out: Path) -> list[dict[str, Any]]:
    """The seeds' JSON in ``out`` (``seed*.json``), by seed; at least one."""
    seeds = [json.loads(p.read_text()) for p in sorted(out.glob("seed*.json"))]
    if not seeds:
        raise FileNotFoundError(f"no seed*.json in {out}: run the seed step first")
    return seeds


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


def snapshots(league_dir: Path) -> list[dict[str, Any]]:
    """A league's snapshots, oldest first: ``{"name": path prefix, "turns"}``."""
    files = sorted((Path(league_dir) / "pool").glob("snapshot_*.json"))
    return [{"name": str(f.with_suffix("")), "turns": int(f.stem.split("_")[1])}
            for f in files]


def _champion_turns(champion: str) -> int | None:
    doc = json.loads(Path(champion).with_suffix(".json").read_text())
    steps = (doc.get("metadata") or {}).get("steps")
    return int(steps) if steps is not None else None


def rate_snapshots(seeds: list[dict[str, Any]], games: int, seed: int, max_decisions: int,
                   played: dict[tuple[str, str], Any] | None = None,
                   say: Any = None) -> dict[str, Any]:
    """The reference ladder calibrated (a round-robin of ``games`` games per pair), then
    every snapshot and champion of every seed rated against it held fixed
    (``rate_against``: each point a match), then the games between the snapshots and champion
    of each seed and between the seeds' champions. All games with ``seed``. Returns the
    calibrated ladder, the ratings, each seed's rated players and every game played."""
    from rallysim.eval.agents import agent
    from rallysim.eval.crossplay import play_pairs
    from rallysim.eval.ratings import (
        REFERENCE_LADDER,
        Ratings,
        calibrate,
        counts,
        rate_against,
        rate_points,
    )

    ladder = list(REFERENCE_LADDER)
    common = {"games": games, "seed": seed, "max_decisions": max_decisions}
    played = {} if played is None else played
    calibrated, ladder_games = calibrate(ladder, say=say, played=played, **common)
    played.update(ladder_games)
    ratings = Ratings.from_json(calibrated.to_json())
    groups = {}
    for s in seeds:
        members = [*snapshots(Path(s["champion"]).parent),
                   {"name": s["champion"], "turns": _champion_turns(s["champion"]),
                    "champion": True}]
        for m in members:
            if all((m["name"], rung) in played for rung in ladder):  # reuse: rate, no replay
                result = {rung: played[m["name"], rung] for rung in ladder}
                rate_points(ratings, [(m["name"], r, g) for r, g in result.items()],
                            fixed=ladder)
            else:
                result = rate_against(ratings, m["name"], agent(m["name"]), ladder, say=say,
                                      **common)
            played.update({(m["name"], rung): g for rung, g in result.items()})
            mu, sigma = ratings.get(m["name"])
            m.update(rating=ratings.ordinal(m["name"]), mu=mu, sigma=sigma,
                     versus={rung: counts(g) for rung, g in result.items()})
        names = [m["name"] for m in members]
        play_pairs(names, list(itertools.combinations(names, 2)), say=say, played=played,
                   **common)
        groups[s["seed"]] = members
    champions = [s["champion"] for s in seeds]
    play_pairs(champions, list(itertools.combinations(champions, 2)), say=say, played=played,
               **common)
    return {"ladder": calibrated, "ratings": ratings, "groups": groups, "played": played}


def report(out: Path, games: int, max_decisions: int = 20_000,
           figures: Path | None = None, crossplay_games: int = 16) -> dict[str, Any]:
    """Pool the seeds' JSON in ``out``, calibrate the ladder, rate every seed's snapshots
    against it, play the cross-play matrix (the ladder, each seed's snapshots and champion),
    draw the figures, write ``out/compete_study.json`` and ``out/ladder_ratings.json``."""
    from rallysim.eval.crossplay import heatmap, matrix, submatrix
    from rallysim.eval.ratings import REFERENCE_LADDER

    seeds = load_seeds(out)
    odd = [s["seed"] for s in seeds
           if s.get("player", "simple") != "simple" or s["best_response"] is None]
    if odd:
        raise ValueError(f"seed(s) {odd} in {out} are not SIMPLE or have no best response: the "
                         "report rates and cross-plays SIMPLE players against the SIMPLE "
                         "ladder; pool them with the summary step")
    pooled = {f"champion_vs_{name}": pooled_rate([s["versus"][name]["per_game"]
                                                  for s in seeds]) for name in OPPONENTS}
    pooled["best_response"] = pooled_rate([s["best_response"]["per_game"] for s in seeds])
    best = max(seeds, key=lambda s: s["versus"]["scripted"]["point_win_rate"]["value"])
    t0 = time.perf_counter()
    cp_seed = EVAL_SEED + 100
    # the games are kept (pickled Games) so that a report drawn again replays none of them
    cache = out / f"crossplay_games_{crossplay_games}_{cp_seed}_{max_decisions}.pkl"
    played = pickle.loads(cache.read_bytes()) if cache.is_file() else {}
    rated = rate_snapshots(seeds, crossplay_games, cp_seed, max_decisions, played,
                           say=say_stderr)
    cache.write_bytes(pickle.dumps(rated["played"]))
    ladder = list(REFERENCE_LADDER)
    ladder_json = {**rated["ladder"].to_json(), "table": rated["ladder"].table(),
                   "games": crossplay_games, "seed": cp_seed, "max_decisions": max_decisions,
                   "unit": "point"}
    groups = rated["groups"]
    names = [*ladder, *(m["name"] for s in seeds for m in groups[s["seed"]])]
    full = matrix(names, rated["played"], crossplay_games, cp_seed, max_decisions,
                  ratings=rated["ratings"])
    labels = {m["name"]: _member_label(s["seed"], m) for s in seeds for m in groups[s["seed"]]}
    rows = []
    for s in seeds:
        row = _seed_row(s)
        row["snapshots"] = [{k: m[k] for k in ("name", "turns", "rating", "mu", "sigma",
                                                  "versus")} for m in groups[s["seed"]]
                            if not m.get("champion")]
        champ = groups[s["seed"]][-1]
        row["champion_rating"] = {k: champ[k] for k in ("turns", "rating", "mu", "sigma",
                                                          "versus")}
        row["ratings"] = [{"turns": m["turns"], "rating": m["rating"]} for m in row["snapshots"]]
        row["ratings_falls"] = falls(row["snapshots"])
        row["ratings_monotonic"] = not row["ratings_falls"]
        row["ratings_no_clear_fall"] = all(f["sigmas"] < 2.0 for f in row["ratings_falls"])
        rows.append(row)
    result = {
        "kind": "compete_study", "opponents": list(OPPONENTS),
        "seeds": rows, "pooled": pooled,
        "targets": TARGETS, "best_seed": best["seed"],
        "checks": _checks(seeds, pooled, rows),
        "ladder": ladder_json,
        "crossplay": {**full, "labels": labels,
                      "wall_s": round(time.perf_counter() - t0, 1)},
        "settings": {**{k: seeds[0][k] for k in ("budget", "br_budget", "games",
                                                  "max_decisions", "overrides")},
                     "crossplay_games": crossplay_games},
    }
    (out / "compete_study.json").write_text(json.dumps(result, indent=1))
    (out / "ladder_ratings.json").write_text(json.dumps(ladder_json, indent=1))
    if figures is not None:
        figures.mkdir(parents=True, exist_ok=True)
        top = [*names[:len(ladder)], *(s["champion"] for s in seeds)]
        heatmap(submatrix(full, top), figures / "compete_crossplay.png", labels=labels,
                title="the ladder and the champions")
        for s in seeds:
            group = [*names[:len(ladder)], *(m["name"] for m in groups[s["seed"]])]
            heatmap(submatrix(full, group), figures / f"compete_crossplay_seed{s['seed']}.png",
                    labels=labels, title=f"the ladder and seed {s['seed']}'s snapshots")
        _rating_figure(rows, ladder_json, figures / "compete_ratings.png")
        _exploitability_figure(seeds, pooled, figures / "compete_exploitability.png")
    return result


SUMMARY = "compete_summary"


def summary(out: Path) -> dict[str, Any]:
    """Pool the seeds' JSON in ``out`` without ``report``'s cross-play and re-rating (for
    players whose games are slow, such as HUMAN-LIKE's): each champion's point-win rate
    against ``OPPONENTS`` per seed and pooled (seeds, then games), the snapshots' ratings as
    the league logged them; writes ``out/compete_summary.json``."""
    seeds = load_seeds(out)
    first = seeds[0]
    for key in ("player", "budget", "br_budget", "games", "max_decisions", "overrides"):
        differ = sorted({json.dumps(s.get(key)) for s in seeds})
        if len(differ) > 1:
            raise ValueError(f"the seeds in {out} differ in {key} ({', '.join(differ)}): pool "
                             "seeds of one study only")
    result = {
        "kind": SUMMARY, "player": first.get("player", "simple"), "opponents": list(OPPONENTS),
        "settings": {k: first[k] for k in ("budget", "br_budget", "games", "max_decisions",
                                           "overrides")},
        "pooled": {n: pooled_rate([s["versus"][n]["per_game"] for s in seeds])
                   for n in OPPONENTS},
        "seeds": [{"seed": s["seed"], "champion": s["champion"], "ratings": s["ratings"],
                   "ratings_monotonic": s["ratings_monotonic"], "wall_s": s["wall_s"],
                   **{f"vs_{n}": s["versus"][n]["point_win_rate"] for n in OPPONENTS},
                   **{f"rally_vs_{n}": s["versus"][n]["mean_rally"] for n in OPPONENTS}}
                  for s in seeds],
    }
    result["ladder"] = league_ladder(out / f"league_seed{first['seed']}")
    pooled = result["pooled"]
    result["checks"] = {
        **{f"champion_wins_80pct_vs_{n}_pooled":
           pooled[n]["value"] >= TARGETS[f"champion_vs_{n}"] for n in OPPONENTS},
        f"ratings_monotonic_in_2_of_{len(seeds)}": sum(s["ratings_monotonic"] for s in seeds)
        >= 2}
    (out / f"{SUMMARY}.json").write_text(json.dumps(result, indent=1))
    return result


def league_ladder(run: Path) -> list[dict[str, Any]]:
    """The reference ladder as a league run calibrated it (its newest checkpoint's ratings,
    the snapshots left out), best first: ``Ratings.table`` rows."""
    from rallysim.eval.ratings import Ratings

    ratings = Ratings.from_json(league_state(run)["ratings"])
    return ratings.table([n for n in ratings.players if not n.startswith("snapshot_")])


def falls(snaps: list[dict[str, Any]]) -> list[dict[str, float]]:
    """Each time a snapshot's ordinal is below its predecessor's: by how much, and in sigmas
    of the difference (``sqrt(sigma_a^2 + sigma_b^2)``; under 2: not a clear fall)."""
    out = []
    for a, b in itertools.pairwise(snaps):
        if b["rating"] < a["rating"]:
            by = a["rating"] - b["rating"]
            out.append({"from_turns": a["turns"], "to_turns": b["turns"], "by": by,
                        "sigmas": by / math.hypot(a["sigma"], b["sigma"])})
    return out


def _member_label(seed: int, m: dict[str, Any]) -> str:
    turns = "?" if m["turns"] is None else f"{m['turns'] / 1000:.0f}k"
    return f"s{seed} champion {turns}" if m.get("champion") else f"s{seed} snap {turns}"


def _seed_row(s: dict[str, Any]) -> dict[str, Any]:
    return {"seed": s["seed"], "champion": s["champion"],
            **{f"vs_{n}": s["versus"][n]["point_win_rate"] for n in OPPONENTS},
            "game_win_vs_scripted": s["versus"]["scripted"]["game_win_rate"],
            "best_response": s["best_response"]["point_win_rate"],
            "ratings": s["ratings"], "ratings_monotonic": s["ratings_monotonic"],
            "ratings_training": s["ratings"],
            "ratings_training_monotonic": s["ratings_monotonic"],
            "wall_s": s["wall_s"]}


def _checks(seeds: list[dict[str, Any]], pooled: dict[str, Any],
            rows: list[dict[str, Any]]) -> dict[str, bool]:
    worst = {n: min(s["versus"][n]["point_win_rate"]["value"] for s in seeds)
             for n in OPPONENTS}
    return {
        "champion_wins_80pct_vs_scripted_pooled": pooled["champion_vs_scripted"]["value"] >= 0.8,
        "champion_wins_80pct_vs_hrl_pooled": pooled["champion_vs_hrl"]["value"] >= 0.8,
        "every_seed_80pct_vs_scripted": worst["scripted"] >= 0.8,
        "every_seed_80pct_vs_hrl": worst["hrl"] >= 0.8,
        "best_response_at_most_60pct": pooled["best_response"]["value"] <= 0.6,
        "ratings_monotonic_in_2_of_3": sum(r["ratings_monotonic"] for r in rows) >= 2,
        "ratings_never_fall_by_2_sigma_in_2_of_3": sum(r["ratings_no_clear_fall"]
                                                       for r in rows) >= 2,
    }


def _figure(width: float, height: float) -> Any:
    from matplotlib.backends.backend_agg import FigureCanvasAgg
    from matplotlib.figure import Figure

    fig = Figure(figsize=(width, height), dpi=100)
    FigureCanvasAgg(fig)
    return fig


def _rating_figure(rows: list[dict[str, Any]], ladder: dict[str, Any], path: Path) -> None:
    fig = _figure(8, 4.2)
    ax = fig.add_subplot()
    for r in rows:
        snaps = r["snapshots"]
        line = ax.errorbar([m["turns"] / 1000 for m in snaps], [m["rating"] for m in snaps],
                           yerr=[m["sigma"] for m in snaps], marker="o", capsize=3,
                           label=f"seed {r['seed']}")
        c = r["champion_rating"]
        if c["turns"] is not None:
            ax.plot([c["turns"] / 1000], [c["rating"]], marker="*", markersize=12,
                    color=line[0].get_color(), linestyle="none")
    for row in ladder["table"]:
        ax.axhline(row["ordinal"], color="grey", linestyle=":", linewidth=0.8)
        ax.text(0.005, row["ordinal"], row["name"], transform=ax.get_yaxis_transform(),
                ha="left", va="bottom", fontsize=7, color="grey")
    ax.set_xlabel("learner turns when snapshotted (thousands); star: the champion")
    ax.set_ylabel("OpenSkill ordinal (mu - 3 sigma)")
    ax.set_title("Snapshot ratings against the calibrated ladder (dotted), bars: 1 sigma",
                 fontsize=10)
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0))
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
def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    sub = parser.add_subparsers(dest="step", required=True)
    one = sub.add_parser("seed", help="one seed's champion, ratings and best response")
    one.add_argument("--seed", type=int, required=True)
    rep = sub.add_parser("report", help="pool the seeds, cross-play, figures, JSON")
    light = sub.add_parser("summary", help="pool the seeds' games and logged ratings only "
                                           "(no cross-play), JSON")
    light.add_argument("--out", type=Path, required=True)
    rep.add_argument("--figures", type=Path, default=None)
    rep.add_argument("--crossplay-games", type=int, default=16,
                     help="games per pair of the ladder's calibration, the snapshots' ratings "
                          "and the cross-play matrix")
    for p in (one, rep):
        p.add_argument("--out", type=Path, required=True)
        p.add_argument("--games", type=int, default=32)
        p.add_argument("--max-decisions", type=int, default=20_000)
    one.add_argument("--budget", type=int, default=200_000)
    one.add_argument("--br-budget", type=int, default=230_000,
                     help="best response turns (about 5M decisions at ~22 per turn; 0: none)")
    one.add_argument("--player", choices=("simple", "humanlike"), default="simple")
    one.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE")
    args = parser.parse_args(argv)
    if args.step == "seed":
        from rallysim.train.config import parse_overrides

        path = run_seed(args.seed, args.out, args.budget, args.br_budget, args.games,
                        args.max_decisions, parse_overrides(args.set), args.player)
        print(f"wrote {path}")
    elif args.step == "summary":
        print(render_summary(summary(args.out)))
    else:
        result = report(args.out, args.games, args.max_decisions, args.figures,
                        args.crossplay_games)
        print(render(result))
    return 0


if __name__ == "__main__":
    sys.exit(main())
