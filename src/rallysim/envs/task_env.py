"""The single-environment view of a one-player task, written once for every player model.

A task object (``ReturnTask``, ``HumanLikeReturnTask``) holds N = 1 game and answers
``reset(units, options)``, ``step(actions) -> (reward, terminated, truncated, info arrays)``,
``observe()`` and ``goal``; this class adds Gymnasium's single-env conventions on top.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from rallysim.envs.rendering import EnvView
from rallysim.envs.validation import validate_actions, validate_seed


def box_spaces(obs_size: int, action_size: int) -> tuple[spaces.Box, spaces.Box]:
    """Observation and action spaces of one player: both scaled to [-1, 1]."""
    return (spaces.Box(-1.0, 1.0, (obs_size,), np.float32),
            spaces.Box(-1.0, 1.0, (action_size,), np.float32))


def _scalar(v: np.ndarray) -> Any:
    return v.item() if np.ndim(v) == 0 else np.copy(v)


class TaskEnv(gym.Env):
    """One environment of a one-player task. Subclasses set ``goal_key`` (the goal's info key),
    ``hit_keys`` and ``landing_keys`` (info values given only when that event happened) and
    draw frames in ``_frame(view, env)``."""

    goal_key = "goal"
    hit_keys: tuple[str, ...] = ()
    landing_keys: tuple[str, ...] = ()

    def _init_task(self, task: Any, obs_size: int, action_size: int,
                   render_mode: str | None, view_kwargs: dict) -> None:
        self.render_mode = render_mode
        self._view = EnvView(render_mode, n_players=1, **view_kwargs)
        self.observation_space, self.action_space = box_spaces(obs_size, action_size)
        self.task = task
        self._done = True

    def _frame(self, view: EnvView, env: int) -> np.ndarray | None:
        raise NotImplementedError

    def reset(self, *, seed: int | None = None, options: dict[str, Any] | None = None):
        # checked before a stream is restarted: a rejected reset changes nothing
        self.task.reset_options(options, 1)
        super().reset(seed=validate_seed(seed))
        if seed is not None:
            self.task.game.seed(np.array([0]), seed)
        self.task.reset(np.array([0]), options)
        self._done = False
        self._view.new_episode()
        if self.render_mode == "human":
            self.render()
        return self.task.observe()[0], {self.goal_key: _scalar(self.task.goal[0])}

    def render(self) -> np.ndarray | None:
        return self._frame(self._view, 0)

    def close(self) -> None:
        self._view.close()

    def step(self, action):
        if self._done:
            raise RuntimeError("the episode has ended (or never began): call reset() first")
        a = validate_actions(action, self.action_space.shape)
        reward, term, trunc, info = self.task.step(a[None, :])
        self._done = bool(term[0] or trunc[0])
        if self.render_mode == "human":
            self.render()
        # Event values appear only when their event happened (Gymnasium's single-env habit).
        keep = {"hit", "net_touch", "landed", self.goal_key}
        if info["hit"][0]:
            keep |= set(self.hit_keys)
        if info["landed"][0]:
            keep |= set(self.landing_keys)
        return (self.task.observe()[0], float(reward[0]), bool(term[0]), bool(trunc[0]),
                {k: _scalar(v[0]) for k, v in info.items() if k in keep})
