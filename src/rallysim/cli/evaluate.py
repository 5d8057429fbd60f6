"""``rallysim evaluate``: rally statistics of HRL, Random High-level and Monolithic; of a
HUMAN-LIKE low level and its 3-D rally; or, with ``--mode competitive``, players in games
against each other."""

from __future__ import annotations

import argparse
import contextlib
import sys
import time
from pathlib import Path

from rallysim.cli.common import (
    DeprecatedName,
    UsageError,
    add_command,
    add_shuttle,
    hits_cap,
    numpy_policies,
    positive,
    say_deprecated,
    seed_value,
)
from rallysim.cli.paths import out_file

# cooperative defaults (the paper's cap: rallysim.eval.rally_eval.PAPER_CAP). One evaluation
# seed keeps a look at the shipped policies to seconds (docs/getting-started.md); each mean is
# printed with its 95 % interval, and --seeds 3 narrows it.
RALLIES, SEEDS, EPISODES, PAPER_CAP = 100, 1, 500, 50
# evaluate --mode competitive: the defaults of its options (None on the parser, so that an
# option given in cooperative mode is seen and refused)
COMPETITIVE_GAMES = 16
COMPETITIVE_MAX_DECISIONS = 200_000  # rallysim.eval.competitive.DEFAULT_MAX_DECISIONS


DESCRIPTION = """\
Cooperative (the default): rally lengths of the paper's three methods, HRL
(the high level's goals for the low level), Random High-level (random goals
for the same low level) and Monolithic (one policy for every decision), with
95 % intervals, then the low level alone on fresh serves. With --player
humanlike: a HUMAN-LIKE low level on fresh serves and the 3-D rally it plays.
With --mode competitive: --players in games against each other."""


def add_parser(sub: argparse._SubParsersAction) -> None:
    from rallysim.train.players import PLAYERS  # (a light module: no torch, SB3 or YAML)

    players = tuple(PLAYERS)
    ev = add_command(sub, "evaluate", "rally statistics of HRL, Random High-level, "
                     "Monolithic; or of a HUMAN-LIKE low level (--player humanlike)",
                     description=DESCRIPTION)
    ev.add_argument("--player", choices=players, default=None,
                    help="humanlike: the low level's hit rate, angle and speed errors on "
                         "--episodes serves, and the 3-D rally it plays; with --mode "
                         "competitive, games of HUMAN-LIKE players (default: the player --low "
                         "was trained for, else the one the --players' policy files play, "
                         "else simple)")
    ev.add_argument("--env", choices=players, dest="player", action=DeprecatedName,
                    new="--player", help="deprecated name of --player")
    ev.set_defaults(deprecated=[])
    ev.add_argument("--pretrained", action="store_true",
                    help="the shipped policies (the default for any policy not given)")
    ev.add_argument("--low", default="pretrained",
                    help="low level: path prefix or pretrained (humanlike: or scripted)")
    ev.add_argument("--high", help="high level: path prefix or pretrained (the default); "
                                   "humanlike: also centre or random")
    ev.add_argument("--episodes", type=positive, default=EPISODES,
                    help="fresh serves the low level returns (its low_level scores)")
    ev.add_argument("--mono", default="pretrained", help="Monolithic: path prefix or pretrained")
    ev.add_argument("--rallies", type=positive, default=RALLIES,
                    help="rallies per seed and method")
    ev.add_argument("--seeds", type=positive, default=SEEDS, help="evaluation seeds")
    ev.add_argument("--cap", type=hits_cap, default=PAPER_CAP,
                    help="SIMPLE rallies end at this many hits (default 50, the paper's; up "
                         "to 100000)")
    ev.add_argument("--json", type=out_file, help="write every number here")
    add_shuttle(ev)
    ev.add_argument("--mode", choices=("cooperative", "competitive"), default="cooperative",
                    help="cooperative (default): rally statistics as above; competitive: "
                         "--players in games against each other")
    ev.add_argument("--players", nargs="+", metavar="NAME",
                    help="competitive: random, scripted, hrl, mono (SIMPLE), simple_compete "
                         "(SIMPLE) or a policy path prefix, players of the kind --player; two: "
                         "the first's point-win and game-win rates; three or more: the "
                         "cross-play matrix and OpenSkill ratings")
    ev.add_argument("--games", type=positive,
                    help=f"competitive: games per pair (default {COMPETITIVE_GAMES})")
    ev.add_argument("--seed", type=seed_value, help="competitive: the games' seed (default 0)")
    ev.add_argument("--max-decisions", dest="max_decisions", type=positive,
                    help="competitive: a game still going after this many decisions stops "
                         f"and counts by its points (default {COMPETITIVE_MAX_DECISIONS})")
    ev.add_argument("--figure", type=out_file,
                    help="competitive, 3 or more players: the cross-play heat map (PNG)")
    ev.set_defaults(run=run)


