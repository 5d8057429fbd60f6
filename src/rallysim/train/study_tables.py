"""Markdown tables of the research studies' JSON, for the docs' generated blocks.

The studies themselves (training runs, games, figures) live outside the package, in the
repository's ``experiments/``; what they write is committed under ``docs/data/`` and rendered
here, so that ``rallysim.train.results_doc`` can check the docs against it with the library
alone. ``RENDERERS`` maps a JSON's ``kind`` to the function that renders it.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rallysim.eval.stats import interval_cell


def number_cell(value: float | None, digits: int = 3) -> str:
    """A number as a table cell (``—`` where undefined)."""
    return "—" if value is None else f"{value:.{digits}f}"


def ci_cell(e: dict[str, float] | None) -> str:
    """A rate and its 95 % interval as a table cell (``—`` where undefined)."""
    return interval_cell(None if e is None or e.get("value") is None else e, 3)


def render_compete_study(result: dict[str, Any]) -> str:
    """The competitive study's tables (``experiments/compete_study.py report``) for
    docs/competitive.md."""
    st, opponents = result["settings"], result["opponents"]
    cp, lad = result["crossplay"], result["ladder"]
    rungs = [r for r in cp["players"] if r in lad["players"]]
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
        lines.append(f"| {s['seed']} | " + " | ".join(ci_cell(s[f"vs_{n}"]) for n in opponents)
                     + f" | {ci_cell(s['best_response'])} | "
                     f"{'yes' if s['ratings_monotonic'] else 'no'} |")
    p = result["pooled"]
    lines.append("| pooled | " + " | ".join(ci_cell(p[f"champion_vs_{n}"]) for n in opponents)
                 + f" | {ci_cell(p['best_response'])} | |")
    lines += ["", f"The reference ladder, calibrated by a round-robin of {lad['games']} games "
              f"per pair (seed {lad['seed']}, each point a match), best first:", "",
              "| rung | mu | sigma | ordinal |", "|---|---|---|---|"]
    lines += [f"| {r['name']} | {r['mu']:.2f} | {r['sigma']:.2f} | {r['ordinal']:.2f} |"
              for r in lad["table"]]
    lines += ["", "Snapshot ratings (OpenSkill ordinal against the calibrated ladder held fixed, "
              f"{lad['games']} games against each rung, each point a match), oldest first, "
              "then the champion:", ""]
    for s in result["seeds"]:
        values = [r["rating"] for r in s["ratings"]]
        down = s["ratings_falls"]
        fell = (f"falls {len(down)} time{'s' if len(down) > 1 else ''}, by at most "
                f"{max(f['by'] for f in down):.2f} = "
                f"{max(f['sigmas'] for f in down):.2f} sigma of the difference" if down
                else "never falls")
        lines.append(f"- seed {s['seed']}: {', '.join(f'{v:.2f}' for v in values)}; champion "
                     f"{s['champion_rating']['rating']:.2f} ({fell})")
    rising = sum(s["ratings_monotonic"] for s in result["seeds"])
    clear = sum(not s["ratings_no_clear_fall"] for s in result["seeds"])
    lines += ["", f"Rising at every snapshot on {rising} of {len(result['seeds'])} seeds; a fall "
              f"of 2 sigma or more on {clear}.", "",
              "As logged during training (the previous rating: each game a match, the ladder at "
              "OpenSkill's defaults, 8 games per rung):", ""]
    for s in result["seeds"]:
        values = [r["rating"] for r in s["ratings_training"] if r["rating"] is not None]
        lines.append(f"- seed {s['seed']}: {', '.join(f'{v:.2f}' for v in values)}")
    lines += ["", "Each snapshot's and champion's point-win rate against each rung (the games "
              "of its rating):", "",
              "| player | turns | ordinal | " + " | ".join(rungs) + " |",
              "|---|---|---|" + "---|" * len(rungs)]
    for s in result["seeds"]:
        for m in [*s["snapshots"], {**s["champion_rating"], "champion": True}]:
            who = f"seed {s['seed']} {'champion' if m.get('champion') else 'snapshot'}"
            lines.append(f"| {who} | {m['turns']:,} | {m['rating']:.2f} | " + " | ".join(
                number_cell(m["versus"][r]["point_win_rate"]) for r in rungs) + " |")
    champions = [s["champion"] for s in result["seeds"]]
    index = [cp["players"].index(n) for n in [*rungs, *champions]]
    names = [*rungs, *(f"champion s{s['seed']}" for s in result["seeds"])]
    lines += ["", f"Cross-play of the ladder and the champions (point-win rate of row against "
              f"column, {cp['games']} games per pair):", "", "| | " + " | ".join(names) + " |",
              "|---|" + "---|" * len(names)]
    for k, i in enumerate(index):
        lines.append(f"| {names[k]} | "
                     + " | ".join(ci_cell(cp["point_win_rate"][i][j]) for j in index) + " |")
    lines += ["", f"The whole matrix ({len(cp['players'])} players: the ladder and every seed's "
              f"snapshots and champion; {len(cp['pairs'])} pairs played, players of different "
              "seeds only champion against champion) is `crossplay` in the JSON.", "",
              "Checks: " + ", ".join(f"`{k}` **{'yes' if v else 'no'}**"
                                     for k, v in result["checks"].items()) + ".", ""]
    return "\n".join(lines)


def render_compete_summary(result: dict[str, Any]) -> str:
    """The competitive study's ``summary`` step's tables for the docs."""
    st, opponents = result["settings"], result["opponents"]
    br = (f"best response {st['br_budget']:,} turns" if st["br_budget"]
          else "no best response")
    lines = [
        f"{len(result['seeds'])} training seeds of the `{result['player']}` player; league budget "
        f"{st['budget']:,} turns, {br}; {st['games']} evaluation games per pair; games "
        f"stopped after {st['max_decisions']:,} decisions. Point-win rate of each champion "
        "(mean rally in hits per point):", "",
        "| seed | " + " | ".join(f"champion vs {n}" for n in opponents)
        + " | snapshot ratings rise | wall (min) |",
        "|---|" + "---|" * (len(opponents) + 2)]
    for s in result["seeds"]:
        cells = [f"{ci_cell(s[f'vs_{n}'])} ({number_cell(s[f'rally_vs_{n}']['value'], 1)})"
                 for n in opponents]
        lines.append(f"| {s['seed']} | " + " | ".join(cells)
                     + f" | {'yes' if s['ratings_monotonic'] else 'no'} | "
                     f"{s['wall_s']['total'] / 60:.1f} |")
    lines.append("| pooled | " + " | ".join(ci_cell(result["pooled"][n]) for n in opponents)
                 + " | | |")
    ladder = ", ".join(f"`{r['name']}` {r['ordinal']:.2f}" for r in result["ladder"])
    lines += ["", f"Snapshot ratings (OpenSkill ordinal against the league's calibrated ladder, "
              f"each point a match, as the league logged them; the ladder: {ladder}), oldest "
              "first:", ""]
    for s in result["seeds"]:
        values = [r["rating"] for r in s["ratings"] if r["rating"] is not None]
        lines.append(f"- seed {s['seed']}: {', '.join(f'{v:.2f}' for v in values)}")
    lines += ["", "Checks: " + ", ".join(f"`{k}` **{'yes' if v else 'no'}**"
                                         for k, v in result["checks"].items()) + ".", ""]
    return "\n".join(lines)


def render_compete_flat(result: dict[str, Any]) -> str:
    """The flat competitive baseline's table (``experiments/compete_flat_study.py``) for
    docs/competitive.md."""
    st, opponents = result["settings"], result["opponents"]
    lines = [
        f"{len(result['seeds'])} training seeds; {st['budget']:,} decisions each, the actor "
        + ("started from random weights; " if st["init_policy"] == "none" else
           f"started from `{st['init_policy']}` (a cooperative Monolithic policy); ")
        + f"{st['games']} evaluation games per pair; games stopped after "
        f"{st['max_decisions']:,} decisions. Point-win rate of the flat champion against:",
        "",
        "| seed | " + " | ".join(opponents) + " | wall (min) |",
        "|---|" + "---|" * (len(opponents) + 1),
    ]
    for s in result["seeds"]:
        lines.append(f"| {s['seed']} | " + " | ".join(ci_cell(s[f"vs_{n}"]) for n in opponents)
                     + f" | {s['wall_s']['total'] / 60:.1f} |")
    lines.append("| pooled | " + " | ".join(ci_cell(result["pooled"][n]) for n in opponents)
                 + " | |")
    lines += ["", "Snapshot ratings (OpenSkill ordinal against the calibrated ladder, as the "
              "league logged them), oldest first:", ""]
    for s in result["seeds"]:
        values = [r["rating"] for r in s["ratings"] if r["rating"] is not None]
        lines.append(f"- seed {s['seed']}: {', '.join(f'{v:.2f}' for v in values)}")
    lines.append("")
    return "\n".join(lines)


# the low-level curves' measures: (key in the JSON, column title, digits)
LOW_CURVE_METRICS = (("mean_reward", "mean episode reward", 3),
                     ("median_error", "median landing error (m)", 2),
                     ("goal_correlation", "goal correlation (reachable goals)", 3))


def render_low_curves(doc: dict[str, Any]) -> str:
    """The low-level learning curves (``experiments/low_curves_study.py``): pooled point by
    point, then every seed's last evaluation."""
    head = " | ".join(title for _, title, _ in LOW_CURVE_METRICS)
    lines = [f"{doc['seeds']} training seeds per method; mean over seeds [95 % bootstrap "
             "interval, seeds resampled].", "",
             f"| method | decisions (M) | {head} |", "|---|---:|---|---|---|"]
    for m in doc["methods"].values():
        for p in m["pooled"]:
            cells = " | ".join(interval_cell(p[key], d) for key, _, d in LOW_CURVE_METRICS)
            lines.append(f"| {m['label']} | {p['decisions'] / 1e6:.2f} | {cells} |")
    lines += ["", "Each seed's last evaluation:", "",
              f"| method | seed | {head} | hit rate |", "|---|---:|---:|---:|---:|---:|"]
    for m in doc["methods"].values():
        for s, points in m["seeds"].items():
            last = points[-1]
            cells = " | ".join(number_cell(last[key], d) for key, _, d in LOW_CURVE_METRICS)
            lines.append(f"| {m['label']} | {s} | {cells} | {last['hit_rate']:.3f} |")
    return "\n".join(lines) + "\n"


