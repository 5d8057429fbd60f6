"""Evaluation of HUMAN-LIKE low-level policies on ``RallySim/HumanLikeReturn-v0``.

Each environment plays one episode, seeded ``seed + i``; the racket velocity at the hit is
compared with the episode's target (SPEC §10): hit rate, angle error in degrees, relative speed
error. Targets of issue 5: hit rate >= 90 %, mean angle error <= 5 degrees, speed error <= 10 %.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from rallysim.envs.humanlike_return_v0 import HumanLikeReturnVectorEnv

Policy = Callable[[np.ndarray], np.ndarray]  # (N, 85) observations -> (N, 15) actions


def evaluate_humanlike(policy: Policy, episodes: int = 256, seed: int = 12345,
                       shuttle: str = "paper") -> dict[str, Any]:
    env = HumanLikeReturnVectorEnv(episodes, shuttle=shuttle, autoreset_mode="same_step")
    obs, _ = env.reset(seed=seed)
    ret = np.zeros(episodes)
    hit = np.zeros(episodes, bool)
    angle = np.full(episodes, np.nan)
    speed = np.full(episodes, np.nan)
    done = np.zeros(episodes, bool)
    while not done.all():
        obs, reward, term, trunc, info = env.step(np.asarray(policy(obs), np.float32))
        live = ~done
        ret[live] += reward[live]
        now = live & info["hit"]
        hit |= now
        angle[now], speed[now] = info["angle_error"][now], info["speed_error"][now]
        done |= live & (term | trunc)
    return {
        "episodes": episodes,
        "mean_reward": float(ret.mean()),
        "hit_rate": float(hit.mean()),
        "mean_angle_error": float(np.nanmean(angle)) if hit.any() else float("nan"),
        "median_angle_error": float(np.nanmedian(angle)) if hit.any() else float("nan"),
        "mean_abs_speed_error": float(np.nanmean(np.abs(speed))) if hit.any() else float("nan"),
    }
