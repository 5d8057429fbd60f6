"""Evaluation of HUMAN-LIKE low-level policies on ``RallySim/HumanLikeReturn-v0``, and of
the 3-D rally they play.

Each environment plays one episode, seeded ``seed + i``; the racket velocity at the hit is
compared with the episode's target (docs/reference.md §10): hit rate, angle error in degrees,
relative speed error. Targets of issue 5: hit rate >= 90 %, mean angle error <= 5 degrees, speed
error <= 10 %, and a mean rally of at least 10 hits.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rallysim.envs.humanlike_return_v0 import HumanLikeReturnVectorEnv
from rallysim.policies.types import HighLevel, Policy

TARGETS = {"hit_rate": 0.9, "mean_angle_error": 5.0, "mean_abs_speed_error": 0.1,
           "mean_rally": 10.0}


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


def rally_goals(spec: str, seed: int = 0) -> HighLevel:
    """The 3-D rally's high level: ``centre`` (every goal (0, 0, 0): 3 m/s at 45 deg straight
    over the net), ``random`` (goals ~ U[-1, 1]^3), ``pretrained`` (the shipped one, trained
    over the shipped low level) or the path prefix of a trained policy."""
    from rallysim.policies.registry import resolve

    return resolve("fixed:0,0,0" if spec == "centre" else spec, "high", "humanlike", seed)


def evaluate_humanlike_player(low: str = "pretrained", high: str = "pretrained",
                              episodes: int = 500, rallies: int = 100, seeds: int = 3,
                              shuttle: str = "paper") -> dict[str, Any]:
    """A HUMAN-LIKE low level (``scripted``, ``pretrained`` or a path prefix) on ``episodes``
    serves, and the 3-D rally it plays for ``high``'s goals (``rallies`` x ``seeds``)."""
    from rallysim.core.tasks.rally import RallyConfig
    from rallysim.eval.rally_eval import rally_lengths_turns
    from rallysim.eval.stats import summarise_rallies
    from rallysim.policies.registry import goal_conditioned, resolve

    if min(episodes, rallies, seeds) < 1:
        raise ValueError("episodes, rallies and seeds must be >= 1")
    policy = resolve(low, "low", "humanlike")  # loaded once: the serves' and the rally's player
    returns = evaluate_humanlike(policy, episodes, shuttle=shuttle)
    low_level = goal_conditioned(policy, "humanlike")
    groups = [rally_lengths_turns(rally_goals(high, 1000 * s), low_level, rallies, 1000 * s,
                                  RallyConfig(shuttle=shuttle), player="humanlike")
              for s in range(seeds)]
    return {"policies": {"low": low, "high": high}, "shuttle": shuttle, "targets": TARGETS,
            "low_level": returns, "rally": summarise_rallies(groups).to_dict(),
            "lengths": [g.tolist() for g in groups]}
