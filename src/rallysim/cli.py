"""The ``rallysim`` command line: ``demo``, ``train``, ``reproduce``, ``evaluate``, ``render``,
``play``.

A user error (a bad option or value, a path that cannot be read or written, a bad setting) is
one line on stderr, ``rallysim COMMAND: error: ...``, and exit status 2; paths are checked
before any long work. ``RALLYSIM_TRACEBACK=1`` shows the traceback instead."""

from __future__ import annotations

import argparse
import contextlib
import os
import stat
import sys
import tempfile
import time
from collections.abc import Callable
from pathlib import Path
from typing import TYPE_CHECKING, NoReturn

import numpy as np

from rallysim.core.shuttle import SHUTTLE_MODELS
from rallysim.jsondoc import MISSING, not_a_file

if TYPE_CHECKING:
    from rallysim.eval.agents import Agent

# TrainConfig's bound (train/config.py SEED_MAX; not imported: it needs the train extra's yaml)
SEED_MAX = 2**31 - 1
# render --size: every frame is held in memory (4096x4096 RGB is 48 MiB) and OpenGL caps
# its render buffers; beyond this a typo like 100000x100000 would fail deep in the renderer
MAX_SIDE = 4096
# render --players: a game's frames are held in memory too (an hour of 640x360 is 25 GB)
MATCH_DECISIONS_MAX = 36_000
DECISION_SECONDS = 0.1  # game time per decision (core.game's physics steps of a decision)
# play --opponent: the shipped competitive champion
DEFAULT_OPPONENT = "simple_compete"


class UsageError(Exception):
    """A mistake in the command line or in what it names. ``main`` prints it as one line and
    returns 2 (the usage-error convention): there is nothing to debug, so no traceback."""

    def __init__(self, message: str, prog: str | None = None, help_hint: bool = False) -> None:
        super().__init__(message)
        self.prog = prog  # the (sub)command whose usage was wrong; None: the running command
        self.help_hint = help_hint


