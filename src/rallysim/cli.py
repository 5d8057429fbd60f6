"""The ``rallysim`` command line."""

from __future__ import annotations

import argparse
import sys
import time

import numpy as np


def _demo(args: argparse.Namespace) -> int:
    """Play the low-level task with the scripted controller and print what happened."""
    from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv
    from rallysim.policies import ScriptedController

    env = SimpleReturnVectorEnv(args.envs, shuttle=args.shuttle, autoreset_mode="same_step")
    controller = ScriptedController()
    obs, _ = env.reset(seed=args.seed)
    returns, hits, errors, ins = [], [], [], []
    episode = np.zeros(args.envs)
    hit = np.zeros(args.envs, bool)
    start = time.perf_counter()
    decisions = 0
    while len(returns) < args.episodes:
        obs, reward, term, trunc, info = env.step(controller.act_return(obs))
        decisions += args.envs
        episode += reward
        hit |= info["hit"]
        for e in np.flatnonzero(term | trunc):
            final = info["final_info"]
            returns.append(episode[e])
            hits.append(hit[e])
            ins.append(final["landed_in"][e])
            if hit[e]:
                errors.append(final["landing_error"][e])
            episode[e], hit[e] = 0.0, False
    elapsed = time.perf_counter() - start
    print(f"RallySim/SimpleReturn-v0, shuttle={args.shuttle!r}, scripted controller, "
          f"{len(returns)} episodes")
    print(f"  mean episode reward   {np.mean(returns):.3f}  (max about 2.0; paper's PPO 1.8)")
    print(f"  hit rate              {np.mean(hits):.3f}")
    print(f"  landed in             {np.mean(ins):.3f}")
    print(f"  median landing error  {np.median(errors):.3f} m")
    print(f"  speed                 {decisions / elapsed:,.0f} decisions/s "
          f"with {args.envs} environments")
    return 0


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="rallysim", description=__doc__)
    sub = parser.add_subparsers(dest="command", required=True)
    demo = sub.add_parser("demo", help="watch the scripted controller play the low-level task")
    demo.add_argument("--episodes", type=int, default=2000)
    demo.add_argument("--envs", type=int, default=256)
    demo.add_argument("--shuttle", default="paper", choices=("paper", "paper-alg1", "aero"))
    demo.add_argument("--seed", type=int, default=0)
    demo.set_defaults(run=_demo)
    args = parser.parse_args(argv)
    return args.run(args)


if __name__ == "__main__":
    sys.exit(main())
