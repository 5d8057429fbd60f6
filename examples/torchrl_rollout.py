"""TorchRL over RallySim: GymEnv on the registered id, and PettingZooWrapper on the rally.

    python examples/torchrl_rollout.py             # 2,000 steps of each env
    python examples/torchrl_rollout.py --smoke     # 200 steps of each (CI)

Three rollouts with a random policy, each a TensorDict of the steps:

1. ``GymEnv("RallySim/SimpleReturn-v1", goals="uniform")``: TorchRL builds the registered single
   env by id (the paper's task: v1 with v0's uniform goals).
2. ``GymWrapper(gym.make_vec(..., vectorization_mode="vector_entry_point"))``: the same task,
   64 environments in one batched MuJoCo model (TorchRL needs a vector env that resets in the
   same step, ``autoreset_mode="same_step"``).
3. ``PettingZooWrapper(simple_rally_v0.parallel_env())``: the two-player rally; both players
   are one TorchRL group, ``"player"``, with observations (2, 20) and actions (2, 3).

Prints each rollout's speed and a ``result:`` line with its steps, finished episodes and the
mean reward per step.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import torch
from torchrl.envs import GymEnv, GymWrapper, PettingZooWrapper

import rallysim  # noqa: F401  (registers the RallySim/... ids)
from rallysim.envs.simple_rally_v0 import parallel_env

# The paper's low-level task: SimpleReturn-v1 with goals="uniform" is SimpleReturn-v0 step for
# step (v1 only changes the default goal distribution), without Gymnasium's notice that
# v0 is out of date.
ENV_ID = "RallySim/SimpleReturn-v1"
ENV_KWARGS = {"goals": "uniform"}


def rollout(name: str, env, steps: int, reward_key, done_key) -> None:
    """``steps`` random steps of ``env`` (reset as episodes end); print speed and result."""
    env.set_seed(0)
    torch.manual_seed(0)
    start = time.perf_counter()
    td = env.rollout(steps, break_when_any_done=False)  # random actions from the action spec
    wall = time.perf_counter() - start
    batch = env.batch_size.numel()  # environments stepped together
    reward = td["next", *reward_key]
    episodes = int(td["next", *done_key].sum())
    env_steps = td.shape.numel()
    print(f"speed: {name}: {env_steps / wall:,.0f} env steps/s ({env_steps:,} steps, "
          f"{batch} env(s), {wall:.2f} s)")
    print(f"result: env={name} steps={td.shape[-1]} env_steps={env_steps} "
          f"episodes={episodes} mean_step_reward={reward.mean().item():.4f} "
          f"steps_per_s={env_steps / wall:.0f}")
    env.close()


def positive_int(text: str) -> int:
    value = int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=positive_int,
                        help="rollout steps per env (default 2,000)")
    parser.add_argument("--smoke", action="store_true", help="200 steps (unless --steps)")
    args = parser.parse_args()
    steps = args.steps if args.steps is not None else (200 if args.smoke else 2000)

    # 1. TorchRL makes the registered id itself (one env, one MuJoCo model)
    rollout("GymEnv", GymEnv(ENV_ID, **ENV_KWARGS), steps, ("reward",), ("done",))

    # 2. the batched vector env wrapped: one rollout step is a step of all 64 environments
    vec = gym.make_vec(ENV_ID, num_envs=64, vectorization_mode="vector_entry_point",
                       autoreset_mode="same_step", **ENV_KWARGS)
    rollout("GymWrapper-make_vec-x64", GymWrapper(vec), steps, ("reward",), ("done",))

    # 3. the PettingZoo parallel rally; a rally ends for both players at once, and each
    # player's reward is under the group "player" (the rally's "done" is the root key)
    rally = PettingZooWrapper(parallel_env(), use_mask=False)
    rollout("PettingZooWrapper-simple_rally_v0", rally, steps, ("player", "reward"),
            ("done",))


if __name__ == "__main__":
    main()
