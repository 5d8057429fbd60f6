"""``rallysim render``: write an MP4, a GIF and a strip of stills of episodes, rallies or
competitive games."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from pathlib import Path

import numpy as np

from rallysim.cli.common import (
    UsageError,
    add_command,
    add_player,
    add_shuttle_and_seed,
    integer_at_least,
    numpy_policies,
    policies,
    positive,
    positive_seconds,
    rally_policies,
)
from rallysim.cli.paths import out_dir, require

# --size: every frame is held in memory (4096x4096 RGB is 48 MiB) and OpenGL caps its render
# buffers; beyond this a typo like 100000x100000 would fail deep in the renderer
MAX_SIDE = 4096
# --players: a game's frames are held in memory too (an hour of 640x360 is 25 GB)
MATCH_DECISIONS_MAX = 36_000
DECISION_SECONDS = 0.1  # game time per decision (core.game's physics steps of a decision)
gif_step = integer_at_least(1, 100)  # a GIF frame lasts at most 655 s (16-bit hundredths)


def size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must look like 640x360, got {text!r}") from None
    if not (16 <= w <= MAX_SIDE and 16 <= h <= MAX_SIDE):
        raise argparse.ArgumentTypeError(f"size must be between 16x16 and {MAX_SIDE}x{MAX_SIDE}, "
                                         f"got {w}x{h}")
    return w, h


def add_parser(sub: argparse._SubParsersAction) -> None:
    render = add_command(sub, "render", "write an MP4, a GIF and stills of episodes")
    render.add_argument("--env", choices=("low", "rally"), default="rally",
                        help="low: episodes of the low-level task (a serve returned); rally: "
                             "rallies, or the games of --players")
    add_player(render, "the players (humanlike: the 3-D rally, by default with the shipped "
                       "pretrained high and low levels)")
    render.add_argument("--policy", default=None,
                        help="low level: scripted, random, pretrained or a policy path prefix "
                             "(default: scripted; humanlike: pretrained)")
    render.add_argument("--high", default=None,
                        help="rally goals: random, fixed:D, pretrained or a policy path prefix "
                             "(default: random); humanlike: centre, random, pretrained (the "
                             "default) or a path prefix")
    render.add_argument("--mode", choices=("cooperative", "competitive"), default="cooperative",
                        help="cooperative: the players keep the rally going; competitive: they "
                             "play for points (games of --players)")
    render.add_argument("--players", nargs="+", metavar="NAME",
                        help="with --mode competitive: a game of agent A (player 0, left in "
                             "the side view) against agent B: random, scripted, hrl, mono "
                             "(SIMPLE), simple_compete (SIMPLE) or an exported policy's path "
                             "prefix, players of the kind --player")
    render.add_argument("--episodes", type=positive, default=None,
                        help="episodes, rallies or --players games (default 2; --players: 1)")
    limit = render.add_mutually_exclusive_group()
    limit.add_argument("--decisions", type=integer_at_least(1, MATCH_DECISIONS_MAX),
                       help="--players: stop each game after this many decisions (default 600)")
    limit.add_argument("--seconds", type=positive_seconds,
                       help="--players: stop each game after this much game time (default 60)")
    render.add_argument("--camera", choices=("side", "three_quarter", "three_quarter_close"),
                        default=None,
                        help="the view (default: side; humanlike: three_quarter_close)")
    render.add_argument("--size", type=size, default=(640, 360),
                        help="frame size, WIDTHxHEIGHT (default: 640x360)")
    render.add_argument("--stills", type=positive, default=8, help="frames in the strip")
    render.add_argument("--gif-every", type=gif_step, default=2,
                        help="keep every k-th frame in the GIF")
    render.add_argument("--out", type=out_dir, default="results/videos",
                        help="folder the MP4, the GIF and the strip are written to")
    add_shuttle_and_seed(render)
    render.set_defaults(run=run)


@numpy_policies
def run(args: argparse.Namespace) -> int:
    """Write an MP4, a GIF and a strip of stills of N episodes (or rallies), or of competitive
    games between two agents (``--players``)."""
    from rallysim.core.tasks.rally import RallyConfig
    from rallysim.render.record import record_low_level, record_rally

    if args.players is not None:
        return _render_match(args)
    if args.decisions is not None or args.seconds is not None:
        raise UsageError("--decisions and --seconds limit the games of --players; rallies "
                         "and episodes play to their end")
    episodes = 2 if args.episodes is None else args.episodes
    policy, high_name = policies(args)
    out = Path(args.out)
    tag = "" if args.player == "simple" else f"{args.player}_"
    stem = out / f"{tag}{args.env}_{Path(policy).name}"
    outputs = (stem.with_suffix(".mp4"), stem.with_suffix(".gif"),
               stem.with_name(stem.name + "_strip.png"))
    for path in outputs:
        require(path, "file")  # before the rendering, which takes minutes
    # the policies first: a bad name fails before the folder is made or anything announced
    if args.env == "low":
        low = _low_level_task_policy(args.player, policy, args.seed)
    else:
        high, rally_low = rally_policies(args.player, policy, high_name, args.seed)
    out.mkdir(parents=True, exist_ok=True)
    width, height = args.size
    camera = args.camera  # None: the player kind's default
    print(f"rendering {episodes} {args.env} episode(s) with policy {policy!r} ...",
          flush=True)
    if args.env == "low":
        frames = record_low_level(episodes, low, args.seed, args.shuttle, width, height,
                                  camera, player=args.player)
    else:
        config = RallyConfig(shuttle=args.shuttle, mode=args.mode)
        frames = record_rally(episodes, high, rally_low, args.seed, config, width, height,
                              camera, player=args.player)
    _write_outputs(frames, outputs, args)
    return 0


def _write_outputs(frames: list[np.ndarray], outputs: tuple[Path, Path, Path],
                   args: argparse.Namespace) -> None:
    """The MP4, the GIF (every ``--gif-every``-th frame) and the strip of ``--stills``."""
    from rallysim.render import write_strip, write_video

    mp4, gif, strip = outputs
    write_video(frames, mp4, fps=10)
    write_video(frames[:: args.gif_every], gif, fps=10 / args.gif_every)
    picks = np.linspace(0, len(frames) - 1, args.stills).round().astype(int)
    write_strip([frames[i] for i in picks], strip, columns=min(4, args.stills))
    print(f"  wrote {mp4}")
    print(f"  wrote {gif}")
    print(f"  wrote {strip}  ({len(frames)} frames)")


def _match_decisions(args: argparse.Namespace) -> int | None:
    """The decision limit of each game from ``--decisions`` or ``--seconds`` (of game time);
    None: the recorder's default."""
    if args.seconds is None:
        return args.decisions
    decisions = max(1, round(args.seconds / DECISION_SECONDS))
    if decisions > MATCH_DECISIONS_MAX:
        raise UsageError(f"--seconds must be at most {MATCH_DECISIONS_MAX * DECISION_SECONDS:g} "
                         f"(a game's frames are held in memory), got {args.seconds:g}")
    return decisions


