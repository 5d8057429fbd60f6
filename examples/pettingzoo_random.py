"""Random actions in the PettingZoo parallel rally: how fast one rally steps through its API.

    python examples/pettingzoo_random.py             # 5,000 rally steps
    python examples/pettingzoo_random.py --smoke     # 500 (CI)

``rallysim.envs.simple_rally_v0.parallel_env()`` is one rally, both players acting every
decision (0.1 s); a rally step is one decision of each player. The actions are uniform in
[-1, 1], drawn from a seeded NumPy generator, so a seed gives the same rallies. A rally that
ends is reset, continuing the seeded stream. Needs only RallySim itself (PettingZoo is one of
its dependencies).

Prints the speed and a ``result:`` line: rally steps, rallies finished, and the mean rally
length (hits by both players) of the finished rallies.
"""

from __future__ import annotations

import argparse
import time

import numpy as np

from rallysim.envs.simple_rally_v0 import parallel_env


def positive_int(text: str) -> int:
    value = int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=positive_int, help="rally steps (default 5,000)")
    parser.add_argument("--smoke", action="store_true", help="500 steps (unless --steps)")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    steps = args.steps if args.steps is not None else (500 if args.smoke else 5000)

    rng = np.random.default_rng(args.seed)
    env = parallel_env()
    env.reset(seed=args.seed)
    lengths: list[int] = []
    start = time.perf_counter()
    for _ in range(steps):
        actions = {a: rng.uniform(-1.0, 1.0, 3).astype(np.float32) for a in env.agents}
        infos = env.step(actions)[4]
        if not env.agents:  # the rally is over for both players
            lengths.append(int(infos["player_0"]["rally_length"]))
            env.reset()
    wall = time.perf_counter() - start
    env.close()
    print(f"speed: {steps / wall:,.0f} rally steps/s ({2 * steps / wall:,.0f} player "
          f"decisions/s; {steps:,} steps in {wall:.2f} s)")
    mean = np.mean(lengths) if lengths else float("nan")
    print(f"result: steps={steps} steps_per_s={steps / wall:.0f} rallies={len(lengths)} "
          f"mean_rally={mean:.3f}")


if __name__ == "__main__":
    main()