# the reference returns' task measures: (title, digits)
REFERENCE_SCORE_NAMES = {"hit_rate": ("hit rate", 3),
                         "median_landing_error": ("median landing error (m)", 2),
                         "goal_correlation": ("goal correlation", 2),
                         "mean_angle_error": ("mean angle error (deg)", 1),
                         "mean_abs_speed_error": ("mean abs. speed error", 2)}


def _score_cell(key: str, value: dict[str, float] | None) -> str:
    title, digits = REFERENCE_SCORE_NAMES[key]
    return f"{title} {interval_cell(value, digits)}"


def render_reference_returns(doc: dict[str, Any]) -> str:
    """The reference returns (``experiments/reference_returns.py``): one row per task and
    algorithm."""
    lines = [f"{doc['episodes']} evaluation episodes per seed (deterministic policy); budgets "
             "in SB3 steps of the task's unit; mean [95 % bootstrap interval].", "",
             "| task | algorithm | budget | mean return | per seed | mean episode length "
             "| task measures | training wall (s, per seed) |",
             "|---|---|---:|---|---|---|---|---|"]
    for r in doc["rows"]:
        scores = "; ".join(_score_cell(k, v) for k, v in r["scores"].items()) or "—"
        per_seed = " / ".join(f"{x:.2f}" for x in r["per_seed_return"])
        walls = " / ".join(f"{w:.0f}" for w in r["train_wall_s"])
        ret = interval_cell(r["mean_return"], 2)
        length = interval_cell(r["mean_length"], 1)
        lines.append(f"| {r['task']} | {r['algo']} | {r['steps']:,} {r['unit']} | {ret} | "
                     f"{per_seed} | {length} | {scores} | {walls} |")
    return "\n".join(lines) + "\n"


# a JSON's ``kind`` -> what renders it
RENDERERS: dict[str, Callable[[dict[str, Any]], str]] = {
    "compete_study": render_compete_study,
    "compete_summary": render_compete_summary,
    "compete_flat": render_compete_flat,
    "low_curves": render_low_curves,
    "reference_returns": render_reference_returns,
}