def _rally_line(name: str, s: dict) -> str:
    return (f"{name:18s} mean rally {s['mean']['value']:6.2f} "
            f"[{s['mean']['low']:.2f}, {s['mean']['high']:.2f}]  median "
            f"{s['median']['value']:5.1f}  reaching {s['cap']}: {s['capped']}/{s['n_rallies']}")


def _losses_line(name: str, s: dict) -> str:
    def pct(key: str, digits: int = 1) -> str:
        e = s[key]
        v, lo, hi = (100 * e[k] for k in ("value", "low", "high"))
        return f"{v:.{digits}f} % [{lo:.{digits}f}, {hi:.{digits}f}]"

    return (f"{name:18s} serve returned {pct('serve_return')}, first return missed "
            f"{pct('first_return_miss')}, lost before hit 2 {pct('early_loss')}, miss rate "
            f"per later hit {pct('later_miss_rate', 2)}")


def _seeds(args: argparse.Namespace) -> str:
    return f"{args.seeds} evaluation seed{'s' if args.seeds > 1 else ''}"


def _evaluate_humanlike(args: argparse.Namespace) -> dict:
    """A HUMAN-LIKE low level on fresh serves and the 3-D rally it plays."""
    from rallysim.eval.humanlike_eval import evaluate_humanlike_player, rally_goals
    from rallysim.policies.registry import resolve

    if args.cap != PAPER_CAP:
        raise UsageError("--cap applies to SIMPLE rallies only")
    high = args.high or "pretrained"
    # a bad policy name or file fails here, before the header and the long work
    resolve(args.low, "low", "humanlike"), rally_goals(high)
    say_deprecated("evaluate", args.deprecated)
    print(f"evaluate: HUMAN-LIKE low level {args.low} on {args.episodes} fresh serves, then "
          f"its 3-D rally for {high} goals, {args.rallies} rallies from each of {_seeds(args)}"
          "; [95 % intervals]", flush=True)
    results = evaluate_humanlike_player(args.low, high, args.episodes, args.rallies,
                                        args.seeds, args.shuttle)
    r, t = results["low_level"], results["targets"]
    print(f"low level {args.low}: {r['episodes']} serves, hit rate {r['hit_rate']:.3f} "
          f"(target >= {t['hit_rate']}), mean angle error {r['mean_angle_error']:.2f} deg "
          f"(<= {t['mean_angle_error']}), median {r['median_angle_error']:.2f} deg, mean "
          f"|speed error| {r['mean_abs_speed_error']:.3f} (<= {t['mean_abs_speed_error']})")
    print(_rally_line(f"rally, {results['policies']['high']} goals", results["rally"])
          + f"  (target mean >= {t['mean_rally']:g})")
    print(_losses_line("where lost", results["rally"]))
    return results


def _evaluate_simple(args: argparse.Namespace) -> dict:
    """HRL, Random High-level and Monolithic on SIMPLE rallies."""
    from rallysim.eval.compare import evaluate_methods
    from rallysim.eval.low_eval import score_low_level
    from rallysim.policies.registry import resolve
    from rallysim.train.progress import Heartbeat, progress_lines

    # a bad policy name or file fails here, before the header and the long work
    resolve(args.low, "low"), resolve(args.high or "pretrained", "high")
    resolve(args.mono, "mono")
    say_deprecated("evaluate", args.deprecated)
    named = {"low": args.low, "high": args.high or "pretrained", "mono": args.mono}
    which = ("the shipped policies" if set(named.values()) == {"pretrained"}
             else ", ".join(f"{level} {name}" for level, name in named.items()))
    print(f"evaluate: HRL, Random High-level and Monolithic with {which}, {args.rallies} "
          f"rallies each from each of {_seeds(args)}, capped at {args.cap} hits; then the low "
          f"level on {args.episodes} fresh serves; [95 % intervals]", flush=True)
    say = progress_lines()
    beat = None if say is None else Heartbeat("[evaluate]", 3 * args.seeds, say,
                                              unit="rally sets")
    with beat or contextlib.nullcontext():
        results = evaluate_methods(args.low, args.high or "pretrained", args.mono,
                                   rallies=args.rallies, seeds=args.seeds,
                                   shuttle=args.shuttle, cap=args.cap, beat=beat)
    for method, s in results["methods"].items():
        print(_rally_line(method, s))
    for method, s in results["methods"].items():
        print(_losses_line(method, s))
    low = score_low_level(resolve(args.low, "low", "simple"), args.episodes,
                          shuttle=args.shuttle)
    print(f"low level {args.low}: {low['episodes']} serves, hit rate {low['hit_rate']:.3f}, "
          f"median landing error {low['median_landing_error']:.2f} m, goal correlation "
          f"{low['goal_correlation']:.3f} over the {low['reachable_hits']} hits whose goal "
          f"the serve makes reachable ({low['goal_correlation_all']:.3f} over all hits)")
    return {"low_level": low, **results}