class _Parser(argparse.ArgumentParser):
    """argparse, with its errors raised as ``UsageError`` instead of a usage block printed
    before the message: every user error then leaves through ``main`` the same way.
    Subparsers are built from this class too (``add_subparsers`` uses the parent's type)."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(message, prog=self.prog, help_hint=True)


def _demo(args: argparse.Namespace) -> int:
    """Play the low-level task (SIMPLE or HUMAN-LIKE) with the scripted controller (or
    ``--policy``) and print what happened."""
    if args.player == "humanlike":
        return _demo_humanlike(args)
    from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv
    from rallysim.eval.low_eval import evaluate_return
    from rallysim.policies.registry import resolve

    env = SimpleReturnVectorEnv(args.envs, shuttle=args.shuttle, autoreset_mode="same_step")
    start = time.perf_counter()
    r = evaluate_return(resolve(args.policy, "low", "simple", args.seed), env, args.episodes,
                        args.seed)
    elapsed = time.perf_counter() - start
    print(f"RallySim/SimpleReturn-v0, shuttle={args.shuttle!r}, policy={args.policy!r}, "
          f"{r.episodes} episodes")
    print(f"  mean episode reward   {r.mean_reward:.3f}  (max about 2.0; paper's PPO 1.8)")
    print(f"  hit rate              {r.hit_rate:.3f}")
    print(f"  landed in             {r.in_rate:.3f}")
    print(f"  median landing error  {r.median_error:.3f} m")
    print(f"  speed                 {r.decisions / elapsed:,.0f} decisions/s "
          f"with {args.envs} environments")
    return 0


def _demo_humanlike(args: argparse.Namespace) -> int:
    """``demo --player humanlike``: ``RallySim/HumanLikeReturn-v0`` in rounds of ``--envs``
    environments, episode i seeded ``--seed`` + i (as the SIMPLE demo)."""
    from rallysim.eval.humanlike_eval import evaluate_humanlike
    from rallysim.policies.registry import resolve

    policy = resolve(args.policy, "low", "humanlike", args.seed)
    rounds = []
    start = time.perf_counter()
    for first in range(0, args.episodes, args.envs):
        k = min(args.envs, args.episodes - first)
        rounds.append((k, evaluate_humanlike(policy, k, args.seed + first, args.shuttle)))
    elapsed = time.perf_counter() - start
    n = sum(k for k, _ in rounds)
    hits = [round(r["hit_rate"] * k) for k, r in rounds]  # the rate is hits / k, exactly

    def mean_over_hits(key: str) -> float:
        total = sum(h * r[key] for h, (_, r) in zip(hits, rounds, strict=True) if h)
        return total / sum(hits) if sum(hits) else float("nan")

    print(f"RallySim/HumanLikeReturn-v0, shuttle={args.shuttle!r}, policy={args.policy!r}, "
          f"{n} episodes")
    print(f"  mean episode reward   {sum(k * r['mean_reward'] for k, r in rounds) / n:.3f}"
          "  (max 1.0)")
    print(f"  hit rate              {sum(hits) / n:.3f}")
    print(f"  mean angle error      {mean_over_hits('mean_angle_error'):.2f} deg  "
          "(racket velocity at the hit vs the target)")
    print(f"  mean |speed error|    {mean_over_hits('mean_abs_speed_error'):.3f}")
    print(f"  speed                 {n / elapsed:,.1f} episodes/s "
          f"with {min(args.envs, n)} environments")
    return 0


def _size(text: str) -> tuple[int, int]:
    try:
        w, h = (int(v) for v in text.lower().split("x"))
    except ValueError:
        raise argparse.ArgumentTypeError(f"size must look like 640x360, got {text!r}") from None
    if not (16 <= w <= MAX_SIDE and 16 <= h <= MAX_SIDE):
        raise argparse.ArgumentTypeError(f"size must be between 16x16 and {MAX_SIDE}x{MAX_SIDE}, "
                                         f"got {w}x{h}")
    return w, h


def _integer_at_least(low: int, high: int | None = None):
    def parse(text: str) -> int:
        try:
            value = int(text)
        except ValueError:
            raise argparse.ArgumentTypeError(f"expected an integer, got {text!r}") from None
        if value < low or (high is not None and value > high):
            bounds = f">= {low}" if high is None else f"in [{low}, {high}]"
            raise argparse.ArgumentTypeError(f"must be {bounds}, got {value}")
        return value

    return parse


_non_negative = _integer_at_least(0)
_positive = _integer_at_least(1)
_cap = _integer_at_least(1, 100_000)
_seed = _integer_at_least(0, SEED_MAX)
_gif_step = _integer_at_least(1, 100)  # a GIF frame lasts at most 655 s (16-bit hundredths)


def _seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (0 < value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got {text!r}")
    return value


def _os_message(err: OSError) -> str:
    """``'PATH': Reason`` for an OSError from the file system, else its own message."""
    if err.strerror and err.filename is not None:
        return f"{str(err.filename)!r}: {err.strerror}"
    return str(err) or type(err).__name__


def _nearest_existing(path: Path) -> Path:
    """``path`` or its nearest ancestor that exists (the folder a creation would start in)."""
    for candidate in (path, *path.parents):
        if candidate.exists():
            return candidate
    return Path(".")  # only a relative path gets here; its top folder is the current one


def _cannot_create(path: Path, start: Path) -> str | None:
    """Why ``path`` cannot be created from ``start``, its nearest existing ancestor."""
    if not start.is_dir():
        return f"cannot create {str(path)!r}: {str(start)!r} is not a directory"
    try:
        name_max = os.pathconf(start, "PC_NAME_MAX")
    except (OSError, ValueError):
        name_max = 255
    for part in path.relative_to(start).parts:
        if len(os.fsencode(part)) > name_max:
            return f"cannot create {str(path)!r}: the name {part[:20]!r}... is too long"
    return _cannot_write_in(start)


def _cannot_write_in(folder: Path) -> str | None:
    # create (and drop) a file rather than ask os.access: as root, access() says yes to a
    # read-only mode, and it does not see a read-only or virtual file system (/proc)
    try:
        with tempfile.TemporaryFile(dir=folder):
            pass
    except OSError as err:
        return f"cannot write in {str(folder)!r}: {err.strerror or err}"
    return None


def _is_stream(path: Path) -> bool:
    try:
        mode = path.stat().st_mode
    except OSError:  # a loop of links, a broken one: not_a_file has said what it is
        return False
    return stat.S_ISFIFO(mode) or stat.S_ISCHR(mode)


def path_problem(text: str, want: str) -> str | None:
    """What stops ``text`` from serving as ``want``, or None: ``"dir"``, an output folder
    (created with its parents); ``"file"``, an output file (likewise); ``"input"``, a file to
    read. Checked before any work, so a bad path fails in a second, not after an evaluation."""
    if not text:
        return "the path is empty"
    if "\0" in text:
        return "the path contains a NUL character"
    if want == "file" and text.endswith(("/", os.sep)):
        return f"{text!r} ends with '/' and so names a directory, not a file"
    path = Path(text)
    try:
        if want == "input":
            problem = not_a_file(path)
            if problem == MISSING:
                start = _nearest_existing(path.parent)
                if not start.is_dir():
                    return f"{text!r} does not exist: {str(start)!r} is not a directory"
                return f"{text!r} does not exist"
            # a pipe or a terminal is read as a stream (--config <(...), /dev/stdin)
            if problem is not None and not _is_stream(path):
                return f"{text!r} {problem}"
            return None if os.access(path, os.R_OK) else f"cannot read {text!r}: permission denied"
        if os.path.islink(path) and not path.exists():
            return f"{text!r} is a broken symbolic link"
        if path.exists():
            if want == "dir":
                return (f"{text!r} is not a directory" if not path.is_dir()
                        else _cannot_write_in(path))
            if path.is_dir():
                return f"{text!r} is a directory, not a file"
            return None if os.access(path, os.W_OK) else f"cannot write {text!r}: permission denied"
        return _cannot_create(path, _nearest_existing(path.parent))
    except OSError as err:  # e.g. a name too long for the system, a loop of links
        return _os_message(err)


def _path_arg(want: str) -> Callable[[str], str]:
    def parse(text: str) -> str:
        problem = path_problem(text, want)
        if problem:
            raise argparse.ArgumentTypeError(problem)
        return text

    return parse


_out_dir, _out_file, _in_file = _path_arg("dir"), _path_arg("file"), _path_arg("input")


def _require(path: Path, want: str) -> None:
    """``path_problem`` for a path the command builds (a default, a file inside ``--out``)."""
    problem = path_problem(str(path), want)
    if problem:
        raise UsageError(problem)


# --policy and --high when not given, per player kind: SIMPLE's scripted controller and random
# goals; HUMAN-LIKE's shipped (pretrained) low and high levels
POLICY_DEFAULTS = {"simple": ("scripted", "random"), "humanlike": ("pretrained", "pretrained")}


def _policies(args: argparse.Namespace) -> tuple[str, str]:
    """The names of the low and high levels: as given, else the player kind's defaults."""
    low, high = POLICY_DEFAULTS[args.player]
    return (low if args.policy is None else args.policy,
            high if args.high is None else args.high)


