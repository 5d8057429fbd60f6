"""Small policy callables as classes rather than closures, so that an env holding one survives
``copy.deepcopy`` and ``pickle`` (closures and lambdas do not pickle)."""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np


class UniformRandom:
    """Outputs drawn uniformly from [low, high], one row per observation: ``size`` values each,
    or one value each when ``size`` is None. Extra arguments (a goal) are ignored.
    ``seed(s)`` restarts the stream, as an env's ``reset(seed=s)`` does for its own."""

    def __init__(self, size: int | None, seed: int | None = None,
                 low: float | np.ndarray = -1.0, high: float | np.ndarray = 1.0) -> None:
        self.size, self.low, self.high = size, low, high
        self.seed(seed)

    def seed(self, seed: int | None) -> None:
        self.rng = np.random.default_rng(seed)

    def __call__(self, obs: np.ndarray, *_: Any) -> np.ndarray:
        shape = len(obs) if self.size is None else (len(obs), self.size)
        return self.rng.uniform(self.low, self.high, shape)


class FixedGoal:
    """The same goal (a number, or an array for a goal of several values) for every
    observation."""

    def __init__(self, goal: float | np.ndarray) -> None:
        self.goal = goal

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return np.full((len(obs), *np.shape(self.goal)), self.goal)


class Composed:
    """``outer(inner(x))``: a policy whose output is mapped (e.g. an action onto a goal)."""

    def __init__(self, outer: Callable[[np.ndarray], np.ndarray],
                 inner: Callable[[np.ndarray], np.ndarray]) -> None:
        self.outer, self.inner = outer, inner

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        return self.outer(self.inner(obs))


class GoalConditioned:
    """A low-level policy of a return task as a rally's ``(observations, goals) -> actions``
    controller: ``observe(obs, goals)`` builds the return task's observations."""

    def __init__(self, policy: Callable[[np.ndarray], np.ndarray],
                 observe: Callable[[np.ndarray, np.ndarray], np.ndarray]) -> None:
        self.policy, self.observe = policy, observe

    def __call__(self, obs: np.ndarray, goals: np.ndarray) -> np.ndarray:
        return self.policy(self.observe(obs, goals))
