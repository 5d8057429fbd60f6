"""``rallysim play``: MuJoCo's viewer on a live rally; take over a player by keyboard."""

from __future__ import annotations

import argparse
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from rallysim.cli.common import (
    UsageError,
    add_command,
    add_player,
    add_shuttle_and_seed,
    numpy_policies,
    policies,
    positive_seconds,
    rally_policies,
)

if TYPE_CHECKING:
    from rallysim.eval.agents import Agent

# --opponent: the shipped competitive champion
DEFAULT_OPPONENT = "simple_compete"


def add_parser(sub: argparse._SubParsersAction) -> None:
    play = add_command(sub, "play", "watch a live rally; take over a player by keyboard")
    add_player(play, "the players (humanlike: your keys choose your player's goals, its learned "
                     "low level swings)")
    play.add_argument("--human", choices=("none", "0", "1"), default="0",
                      help="the player your keys control, 0 or 1; none: watch the computer "
                           "play both")
    play.add_argument("--policy", default=None,
                      help="the low level (default: scripted; humanlike: pretrained); in "
                           "competitive SIMPLE play, with --high, the opponent's instead of "
                           "--opponent")
    play.add_argument("--high", default=None,
                      help="the computer's goals (default: random; humanlike: pretrained); in "
                           "competitive SIMPLE play, with --policy, the opponent's instead of "
                           "--opponent")
    play.add_argument("--mode", choices=("cooperative", "competitive"), default="competitive",
                      help="competitive: the players play for points, scored in games; "
                           "cooperative: they keep the rally going")
    play.add_argument("--opponent", metavar="NAME",
                      help="competitive SIMPLE play with a person at the keyboard: the agent "
                           f"you play against (default: {DEFAULT_OPPONENT}, the shipped "
                           "champion): simple_compete, scripted, random, hrl, mono or an "
                           "exported policy's path prefix; --policy and --high instead make "
                           "the opponent of those levels")
    play.add_argument("--seconds", type=positive_seconds, default=None,
                      help="close the window after this many seconds (default: when you close it)")
    add_shuttle_and_seed(play)
    play.set_defaults(run=run)


@numpy_policies
def run(args: argparse.Namespace) -> int:
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
    low, high = policies(args)
    high_level, low_level = rally_policies(args.player, low, high, args.seed)
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
        low, high = policies(args)
        high_level, low_level = rally_policies("simple", low, high, args.seed)
        return Hierarchical(high_level, low_level, f"{Path(high).name} goals")
    return agent(args.opponent or DEFAULT_OPPONENT, "simple", args.seed)