def _rally_policies(player: str, low: str, high: str, seed: int,
                    ) -> tuple[Callable, Callable]:
    """(high level, rally low level) of ``player`` from their names; a bad name raises here."""
    from rallysim.policies.registry import resolve

    if player == "humanlike" and high == "centre":
        high = "fixed:0,0,0"  # the 3-D rally's centre goal, as evaluate calls it
    return resolve(high, "high", player, seed), resolve(low, "rally_low", player, seed)


def _render(args: argparse.Namespace) -> int:
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
    policy, high_name = _policies(args)
    out = Path(args.out)
    tag = "" if args.player == "simple" else f"{args.player}_"
    stem = out / f"{tag}{args.env}_{Path(policy).name}"
    outputs = (stem.with_suffix(".mp4"), stem.with_suffix(".gif"),
               stem.with_name(stem.name + "_strip.png"))
    for path in outputs:
        _require(path, "file")  # before the rendering, which takes minutes
    # the policies first: a bad name fails before the folder is made or anything announced
    if args.env == "low":
        low = _low_level_task_policy(args.player, policy, args.seed)
    else:
        high, rally_low = _rally_policies(args.player, policy, high_name, args.seed)
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
        _require(path, "file")
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


def _play(args: argparse.Namespace) -> int:
    """Open MuJoCo's viewer on a live rally; optionally take part by keyboard (a SIMPLE
    player's actions, a HUMAN-LIKE player's goals)."""
    from rallysim.core.tasks.rally import RallyConfig
    from rallysim.envs.rendering import has_display
    from rallysim.render.play import play, play_match

    human = None if args.human == "none" else int(args.human)
    # the opponent first: a bad command line or name is told with or without a display
    opponent = _opponent(args) if _check_opponent(args, human) else None
    if not has_display():
        raise UsageError("a display is needed (DISPLAY is unset); use `rallysim render` to "
                         "write videos instead")
    config = RallyConfig(shuttle=args.shuttle, mode=args.mode)
    if opponent is not None:
        board = play_match(opponent, human, config, args.seed, seconds=args.seconds)
        if board.point_winners:
            print(f"points played: {len(board.point_winners)}, score {board.score_line}"
                  + "".join(f", game {k + 1} to {board.result(s)}"
                            for k, s in enumerate(board.games)))
        return 0
    low, high = _policies(args)
    high_level, low_level = _rally_policies(args.player, low, high, args.seed)
    lengths = play(low_level, high_level, human=human, config=config, seed=args.seed,
                   seconds=args.seconds, player=args.player)
    if lengths:
        print(f"rallies played: {len(lengths)}, mean length {np.mean(lengths):.1f}")
    return 0


