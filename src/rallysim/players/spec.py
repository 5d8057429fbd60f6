"""What makes a player kind: one frozen ``PlayerSpec`` per kind (``rallysim.players.PLAYERS``).

The rulebook (``rallysim.core``) works for any ``PlayerBodies``; everything else that differs
between player kinds (observation and action layouts, the start and the serve, the goal a high
level gives the low level, the scripted low level, the render rig) is declared here once, and
the tasks, views, policies, training and rendering read it from the spec instead of switching on
the kind's name.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from functools import cached_property
from typing import Any

import numpy as np

from rallysim.core.layout import Layout


def _read_only(a: np.ndarray) -> np.ndarray:
    a.setflags(write=False)
    return a


@dataclass(frozen=True)
class GoalSpec:
    """The goal a turn-based high level hands the low level: ``size`` values within
    [``low``, ``high``] (``size`` 1: a scalar goal), ``default`` before any choice.

    A high-level network's action ``a`` in [-1, 1]^size becomes the goal
    ``centre + half_range * clip(a, -1, 1)``, so the action's midpoint is the goal range's."""

    size: int
    low: tuple[float, ...]
    high: tuple[float, ...]
    default: float | tuple[float, ...]
    unit: str
    mapping: str  # how a high-level action becomes the goal, in words (exports record it)

    @cached_property
    def centre(self) -> np.ndarray:
        return _read_only(0.5 * (np.asarray(self.low) + np.asarray(self.high)))

    @cached_property
    def half_range(self) -> np.ndarray:
        return _read_only(0.5 * (np.asarray(self.high) - np.asarray(self.low)))

    @property
    def shape(self) -> tuple[int, ...]:
        """One goal's shape: () for a scalar goal, (size,) otherwise."""
        return () if self.size == 1 else (self.size,)

    def from_action(self, action: Any) -> np.ndarray:
        """High-level actions (M, size), or (M,) for a scalar goal -> goals, one row each:
        ``centre + half_range * clip(a, -1, 1)``. The action's dtype is kept (a float32
        network's goals stay float32), as every trainer and loader has always mapped them."""
        a = np.clip(np.asarray(action), -1.0, 1.0)
        if self.size == 1:
            return float(self.centre[0]) + float(self.half_range[0]) * a.reshape(-1)
        a = a.reshape(-1, self.size)
        if np.array_equal(self.centre, 0.0) and np.array_equal(self.half_range, 1.0):
            return a
        return self.centre + self.half_range * a

    def clip(self, goals: Any) -> np.ndarray:
        """Goals as finite float64 values clipped into the goal range; NaN or inf raise
        ``ValueError``."""
        g = np.asarray(goals, dtype=np.float64)
        if not np.all(np.isfinite(g)):
            raise ValueError(f"goals must be finite, got {goals!r}")
        if self.size == 1:
            return np.clip(g, self.low[0], self.high[0])
        return np.clip(g, self.low, self.high)

    def sample(self, rng: np.random.Generator, n: int) -> np.ndarray:
        """``n`` goals drawn uniformly from the goal range: (n,) or (n, size)."""
        if self.size == 1:
            return rng.uniform(self.low[0], self.high[0], n)
        return rng.uniform(self.low, self.high, (n, self.size))


@dataclass(frozen=True)
class StartPose:
    """Where a rally's players start, in their own frames (index: player 0, player 1)."""

    base_x: tuple[float, float]
    base_y: tuple[float, float] | None = None  # None: the bodies have no y freedom


@dataclass(frozen=True)
class PlayerSpec:
    """One player kind. Its callables are module-level functions or classes, so that what
    they make pickles."""

    name: str
    asset: str  # MJCF file in rallysim/assets
    make_bodies: Callable[[int, int], Any]  # (n_envs, n_players) -> PlayerBodies
    obs: Layout  # what a player observes of itself and the shuttle, own frame, in [-1, 1]
    low_obs: Layout  # the low-level task's observation: ``obs`` and the goal's encoding
    rally_obs: Layout  # the rally's observation: ``obs``, the opponent, "my turn"
    action: Layout
    goal: GoalSpec
    start: StartPose
    serve: Any  # the serve that starts each rally (a rallysim.core.serve strategy)
    observe: Callable[[Any], np.ndarray]  # Game -> (N, P, obs.size), scaled, not yet clipped
    # Game, extra (N, P, X), centre (X,), scale (X,) -> (N, P, obs.size + X) float32: ``obs``
    # then (extra - centre) / scale, all clipped into [-1, 1]
    observe_with: Callable[[Any, np.ndarray, np.ndarray, np.ndarray], np.ndarray]
    opponent: Callable[[Any], np.ndarray]  # Game -> (N, 2, 3) the opponent's position, own frame
    low_observations: Callable[[np.ndarray, np.ndarray], np.ndarray]  # rally obs, goals -> low
    scripted_low: Callable[[], Callable]  # () -> the rally's scripted low level (obs, goals)
    scripted_task_low: Callable[[], Callable]  # () -> the low-level task's scripted policy
    camera: str  # the default render camera (a rallysim.render.model.CAMERAS name)
    low_env_id: str  # the Gymnasium id of the low-level task
    # The render rig (rallysim.render.players.PlayerRig) as "module:Class": what draws this kind,
    # its goals and targets, and its keyboard player. Only rallysim.render imports it.
    rig: str