# what `rallysim evaluate --player P` evaluates
_EVALUATIONS = {"simple": _evaluate_simple, "humanlike": _evaluate_humanlike}


# cooperative-only options of evaluate and their defaults: given with --mode competitive, they
# would be silently ignored, so they are refused
_COOPERATIVE_ONLY = {"--high": ("high", None), "--mono": ("mono", "pretrained"),
                     "--rallies": ("rallies", RALLIES), "--seeds": ("seeds", SEEDS),
                     "--cap": ("cap", PAPER_CAP), "--episodes": ("episodes", EPISODES),
                     "--pretrained": ("pretrained", False)}
_COMPETITIVE_ONLY = {"--players": "players", "--games": "games", "--seed": "seed",
                     "--max-decisions": "max_decisions", "--figure": "figure"}


def _check_competitive(args: argparse.Namespace) -> None:
    """Refuse (UsageError) a competitive evaluation that cannot run, before any game."""
    for option, (dest, default) in _COOPERATIVE_ONLY.items():
        if getattr(args, dest) != default:
            raise UsageError(f"{option} applies to --mode cooperative only")
    low_kind = _low_level_player(args.low)
    if low_kind not in (None, args.player):
        raise UsageError(f"--low {args.low} is a {low_kind} low level; these games are "
                         f"{args.player} players' (--player)")
    if not args.players:
        raise UsageError("--mode competitive needs --players A B [C ...]")
    if len(args.players) < 2:
        raise UsageError(f"--players needs at least two players, got one: {args.players[0]!r}")
    repeated = sorted({n for n in args.players if args.players.count(n) > 1})
    if repeated:
        raise UsageError(f"--players names each player once; repeated: {', '.join(repeated)}")
    if args.figure is not None:
        if len(args.players) < 3:
            raise UsageError("--figure draws the cross-play matrix: give 3 or more --players")
        if Path(args.figure).suffix.lower() != ".png":
            raise UsageError(f"--figure writes a PNG: give a .png path, got {args.figure!r}")
    import importlib.util

    needed = ["openskill"] if len(args.players) >= 3 else []
    needed += ["matplotlib"] if args.figure is not None else []
    missing = [m for m in needed if importlib.util.find_spec(m) is None]
    if missing:
        raise UsageError(f"cross-play of 3 or more players needs {', '.join(missing)}: "
                         "pip install 'rallysim[train]'")
    from rallysim.eval.agents import agent

    for name in args.players:  # an unknown name: a ValueError listing the valid ones
        agent(name, args.player, low=args.low)


def _estimate(e: dict, digits: int = 2) -> str:
    if e["value"] is None or e["value"] != e["value"]:  # None (JSON) or NaN
        return "n/a"
    return f"{e['value']:.{digits}f} [{e['low']:.{digits}f}, {e['high']:.{digits}f}]"


def _evaluate_two(args: argparse.Namespace) -> dict:
    """Games of the first player against the second; their summary and the settings."""
    from rallysim.eval.agents import agent
    from rallysim.eval.competitive import play_games, summarise
    from rallysim.jsondoc import jsonable

    a, b = args.players
    games = args.games or COMPETITIVE_GAMES
    seed = args.seed or 0
    max_decisions = args.max_decisions or COMPETITIVE_MAX_DECISIONS
    print(f"[evaluate] {a} vs {b}: {games} games ...", file=sys.stderr, flush=True)
    start = time.perf_counter()
    played = play_games(agent(a, args.player, low=args.low),
                        agent(b, args.player, low=args.low), games, seed, args.shuttle,
                        max_decisions)
    s = summarise(played, seed=seed)
    print(f"[evaluate] {a} vs {b}: {games} games in {time.perf_counter() - start:.0f} s",
          file=sys.stderr, flush=True)
    print(f"{a} vs {b}: {games} games (seed {seed}), {s['games_finished']} finished, "
          f"{s['points']} points, {s['lets']} lets")
    rows = [(f"point-win rate of {a}", _estimate(s["point_win_rate"])),
            (f"game-win rate of {a}", f"{_estimate(s['game_win_rate'])}  (finished games)"),
            ("mean rally", f"{_estimate(s['mean_rally'])}  hits per point")]
    width = max(len(label) for label, _ in rows)
    for label, value in rows:
        print(f"  {label:{width}s}  {value}")
    settings = {"games": games, "seed": seed, "max_decisions": max_decisions,
                "shuttle": args.shuttle, "low": args.low, "player": args.player}
    return {"players": [a, b], **jsonable(s), "settings": settings}