def _check_opponent(args: argparse.Namespace, human: int | None) -> bool:
    """Whether ``play`` puts the person against a competitive agent (``play_match``): a SIMPLE
    competitive game with a person at the keyboard. ``--opponent`` anywhere else is refused:
    cooperative rallies and HUMAN-LIKE games keep the shared high and low levels."""
    against_agent = args.mode == "competitive" and args.player == "simple" and human is not None
    if args.opponent is None or against_agent:
        if args.opponent is not None and (args.policy is not None or args.high is not None):
            raise UsageError("--opponent brings its own levels: drop --policy and --high")
        return against_agent
    if args.player != "simple":
        raise UsageError("--opponent: the keyboard plays SIMPLE competitive games only; "
                         "HUMAN-LIKE play keeps the shared levels of --policy and --high")
    if args.mode != "competitive":
        raise UsageError("--opponent plays a competitive game: it needs --mode competitive")
    raise UsageError("--opponent is the opponent of a person at the keyboard (--human 0 or 1); "
                     "to watch two agents, use `rallysim render --mode competitive --players A "
                     "B`")


def _opponent(args: argparse.Namespace) -> Agent:
    """The person's opponent: the agent ``--opponent`` names (default ``simple_compete``, the
    shipped champion), or, when
    ``--policy`` or ``--high`` are given instead, their levels as one hierarchical agent (the
    computer of earlier versions)."""
    from rallysim.eval.agents import Hierarchical, agent

    if args.opponent is None and (args.policy is not None or args.high is not None):
        low, high = _policies(args)
        high_level, low_level = _rally_policies("simple", low, high, args.seed)
        return Hierarchical(high_level, low_level, f"{Path(high).name} goals")
    return agent(args.opponent or DEFAULT_OPPONENT, "simple", args.seed)


def _require_train_extra() -> None:
    """Refuse (UsageError) when the packages of the ``train`` extra are not installed."""
    import importlib.util

    missing = [m for m in ("torch", "stable_baselines3", "yaml", "tqdm")
               if importlib.util.find_spec(m) is None]
    if missing:
        raise UsageError(f"the train extra is not installed (missing: {', '.join(missing)}): "
                         "pip install torch==2.13.0 && pip install 'rallysim[train]'")


def _require_ray_extra() -> None:
    """Refuse (UsageError) when the packages of the ``ray`` extra are not installed."""
    from rallysim.rllib import INSTALL_HINT, missing_packages

    missing = missing_packages()
    if missing:
        raise UsageError(f"--backend rllib needs the ray extra (missing: {', '.join(missing)}):"
                         f" install rallysim[ray], e.g. {INSTALL_HINT}")


