"""What the subcommands share: the user error and the parser that raises it, the help
formatter, argument types, options several commands take, and the policies they name."""

from __future__ import annotations

import argparse
import functools
import sys
from collections.abc import Callable
from typing import NoReturn

from rallysim.core.shuttle import SHUTTLE_MODELS

# TrainConfig's bound (train/config.py SEED_MAX; not imported: it needs the train extra's yaml)
SEED_MAX = 2**31 - 1
PLAYER_KINDS = ("simple", "humanlike")


class UsageError(Exception):
    """A mistake in the command line or in what it names. ``main`` prints it as one line and
    returns 2 (the usage-error convention): there is nothing to debug, so no traceback."""

    def __init__(self, message: str, prog: str | None = None, help_hint: bool = False) -> None:
        super().__init__(message)
        self.prog = prog  # the (sub)command whose usage was wrong; None: the running command
        self.help_hint = help_hint


class Parser(argparse.ArgumentParser):
    """argparse, with its errors raised as ``UsageError`` instead of a usage block printed
    before the message: every user error then leaves through ``main`` the same way.
    Subparsers are built from this class too (``add_subparsers`` uses the parent's type)."""

    def error(self, message: str) -> NoReturn:
        raise UsageError(message, prog=self.prog, help_hint=True)


class HelpFormatter(argparse.RawDescriptionHelpFormatter):
    """Descriptions and epilogs as written (their line breaks are deliberate), and every
    option's default after its help, unless the help already says it in its own words
    ("(default ...", "default: ...": a default that depends on other options) or there is none
    to say (a flag, an option that is off unless given)."""

    def _get_help_string(self, action: argparse.Action) -> str | None:
        text = action.help or ""
        default = action.default
        if (not action.option_strings or "(default" in text or "default:" in text
                or default is None or default is False or default == []
                or default is argparse.SUPPRESS):
            return text
        return f"{text} (default: %(default)s)"


def add_command(sub: argparse._SubParsersAction, name: str, help_text: str,
                description: str | None = None, **kwargs: object) -> argparse.ArgumentParser:
    """A subcommand's parser, with the shared help formatter; its description is its help
    unless given."""
    return sub.add_parser(name, help=help_text, description=description or help_text,
                          formatter_class=HelpFormatter, **kwargs)


def numpy_policies(run: Callable[[argparse.Namespace], int]
                   ) -> Callable[[argparse.Namespace], int]:
    """For a command that runs the policies in NumPy: the BLAS on one thread while it runs.
    The policies' products are small (64 units, batches of hundreds), where BLAS threads cost
    far more than they give (docs/performance.md); one thread also gives the same numbers
    whatever the core count, since splitting a product between threads moves some bits."""

    @functools.wraps(run)
    def one_thread(args: argparse.Namespace) -> int:
        from threadpoolctl import threadpool_limits

        with threadpool_limits(limits=1, user_api="blas"):
            return run(args)

    return one_thread


def integer_at_least(low: int, high: int | None = None) -> Callable[[str], int]:
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


non_negative = integer_at_least(0)
positive = integer_at_least(1)
hits_cap = integer_at_least(1, 100_000)
seed_value = integer_at_least(0, SEED_MAX)


def positive_seconds(text: str) -> float:
    try:
        value = float(text)
    except ValueError:
        value = float("nan")
    if not (0 < value < float("inf")):
        raise argparse.ArgumentTypeError(f"must be a positive number of seconds, got {text!r}")
    return value


def add_shuttle_and_seed(p: argparse.ArgumentParser) -> None:
    add_shuttle(p)
    p.add_argument("--seed", type=seed_value, default=0,
                   help="the seed of the episodes, rallies or games played")


def add_shuttle(p: argparse.ArgumentParser) -> None:
    p.add_argument("--shuttle", default="paper", choices=tuple(SHUTTLE_MODELS),
                   help="the shuttlecock's flight model")


def add_player(p: argparse.ArgumentParser, help_text: str) -> None:
    p.add_argument("--player", choices=PLAYER_KINDS, default="simple", help=help_text)


class DeprecatedName(argparse.Action):
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


def say_deprecated(command: str, notes: list[str]) -> None:
    for note in notes:
        print(f"rallysim {command}: warning: {note}", file=sys.stderr)


def require_train_extra() -> None:
    """Refuse (UsageError) when the packages of the ``train`` extra are not installed."""
    import importlib.util

    missing = [m for m in ("torch", "stable_baselines3", "yaml", "tqdm")
               if importlib.util.find_spec(m) is None]
    if missing:
        raise UsageError(f"the train extra is not installed (missing: {', '.join(missing)}): "
                         "pip install torch==2.13.0 && pip install 'rallysim[train]'")


# --policy and --high when not given, per player kind: SIMPLE's scripted controller and random
# goals; HUMAN-LIKE's shipped (pretrained) low and high levels
POLICY_DEFAULTS = {"simple": ("scripted", "random"), "humanlike": ("pretrained", "pretrained")}


def policies(args: argparse.Namespace) -> tuple[str, str]:
    """The names of the low and high levels: as given, else the player kind's defaults."""
    low, high = POLICY_DEFAULTS[args.player]
    return (low if args.policy is None else args.policy,
            high if args.high is None else args.high)


def rally_policies(player: str, low: str, high: str, seed: int) -> tuple[Callable, Callable]:
    """(high level, rally low level) of ``player`` from their names; a bad name raises here."""
    from rallysim.policies.registry import resolve

    if player == "humanlike" and high == "centre":
        high = "fixed:0,0,0"  # the 3-D rally's centre goal, as evaluate calls it
    return resolve(high, "high", player, seed), resolve(low, "rally_low", player, seed)
