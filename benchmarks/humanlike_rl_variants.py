"""What PPO alone learns on the HUMAN-LIKE low level under reshaped velocity rewards (issue 15's
exploration; the env's own reward is the paper's): one seed per variant, scored on fresh serves.

The task's hit reward is 0.5 (1 + exp(-1.5 d)), d = |v - v*| in m/s: once d is a few m/s the
velocity term is flat, so PPO learns to hit hard and ignores the target. Variants replace the
velocity term on a hit (a wrapper; the registered env is unchanged):

- ``paper``: unchanged;
- ``exp:K``: 0.5 exp(-K d) (a wider kernel than 1.5);
- ``only:K``: the whole hit reward is exp(-K d) (no fixed part for hitting at all);
- ``cos:K``: 0.25 cos(angle error) + 0.25 exp(-K |speed error|) (the angle and the relative
  speed apart).

PPO settings are the low stage's (64x64 tanh, 256 envs x 16 steps, minibatch 1024, 10 epochs,
lr 3e-4 annealed, log-std -0.5); SB3 learns in four equal calls with a deterministic evaluation
on 256 serves (seed 12345) after each. ``--export PREFIX`` writes the last policy as a
shippable policy (safetensors + JSON).

    python benchmarks/humanlike_rl_variants.py --variant cos:2 --budget 3000000 --seed 0 \
        --export runs/humanlike_rl_cos2 --json runs/humanlike_rl_cos2_curve.json
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np
import torch
from stable_baselines3 import PPO

from rallysim.envs.humanlike_return_v0 import HumanLikeReturnVectorEnv
from rallysim.envs.registration import HUMANLIKE_RETURN_ID
from rallysim.eval.humanlike_eval import evaluate_humanlike
from rallysim.train.config import load_config
from rallysim.train.export import save_policy
from rallysim.train.sb3_vec import NativeVecEnv

KINDS = ("paper", "exp", "only", "cos")
MEASURES = ("hit_rate", "mean_angle_error", "mean_abs_speed_error", "mean_reward")


class VelocityReward(gym.vector.VectorWrapper):
    """The hit's reward with another velocity term (see the module's list)."""

    def __init__(self, env: gym.vector.VectorEnv, kind: str, k: float) -> None:
        super().__init__(env)
        self.kind, self.k = kind, k

    def step(self, actions: np.ndarray) -> tuple[Any, ...]:
        obs, reward, terminated, truncated, info = self.env.step(actions)
        hit = info["hit"]
        if hit.any():
            d = np.nan_to_num(info["velocity_error"], nan=10.0)
            if self.kind == "exp":
                term = 0.5 * np.exp(-self.k * d)
            elif self.kind == "only":
                term = np.exp(-self.k * d) - 0.5
            else:  # cos
                angle = np.deg2rad(np.nan_to_num(info["angle_error"], nan=180.0))
                speed = np.nan_to_num(np.abs(info["speed_error"]), nan=1.0)
                term = 0.25 * np.cos(angle) + 0.25 * np.exp(-self.k * speed)
            reward = np.where(hit, 0.5 + term, reward)
        return obs, reward, terminated, truncated, info


def parse_variant(text: str) -> tuple[str, float]:
    """``paper``, or ``KIND:K`` with KIND one of exp, only, cos: ``(kind, k)``."""
    kind, _, k = text.partition(":")
    if kind not in KINDS or (kind != "paper") != bool(k):
        raise argparse.ArgumentTypeError(f"variant: paper, exp:K, only:K or cos:K; got {text!r}")
    return kind, float(k) if k else 0.0


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variant", type=parse_variant, default=("paper", 0.0))
    parser.add_argument("--budget", type=int, default=3_000_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--export", type=Path, help="write the final policy to this prefix")
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    if args.export is not None and args.json == args.export.with_suffix(".json"):
        parser.error("--json would overwrite the exported policy's JSON: name another file")
    kind, k = args.variant
    torch.set_num_threads(1)
    ppo = load_config("low").ppo
    base = HumanLikeReturnVectorEnv(ppo.n_envs, autoreset_mode="same_step", seed=args.seed)
    env = NativeVecEnv(base if kind == "paper" else VelocityReward(base, kind, k))
    model = PPO("MlpPolicy", env, seed=args.seed, device="cpu", verbose=0, **ppo.sb3_kwargs())
    evals = []
    t0 = time.perf_counter()
    for _ in range(4):
        model.learn(args.budget // 4, reset_num_timesteps=False)
        scores = evaluate_humanlike(lambda o: model.predict(o, deterministic=True)[0],
                                    episodes=256, seed=12345)
        evals.append({"steps": model.num_timesteps, **{m: scores[m] for m in MEASURES},
                      "wall_s": round(time.perf_counter() - t0)})
        print(json.dumps(evals[-1]), flush=True)
    if args.export is not None:
        save_policy(model, args.export, env_id=HUMANLIKE_RETURN_ID, metadata={
            "stage": "low", "player": "humanlike", "seed": args.seed,
            "steps": model.num_timesteps, "reward": [kind, k], "final": evals[-1],
            "source": "benchmarks/humanlike_rl_variants.py"})
    if args.json is not None:
        args.json.write_text(json.dumps({"variant": [kind, k], "budget": args.budget,
                                         "seed": args.seed, "evals": evals}, indent=1))


if __name__ == "__main__":
    main()