def _train(args: argparse.Namespace) -> int:
    """Train one stage (low, high, mono, compete, compete_mono) with Stable-Baselines3 PPO
    (resumable) or, with ``--backend rllib``, with RLlib PPO on a Ray cluster."""
    import warnings

    rllib = args.backend == "rllib"
    if not rllib and (args.address or args.env_runners is not None):
        raise UsageError("--address and --env-runners need --backend rllib")
    if rllib:
        _require_ray_extra()
    else:
        _require_train_extra()
    from rallysim.train.config import RenamedSetting, load_config, parse_overrides
    from rallysim.train.players import PLAYERS

    overrides = parse_overrides(args.set)
    for key in ("budget", "seed", "shuttle", "low_policy", "player"):
        value = getattr(args, key, None)
        if value is not None:
            overrides[key] = value
    # old setting names in --set or --config load with a warning each: said in one line
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always", DeprecationWarning)
        config = load_config(args.stage, args.config, overrides)
    renamed: dict[str, str] = {}
    for warning in caught:
        if isinstance(warning.message, RenamedSetting):
            renamed[warning.message.old] = warning.message.new
        else:
            warnings.showwarning(warning.message, warning.category, warning.filename,
                                 warning.lineno)
    notes = list(args.deprecated)
    if renamed:
        notes.append("old setting names are deprecated (same effect): " + ", ".join(
            f"{old} -> {new}" for old, new in renamed.items()))
    out = Path(args.out or PLAYERS[config.player].run_folder(args.stage, config.seed))
    _require(out, "dir")  # the default folder is only known now
    _say_deprecated("train", notes)
    if rllib:
        from rallysim.rllib.runner import train_stage_rllib

        # a cluster: spread the sampling; one machine: the driver samples fastest (docs/rllib.md)
        runners = args.env_runners if args.env_runners is not None else (
            2 if args.address else 0)
        curve = train_stage_rllib(config, out, address=args.address, env_runners=runners,
                                  progress=not args.quiet)
    else:
        from rallysim.train.runner import train_stage

        curve = train_stage(config, out, resume=not args.restart, progress=not args.quiet)
    print(f"{args.stage}: {curve['steps']:,} {config.budget_unit} in "
          f"{curve['train_wall_s']:.0f} s ({curve['steps_per_s']:,.0f}/s); policy written to "
          f"{out / 'policy.safetensors'}")
    return 0


def _reproduce(args: argparse.Namespace) -> int:
    """Train every stage and baseline on the chosen budget and write the Table VII report."""
    _require_train_extra()
    from rallysim.train.reproduce import BUDGETS, result_names, run_reproduce

    for name in result_names(args.cap).values():
        _require(Path(args.out) / name, "file")  # written after all the training
    results = run_reproduce(BUDGETS[args.budget], Path(args.out), workers=args.workers,
                            seeds=args.seeds, cap=args.cap)
    print((Path(args.out) / result_names(args.cap)["report"]).read_text())
    return 0 if results else 1


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


def _evaluate_humanlike(args: argparse.Namespace) -> dict:
    """A HUMAN-LIKE low level on fresh serves and the 3-D rally it plays."""
    from rallysim.eval.humanlike_eval import evaluate_humanlike_player

    if args.cap != 50:
        raise UsageError("--cap applies to SIMPLE rallies only")
    _say_deprecated("evaluate", args.deprecated)
    results = evaluate_humanlike_player(args.low, args.high or "pretrained", args.episodes,
                                        args.rallies, args.seeds, args.shuttle)
    r, t = results["low_level"], results["targets"]
    print(f"low level {args.low}: {r['episodes']} serves, hit rate {r['hit_rate']:.3f} "
          f"(target >= {t['hit_rate']}), mean angle error {r['mean_angle_error']:.2f} deg "
          f"(<= {t['mean_angle_error']}), median {r['median_angle_error']:.2f} deg, mean "
          f"|speed error| {r['mean_abs_speed_error']:.3f} (<= {t['mean_abs_speed_error']})")
    print(_rally_line(f"rally, {results['policies']['high']} goals", results["rally"])
          + f"  (target mean >= {t['mean_rally']:g})")
    return results


def _evaluate_simple(args: argparse.Namespace) -> dict:
    """HRL, Random High-level and Monolithic on SIMPLE rallies."""
    from rallysim.eval.compare import evaluate_methods
    from rallysim.eval.low_eval import score_low_level
    from rallysim.policies.registry import resolve
    from rallysim.train.progress import Heartbeat, progress_lines

    # a bad policy name or file fails here, before the long work
    resolve(args.low, "low"), resolve(args.high or "pretrained", "high")
    resolve(args.mono, "mono")
    _say_deprecated("evaluate", args.deprecated)
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