def _render_match(args: argparse.Namespace) -> int:
    """``render --mode competitive --players A B``: games of agent A against agent B, played
    by ``rallysim.eval.competitive.Match``, with their score in the HUD."""
    from rallysim.core.tasks.rally import RallyConfig
    from rallysim.eval.agents import agent
    from rallysim.render.record import record_match

    if len(args.players) != 2:
        raise UsageError(f"--players takes two names, player A and player B, got "
                         f"{len(args.players)}: {' '.join(args.players)}")
    if args.mode != "competitive":
        raise UsageError("--players plays competitive games: add --mode competitive")
    if args.env != "rally":
        raise UsageError("--players plays rallies, not the low-level task: drop --env low")
    if args.policy is not None or args.high is not None:
        raise UsageError("--players: each agent brings its own levels; drop --policy and --high")
    decisions = _match_decisions(args)
    games = 1 if args.episodes is None else args.episodes
    out = Path(args.out)
    a_name, b_name = (Path(name).name for name in args.players)
    stem = out / f"match_{a_name}_vs_{b_name}"
    outputs = (stem.with_suffix(".mp4"), stem.with_suffix(".gif"),
               stem.with_name(stem.name + "_strip.png"))
    for path in outputs:
        require(path, "file")
    # the agents first: an unknown name fails before the folder is made or anything announced
    a, b = (agent(name, args.player, args.seed) for name in args.players)
    out.mkdir(parents=True, exist_ok=True)
    width, height = args.size
    limit = "" if decisions is None else f", at most {decisions} decisions each"
    print(f"rendering {games} game(s) of {args.players[0]!r} against {args.players[1]!r}"
          f"{limit} ...", flush=True)
    config = RallyConfig(shuttle=args.shuttle, mode="competitive")
    kwargs = {} if decisions is None else {"max_decisions": decisions}
    frames = record_match(a, b, games, args.seed, config, width, height, args.camera, **kwargs)
    _write_outputs(frames, outputs, args)
    return 0


def _low_level_task_policy(player: str, spec: str, seed: int) -> Callable | str:
    """The low-level task's batched policy of ``player`` from its name (``random`` is left to
    the recorder, which seeds it)."""
    from rallysim.policies.registry import resolve

    return spec if spec == "random" else resolve(spec, "low", player, seed)
