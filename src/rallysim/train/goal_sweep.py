"""The high stage's start: a short sweep of fixed goals over the frozen low level, whose best
goal becomes the untrained high level's mean action.

A low level returns some goals far better than others, and which ones depends on the run (its
seed, and the numerics it trained under). An untrained high level aims every shot at the centre
of the goal range, with a spread of about a third of it. Where the centre is a poor goal, every
rally ends within a few hits, the returns carry little signal, and PPO can spend most of its
budget finding the band of good goals (docs/research-log/reproduce.md, "Why a high level climbed
slowly"). The sweep plays ``rallies`` rallies at each of ``points`` evenly spaced goals per
axis, both players holding that goal for the whole rally, and starts PPO's Gaussian at the goal
with the longest mean rally, one grid step wide, so that its first rollouts are rallies inside
the band rather than misses around it. The sweep's rallies use the training seed's stream, not
the evaluation's, and the low-level decisions they simulate count in the hierarchy's budget like
the high stage's own.
"""

from __future__ import annotations

import itertools
from typing import Any

import numpy as np

from rallysim.core.tasks.rally import RallyConfig
from rallysim.players import PlayerSpec
from rallysim.policies.types import LowLevel

SWEEP_SEED_OFFSET = 7_919  # the sweep's rallies: a stream apart from the training envs'


def action_grid(points: int, size: int) -> np.ndarray:
    """(points**size, size) evenly spaced high-level actions in [-1, 1] per axis."""
    axis = np.linspace(-1.0, 1.0, points)
    return np.array(list(itertools.product(axis, repeat=size)), np.float64).reshape(-1, size)


def sweep_goals(player: PlayerSpec, low_level: LowLevel | str, points: int, rallies: int,
                seed: int, config: RallyConfig | None = None) -> dict[str, Any]:
    """Play ``rallies`` rallies at each goal of ``action_grid(points, goal size)``; return the
    grid, each goal's mean rally, the best action, and the decisions and turns it cost."""
    from rallysim.eval.rally_eval import play_turns

    if points < 2 or rallies < 1:
        raise ValueError(f"a goal sweep needs points >= 2 and rallies >= 1, got {points} and "
                         f"{rallies}")
    grid = action_grid(points, player.goal.size)
    goals = player.goal.from_action(np.repeat(grid, rallies, axis=0))
    lengths, decisions, turns = play_turns(np.asarray(goals, np.float64), low_level,
                                           len(goals), seed + SWEEP_SEED_OFFSET, config,
                                           player=player)
    means = lengths.reshape(len(grid), rallies).mean(axis=1)
    best = int(np.argmax(means))  # the first of equals: deterministic
    return {"points": points, "rallies_per_goal": rallies,
            "actions": grid.tolist(), "mean_rally": [float(m) for m in means],
            "best_action": grid[best].tolist(), "best_mean_rally": float(means[best]),
            "decisions": decisions, "turns": turns}


def start_at(model: Any, action: np.ndarray, spread: float) -> None:
    """Start an SB3 Gaussian policy at ``action`` (in [-1, 1] per axis, mapped onto the
    model's action space) with a standard deviation of ``spread`` in those units: the mean
    through the bias of its last layer (its weights, small at initialisation, leave the mean
    within a few hundredths of it), the spread through its state-independent log-std."""
    import torch

    space = model.action_space
    low, high = np.asarray(space.low, np.float64), np.asarray(space.high, np.float64)
    mean = low + 0.5 * (np.asarray(action, np.float64) + 1.0) * (high - low)
    std = 0.5 * spread * (high - low)
    with torch.no_grad():
        model.policy.action_net.bias.copy_(torch.as_tensor(mean, dtype=torch.float32))
        model.policy.log_std.copy_(torch.as_tensor(np.log(std), dtype=torch.float32))


def grid_step(points: int) -> float:
    """The spacing of ``action_grid(points, ...)`` along an axis."""
    return 2.0 / (points - 1)
