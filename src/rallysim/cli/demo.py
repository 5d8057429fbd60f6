"""``rallysim demo``: play the low-level task and print what happened."""

from __future__ import annotations

import argparse
import time

from rallysim.cli.common import (
    add_command,
    add_player,
    add_shuttle_and_seed,
    numpy_policies,
    positive,
)


def add_parser(sub: argparse._SubParsersAction) -> None:
    demo = add_command(sub, "demo", "play the low-level task and print what happened")
    demo.add_argument("--episodes", type=positive, default=2000, help="episodes to play")
    demo.add_argument("--envs", type=positive, default=256,
                      help="environments stepped together (a batch)")
    demo.add_argument("--policy", default="scripted",
                      help="scripted, random, pretrained or a policy path prefix")
    add_player(demo, "the low-level task's player (humanlike: RallySim/HumanLikeReturn-v0, "
                     "scripted = AimedSwing)")
    add_shuttle_and_seed(demo)
    demo.set_defaults(run=run)


@numpy_policies
def run(args: argparse.Namespace) -> int:
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
