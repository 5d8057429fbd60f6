"""``rallysim train``: train one stage with PPO, resumable, on this machine or a Ray cluster."""

from __future__ import annotations

import argparse
from pathlib import Path

from rallysim.cli.common import (
    DeprecatedName,
    UsageError,
    add_command,
    non_negative,
    require_train_extra,
    say_deprecated,
    seed_value,
)
from rallysim.cli.paths import in_file, out_dir, require
from rallysim.core.shuttle import SHUTTLE_MODELS


def add_parser(sub: argparse._SubParsersAction) -> None:
    # the stages, players and settings of training (light modules: no torch, SB3 or YAML)
    from rallysim.train.config import settings_help
    from rallysim.train.players import PLAYERS
    from rallysim.train.stages import NAMES as stages

    players = tuple(PLAYERS)
    train = add_command(sub, "train", "train a stage with PPO (resumes an interrupted run)",
                        epilog=settings_help())
    train.add_argument("stage", choices=stages,
                       help="low, high, mono: the paper's stages; compete: the competitive high "
                            "level by self-play; compete_mono: the flat competitive baseline "
                            "(docs/competitive.md)")
    train.add_argument("--config", type=in_file,
                       help="a YAML file of settings over the stage's defaults")
    train.add_argument("--set", nargs="*", default=[], metavar="KEY=VALUE",
                       help="settings over the config, e.g. ppo.n_envs=128 "
                            "ppo.net_arch=[64,64] eval.episodes=200 (all listed below)")
    train.add_argument("--budget", type=int,
                       help="budget in the stage's unit: decisions (low, compete_mono), "
                            "turns (high, compete), player-decisions (mono); default: the "
                            "stage config's")
    train.add_argument("--decisions", type=int, dest="budget", action=DeprecatedName,
                       new="--budget", help="deprecated name of --budget")
    train.add_argument("--seed", type=seed_value,
                       help="the training seed (default: the config's, 0)")
    train.add_argument("--shuttle", choices=tuple(SHUTTLE_MODELS),
                       help="the shuttlecock's flight model (default: the config's, paper)")
    train.add_argument("--player", choices=players,
                       help="the player (default simple; humanlike: low, high and compete stages)")
    train.add_argument("--env", choices=players, dest="player", action=DeprecatedName,
                       new="--player", help="deprecated name of --player")
    train.add_argument("--low-policy", dest="low_policy",
                       help="high stage: frozen low level (path prefix, pretrained, scripted; "
                            "default: the config's)")
    train.add_argument("--out", type=out_dir,
                       help="run folder (default runs/STAGE_seedN; HUMAN-LIKE: "
                            "runs/STAGE_humanlike_seedN)")
    train.add_argument("--restart", action="store_true", help="ignore existing checkpoints")
    train.add_argument("--quiet", action="store_true", help="no progress bar")
    train.add_argument("--backend", choices=("sb3", "rllib"), default="sb3",
                       help="sb3: Stable-Baselines3 on this machine (default); rllib: RLlib "
                            "PPO on a Ray cluster (needs rallysim[ray])")
    train.add_argument("--address", help="rllib: the Ray cluster, auto or HOST:PORT "
                                         "(default: a local Ray started for the run)")
    train.add_argument("--env-runners", dest="env_runners", type=non_negative,
                       help="rllib: env runners, one CPU each, placed by Ray (default: 2 with "
                            "--address, else 0: the driver samples)")
    train.set_defaults(deprecated=[])
    train.set_defaults(run=run)


def _require_ray_extra() -> None:
    """Refuse (UsageError) when the packages of the ``ray`` extra are not installed."""
    from rallysim.rllib import INSTALL_HINT, missing_packages

    missing = missing_packages()
    if missing:
        raise UsageError(f"--backend rllib needs the ray extra (missing: {', '.join(missing)}):"
                         f" install rallysim[ray], e.g. {INSTALL_HINT}")


def run(args: argparse.Namespace) -> int:
    """Train one stage (low, high, mono, compete, compete_mono) with Stable-Baselines3 PPO
    (resumable) or, with ``--backend rllib``, with RLlib PPO on a Ray cluster."""
    import warnings

    rllib = args.backend == "rllib"
    if not rllib and (args.address or args.env_runners is not None):
        raise UsageError("--address and --env-runners need --backend rllib")
    if rllib:
        _require_ray_extra()
    else:
        require_train_extra()
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
    require(out, "dir")  # the default folder is only known now
    say_deprecated("train", notes)
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
