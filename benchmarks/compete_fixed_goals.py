"""How many points a depth-only competitive policy can win: fixed goals against the scripted
controller and the cooperative HRL agent.

Run: ``python benchmarks/compete_fixed_goals.py [--games N] [--seed S]``

A SIMPLE high level chooses one thing, the landing depth (2 to 6 m beyond the net) its low
level aims for. This plays a player that always asks for the same depth, over the shipped low
level (``simple_low``) and over the scripted controller, against ``scripted`` and ``hrl``, and
prints its point-win rate with a 95 % interval over games: the yardstick for what the compete
stage's champion (``docs/competitive.md``) learns, and for its targets.
"""

from __future__ import annotations

import argparse
import time

from rallysim.eval.agents import Hierarchical, agent
from rallysim.eval.competitive import play_games, summarise
from rallysim.policies.callables import FixedGoal
from rallysim.policies.registry import resolve

GOALS = (2.0, 3.0, 4.0, 5.0, 6.0)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--games", type=int, default=16)
    parser.add_argument("--seed", type=int, default=3)
    parser.add_argument("--max-decisions", type=int, default=20_000)
    args = parser.parse_args()
    print("| low level | goal (m) | vs scripted | vs hrl | seconds |")
    print("|---|---:|---|---|---:|")
    for low in ("pretrained", "scripted"):
        for goal in GOALS:
            t = time.perf_counter()
            cells = []
            for opponent in ("scripted", "hrl"):
                me = Hierarchical(FixedGoal(goal), resolve(low, "rally_low"), f"fixed {goal}")
                games = play_games(me, agent(opponent), args.games, args.seed,
                                   max_decisions=args.max_decisions)
                p = summarise(games, seed=args.seed)["point_win_rate"]
                cells.append(f"{p['value']:.3f} [{p['low']:.3f}, {p['high']:.3f}]")
            name = "simple_low" if low == "pretrained" else "scripted"
            print(f"| {name} | {goal:.1f} | {cells[0]} | {cells[1]} | "
                  f"{time.perf_counter() - t:.0f} |", flush=True)


if __name__ == "__main__":
    main()