# evaluate --mode competitive: the defaults of its options (None on the parser, so that an
# option given in cooperative mode is seen and refused)
COMPETITIVE_GAMES = 16
COMPETITIVE_MAX_DECISIONS = 200_000  # rallysim.eval.competitive.DEFAULT_MAX_DECISIONS
# cooperative-only options of evaluate and their defaults: given with --mode competitive, they
# would be silently ignored, so they are refused
_COOPERATIVE_ONLY = {"--high": ("high", None), "--mono": ("mono", "pretrained"),
                     "--rallies": ("rallies", 100), "--seeds": ("seeds", 3),
                     "--cap": ("cap", 50), "--episodes": ("episodes", 500),
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
    from rallysim.eval.crossplay import jsonable

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


def _evaluate(args: argparse.Namespace) -> int:
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


class _DeprecatedName(argparse.Action):
    """An option's old name: sets the new option's value and leaves a note that the command
    prints once its own checks pass (a user error stays one line)."""

    def __init__(self, option_strings: list[str], dest: str, new: str, **kwargs) -> None:
        self.new = new
        super().__init__(option_strings, dest, **kwargs)

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: object, option_string: str | None = None) -> None:
        setattr(namespace, self.dest, values)
        namespace.deprecated = [*namespace.deprecated,
                                f"{option_string} is deprecated: use {self.new} (same effect)"]


def _say_deprecated(command: str, notes: list[str]) -> None:
    for note in notes:
        print(f"rallysim {command}: warning: {note}", file=sys.stderr)


def _common(p: argparse.ArgumentParser) -> None:
    p.add_argument("--shuttle", default="paper", choices=tuple(SHUTTLE_MODELS))
    p.add_argument("--seed", type=_seed, default=0)


def _player(p: argparse.ArgumentParser, help_text: str) -> None:
    p.add_argument("--player", choices=("simple", "humanlike"), default="simple",
                   help=help_text)


