"""The ``rallysim`` command line: one module per subcommand (``demo``, ``train``,
``reproduce``, ``evaluate``, ``render``, ``play``), each with its parser and its handler, and
``main``, which assembles them.

A user error (a bad option or value, a path that cannot be read or written, a bad setting) is
one line on stderr, ``rallysim COMMAND: error: ...``, and exit status 2; paths are checked
before any long work. ``RALLYSIM_TRACEBACK=1`` shows the traceback instead."""

from __future__ import annotations

import argparse
import os
import sys

from rallysim.cli import demo, evaluate, play, render, reproduce, train
from rallysim.cli.common import SEED_MAX, HelpFormatter, Parser, UsageError
from rallysim.cli.paths import os_message, path_problem

__all__ = ["SEED_MAX", "UsageError", "build_parser", "main", "path_problem"]

# in the order `rallysim --help` lists them
COMMANDS = (demo, train, reproduce, evaluate, render, play)

DESCRIPTION = """\
RallySim: two robots rally a shuttlecock, for multi-agent reinforcement learning.

A mistake on the command line is one line on stderr and exit status 2; set
RALLYSIM_TRACEBACK=1 to see the traceback instead. 'rallysim command --help'
lists a command's options with their defaults."""


def build_parser() -> argparse.ArgumentParser:
    parser = Parser(prog="rallysim", description=DESCRIPTION, formatter_class=HelpFormatter)
    sub = parser.add_subparsers(dest="command", required=True, metavar="command",
                                title="commands", help="what to do")
    for command in COMMANDS:
        command.add_parser(sub)
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
        message = os_message(err) if isinstance(err, OSError) else str(err)
        return _error_line(prog, message or type(err).__name__)