def _evaluate_crossplay(args: argparse.Namespace) -> dict:
    """Every pair of the players: the point-win matrix, OpenSkill ratings, the heat map."""
    from rallysim.eval.crossplay import crossplay, heatmap

    def say(line: str) -> None:
        print(line, file=sys.stderr, flush=True)

    result = crossplay(args.players, args.games or COMPETITIVE_GAMES, args.seed or 0,
                       args.max_decisions or COMPETITIVE_MAX_DECISIONS, args.shuttle,
                       say=say, low=args.low, player=args.player)
    names = result["players"]
    width = max(17, *(len(n) for n in names))
    print(f"point-win rate of row vs column ({result['games']} games per pair, seed "
          f"{result['seed']})")
    print(" " * width + "  " + "  ".join(f"{n:>{width}s}" for n in names))
    for name, row in zip(names, result["point_win_rate"], strict=True):
        cells = ("-" if c is None else _estimate(c) for c in row)
        print(f"{name:{width}s}  " + "  ".join(f"{c:>{width}s}" for c in cells))
    print("OpenSkill ratings (Plackett-Luce, each point a match), best ordinal (mu - 3 sigma) "
          "first")
    for r in result["table"]:
        print(f"  {r['name']:{width}s}  mu {r['mu']:6.2f}  sigma {r['sigma']:5.2f}  "
              f"ordinal {r['ordinal']:6.2f}")
    if args.figure:
        Path(args.figure).parent.mkdir(parents=True, exist_ok=True)
        print(f"heat map written to {heatmap(result, args.figure)}")
    return result


def _evaluate_competitive(args: argparse.Namespace) -> dict:
    """``evaluate --mode competitive``: two players' games, or the cross-play of 3 or more, of
    the kind ``--player`` (``_inferred_player`` when not given)."""
    _check_competitive(args)
    if len(args.players) == 2:
        return {"competitive": _evaluate_two(args)}
    return {"crossplay": _evaluate_crossplay(args)}


def _inferred_player(args: argparse.Namespace) -> str:
    """The player kind ``evaluate`` plays when ``--player`` is not given: the one ``--low``
    was trained for, else (``--mode competitive``) the one the ``--players``' policy files
    play where they agree, else ``simple``."""
    from rallysim.eval.agents import compete_prefix, policy_player

    kind = _low_level_player(args.low)
    if kind is None and args.mode == "competitive":
        kinds = {policy_player(compete_prefix(n) or Path(n)) for n in args.players or []}
        kinds.discard(None)
        kind = kinds.pop() if len(kinds) == 1 else None
    return kind or "simple"


def _low_level_player(low: str) -> str | None:
    """The player a low-level policy (a shipped name or a path prefix) was trained for, read
    from its JSON's env id, so that ``evaluate --low humanlike_low_rl`` needs no ``--player``;
    None where it names no file (``pretrained``, ``scripted``, ``random``: any kind's)."""
    import json

    from rallysim.envs.registration import HUMANLIKE_RETURN_ID
    from rallysim.policies.registry import shipped_prefix

    prefix = shipped_prefix(low) or Path(low)
    meta = prefix.with_name(prefix.name + ".json")
    if not meta.is_file():
        return None
    try:
        env_id = json.loads(meta.read_text()).get("env_id")
    except (ValueError, AttributeError):
        return None  # not a policy document: loading it says why
    return "humanlike" if env_id == HUMANLIKE_RETURN_ID else "simple"


@numpy_policies
def run(args: argparse.Namespace) -> int:
    """Evaluate HRL, Random High-level and Monolithic (pretrained or given policies), or a
    HUMAN-LIKE low level and its 3-D rally; or, with ``--mode competitive``, players in games
    against each other."""
    import json

    if args.player is None:
        args.player = _inferred_player(args)
    if args.mode == "competitive":
        results = _evaluate_competitive(args)
    else:
        for option, dest in _COMPETITIVE_ONLY.items():
            if getattr(args, dest) is not None:
                raise UsageError(f"{option} needs --mode competitive")
        results = _EVALUATIONS[args.player](args)
    if args.json:
        Path(args.json).parent.mkdir(parents=True, exist_ok=True)
        Path(args.json).write_text(json.dumps(results, indent=1))
        print(f"every number written to {args.json}")
    return 0