def build_parser() -> argparse.ArgumentParser:
    parser = _Parser(prog="rallysim", description=__doc__,
                     formatter_class=argparse.RawDescriptionHelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True)

    demo = sub.add_parser("demo", help="play the low-level task and print what happened")
    demo.add_argument("--episodes", type=_positive, default=2000)
    demo.add_argument("--envs", type=_positive, default=256)
    demo.add_argument("--policy", default="scripted",
                      help="scripted, random, pretrained or a policy path prefix")
    _player(demo, "the low-level task's player (humanlike: RallySim/HumanLikeReturn-v0, "
                  "scripted = AimedSwing)")
    _common(demo)
    demo.set_defaults(run=_demo)

    # the stages, players and settings of training (light modules: no torch, SB3 or YAML)
    from rallysim.train.config import settings_help
    from rallysim.train.players import PLAYERS
    from rallysim.train.stages import NAMES as stages

    players = tuple(PLAYERS)
    train = sub.add_parser("train", help="train a stage with PPO (resumes an interrupted run)",
                           epilog=settings_help(),
                           formatter_class=argparse.RawDescriptionHelpFormatter)
    train.add_argument("stage", choices=stages,
                       help="low, high, mono: the paper's stages; compete: the competitive high "
                            "level by self-play; compete_mono: the flat competitive baseline "
                            "(docs/competitive.md)")
    train.add_argument("--config", type=_in_file,
                       help="a YAML file of settings over the stage's defaults")
    train.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                       help="settings over the config, e.g. ppo.n_envs=128 "
                            "ppo.net_arch=[64,64] eval.episodes=200 (all listed below)")
    train.add_argument("--budget", type=int,
                       help="budget in the stage's unit: decisions (low, compete_mono), "
                            "turns (high, compete), player-decisions (mono)")
    train.add_argument("--decisions", type=int, dest="budget", action=_DeprecatedName,
                       new="--budget", help="deprecated name of --budget")
    train.add_argument("--seed", type=_seed)
    train.add_argument("--shuttle", choices=tuple(SHUTTLE_MODELS))
    train.add_argument("--player", choices=players,
                       help="the player (default simple; humanlike: low, high and compete stages)")
    train.add_argument("--env", choices=players, dest="player", action=_DeprecatedName,
                       new="--player", help="deprecated name of --player")
    train.add_argument("--low-policy", dest="low_policy",
                       help="high stage: frozen low level (path prefix, pretrained, scripted)")
    train.add_argument("--out", type=_out_dir,
                       help="run folder (default runs/STAGE_seedN; HUMAN-LIKE: "
                            "runs/STAGE_humanlike_seedN)")
    train.add_argument("--restart", action="store_true", help="ignore existing checkpoints")
    train.add_argument("--quiet", action="store_true", help="no progress bar")
    train.add_argument("--backend", choices=("sb3", "rllib"), default="sb3",
                       help="sb3: Stable-Baselines3 on this machine (default); rllib: RLlib "
                            "PPO on a Ray cluster (needs rallysim[ray])")
    train.add_argument("--address", help="rllib: the Ray cluster, auto or HOST:PORT "
                                         "(default: a local Ray started for the run)")
    train.add_argument("--env-runners", dest="env_runners", type=_non_negative,
                       help="rllib: env runners, one CPU each, placed by Ray (default: 2 with "
                            "--address, else 0: the driver samples)")
    train.set_defaults(deprecated=[])
    train.set_defaults(run=_train)

    repro = sub.add_parser("reproduce", help="the whole pipeline and the paper's Table VII")
    repro.add_argument("--budget", choices=("default", "quick", "scratch", "rl", "smoke"),
                       default="default",
                       help="default: 3 seeds (its time on 2 cores: docs/results.md); "
                            "quick: a look in ~5 min; scratch: "
                            "the default with the low level trained from scratch; rl: no "
                            "teacher anywhere, the low level from scratch on "
                            "SimpleReturn-v1")
    repro.add_argument("--out", type=_out_dir, default="results")
    repro.add_argument("--workers", type=_positive,
                       help="processes training and evaluating at once (default: one per CPU "
                            "core)")
    repro.add_argument("--seeds", type=_positive,
                       help="training seeds (default: the budget's, 3; the seed-spread study "
                            "uses 5)")
    repro.add_argument("--cap", type=_cap, default=50,
                       help="rallies end at this many hits (default 50, the paper's; up to "
                            "100000): only a landing or the cap ends a rally")
    repro.set_defaults(run=_reproduce)

    ev = sub.add_parser("evaluate", help="rally statistics of HRL, Random High-level, "
                        "Monolithic; or of a HUMAN-LIKE low level (--player humanlike)")
    ev.add_argument("--player", choices=players, default=None,
                    help="humanlike: the low level's hit rate, angle and speed errors on "
                         "--episodes serves, and the 3-D rally it plays; with --mode "
                         "competitive, games of HUMAN-LIKE players (default: the player --low "
                         "was trained for, else the one the --players' policy files play, "
                         "else simple)")
    ev.add_argument("--env", choices=players, dest="player", action=_DeprecatedName,
                    new="--player", help="deprecated name of --player")
    ev.set_defaults(deprecated=[])
    ev.add_argument("--pretrained", action="store_true",
                    help="the shipped policies (the default for any policy not given)")
    ev.add_argument("--low", default="pretrained",
                    help="low level: path prefix or pretrained (humanlike: or scripted)")
    ev.add_argument("--high", help="high level: path prefix or pretrained (the default); "
                                   "humanlike: also centre or random")
    ev.add_argument("--episodes", type=_positive, default=500,
                    help="fresh serves the low level returns (its low_level scores)")
    ev.add_argument("--mono", default="pretrained", help="Monolithic: path prefix or pretrained")
    ev.add_argument("--rallies", type=_positive, default=100,
                    help="rallies per seed and method")
    ev.add_argument("--seeds", type=_positive, default=3, help="evaluation seeds")
    ev.add_argument("--cap", type=_cap, default=50,
                    help="SIMPLE rallies end at this many hits (default 50, the paper's; up "
                         "to 100000)")
    ev.add_argument("--json", type=_out_file, help="write every number here")
    ev.add_argument("--shuttle", default="paper", choices=tuple(SHUTTLE_MODELS))
    ev.add_argument("--mode", choices=("cooperative", "competitive"), default="cooperative",
                    help="cooperative (default): rally statistics as above; competitive: "
                         "--players in games against each other")
    ev.add_argument("--players", nargs="+", metavar="NAME",
                    help="competitive: random, scripted, hrl, mono (SIMPLE), simple_compete "
                         "(SIMPLE) or a policy path prefix, players of the kind --player; two: "
                         "the first's point-win and game-win rates; three or more: the "
                         "cross-play matrix and OpenSkill ratings")
    ev.add_argument("--games", type=_positive,
                    help=f"competitive: games per pair (default {COMPETITIVE_GAMES})")
    ev.add_argument("--seed", type=_seed, help="competitive: the games' seed (default 0)")
    ev.add_argument("--max-decisions", dest="max_decisions", type=_positive,
                    help="competitive: a game still going after this many decisions stops "
                         f"and counts by its points (default {COMPETITIVE_MAX_DECISIONS})")
    ev.add_argument("--figure", type=_out_file,
                    help="competitive, 3 or more players: the cross-play heat map (PNG)")
    ev.set_defaults(run=_evaluate)

    render = sub.add_parser("render", help="write an MP4, a GIF and stills of episodes")
    render.add_argument("--env", choices=("low", "rally"), default="rally")
    _player(render, "the players (humanlike: the 3-D rally, by default with the shipped "
                    "pretrained high and low levels)")
    render.add_argument("--policy", default=None,
                        help="low level: scripted, random, pretrained or a policy path prefix "
                             "(default: scripted; humanlike: pretrained)")
    render.add_argument("--high", default=None,
                        help="rally goals: random, fixed:D, pretrained or a policy path prefix "
                             "(default: random); humanlike: centre, random, pretrained (the "
                             "default) or a path prefix")
    render.add_argument("--mode", choices=("cooperative", "competitive"), default="cooperative")
    render.add_argument("--players", nargs="+", metavar="NAME",
                        help="with --mode competitive: a game of agent A (player 0, left in "
                             "the side view) against agent B: random, scripted, hrl, mono "
                             "(SIMPLE), simple_compete (SIMPLE) or an exported policy's path "
                             "prefix, players of the kind --player")
    render.add_argument("--episodes", type=_positive, default=None,
                        help="episodes, rallies or --players games (default 2; --players: 1)")
    limit = render.add_mutually_exclusive_group()
    limit.add_argument("--decisions", type=_integer_at_least(1, MATCH_DECISIONS_MAX),
                       help="--players: stop each game after this many decisions (default 600)")
    limit.add_argument("--seconds", type=_seconds,
                       help="--players: stop each game after this much game time (default 60)")
    render.add_argument("--camera", choices=("side", "three_quarter", "three_quarter_close"),
                        default=None, help="default: side; humanlike: three_quarter_close")
    render.add_argument("--size", type=_size, default=(640, 360), help="WIDTHxHEIGHT")
    render.add_argument("--stills", type=_positive, default=8, help="frames in the strip")
    render.add_argument("--gif-every", type=_gif_step, default=2,
                        help="keep every k-th frame in the GIF")
    render.add_argument("--out", type=_out_dir, default="results/videos")
    _common(render)
    render.set_defaults(run=_render)

    play = sub.add_parser("play", help="watch a live rally; take over a player by keyboard")
    _player(play, "the players (humanlike: your keys choose your player's goals, its learned "
                  "low level swings)")
    play.add_argument("--human", choices=("none", "0", "1"), default="0")
    play.add_argument("--policy", default=None,
                      help="the low level (default: scripted; humanlike: pretrained); in "
                           "competitive SIMPLE play, with --high, the opponent's instead of "
                           "--opponent")
    play.add_argument("--high", default=None,
                      help="the computer's goals (default: random; humanlike: pretrained); in "
                           "competitive SIMPLE play, with --policy, the opponent's instead of "
                           "--opponent")
    play.add_argument("--mode", choices=("cooperative", "competitive"), default="competitive")
    play.add_argument("--opponent", metavar="NAME",
                      help="competitive SIMPLE play: the agent you play against: scripted (the "
                           "default until the champion ships), random, hrl, mono, "
                           "simple_compete (the intended opponent) or an exported policy's "
                           "path prefix")
    play.add_argument("--seconds", type=_seconds, default=None,
                      help="close the window after this many seconds (default: when you close it)")
    _common(play)
    play.set_defaults(run=_play)
    return parser


def _error_line(prog: str, message: str) -> int:
    # one line whatever the message holds (PyYAML's and numpy's span several)
    print(f"{prog}: error: {' '.join(message.split())}", file=sys.stderr)
    return 2


def main(argv: list[str] | None = None) -> int:
    """Run the command line; a user error is one line on stderr and the return value 2."""
    parser = build_parser()
    prog = parser.prog
    try:
        args = parser.parse_args(argv)
        prog = f"{parser.prog} {args.command}"
        return args.run(args)
    except (UsageError, ValueError, OSError) as err:
        if os.environ.get("RALLYSIM_TRACEBACK"):
            raise  # for a developer who wants to see where it came from
        if isinstance(err, UsageError):
            hint = f" (see '{err.prog} --help')" if err.help_hint else ""
            return _error_line(err.prog or prog, f"{err}{hint}")
        # ValueError: a bad value found past the parser (a setting, a policy name);
        # OSError: a file the user named that could not be read or written after all
        message = _os_message(err) if isinstance(err, OSError) else str(err)
        return _error_line(prog, message or type(err).__name__)


if __name__ == "__main__":
    sys.exit(main())
