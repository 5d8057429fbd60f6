"""The single-environment view of a one-player task, written once for every player model.

A task object (``ReturnTask``, ``HumanLikeReturnTask``) holds N = 1 game and answers
``reset(units, options)``, ``outcome(actions) -> (reward, terminated, truncated, info values)``
(the vector envs' ``step`` before their vector-only info keys, as arrays), ``observe()`` and
``goal``; this class adds Gymnasium's single-env conventions on top.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces

from rallysim.core.validation import validate_action_row, validate_seed
from rallysim.envs.rendering import EnvView


def box_spaces(obs_size: int, action_size: int) -> tuple[spaces.Box, spaces.Box]:
    """Observation and action spaces of one player: both scaled to [-1, 1]."""
    return (spaces.Box(-1.0, 1.0, (obs_size,), np.float32),
            spaces.Box(-1.0, 1.0, (action_size,), np.float32))


def _first(v: Any) -> Any:
    """Environment 0's value of an array: a Python scalar, or a copy of its row."""
    return v.item(0) if v.ndim == 1 else v[0].copy()


class TaskEnv(gym.Env):
    """One environment of a one-player task. Subclasses set ``goal_key`` (the goal's info key),
    ``reward_keys`` (the reward's terms), ``hit_keys`` and ``landing_keys`` (info values given
    only when that event happened) and draw frames in ``_frame(view, env)``."""

    goal_key = "goal"
    reward_keys: tuple[str, ...] = ()  # the reward's terms, given every step
    hit_keys: tuple[str, ...] = ()
    landing_keys: tuple[str, ...] = ()
    _info_keys: tuple[str, ...]  # the info keys given every step, per subclass

    def __init_subclass__(cls, **kwargs: Any) -> None:
        super().__init_subclass__(**kwargs)
        cls._info_keys = ("hit", "net_touch", "landed", cls.goal_key, *cls.reward_keys)

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
        return self.task.observe()[0], {self.goal_key: _first(self.task.goal)}

    def render(self) -> np.ndarray | None:
        return self._frame(self._view, 0)

    def close(self) -> None:
        self._view.close()

    def step(self, action):
        if self._done:
            raise RuntimeError("the episode has ended (or never began): call reset() first")
        a = validate_action_row(action, self.action_space.shape)
        reward, term, trunc, values = self.task.outcome(a)
        terminated, truncated = bool(term[0]), bool(trunc[0])
        self._done = terminated or truncated
        if self.render_mode == "human":
            self.render()
        return (self.task.observe()[0], reward.item(0), terminated, truncated,
                self._info(values))

    def _info(self, values: dict) -> dict:
        """The info of the task's values. Event values appear only when their event happened
        (Gymnasium's single-env habit)."""
        info: dict[str, Any] = {}
        _put_firsts(info, values, self._info_keys)
        if info["hit"]:
            _put_firsts(info, values, self.hit_keys)
        if info["landed"]:
            _put_firsts(info, values, self.landing_keys)
        return info


def _put_firsts(info: dict, values: dict, keys: tuple[str, ...]) -> None:
    """``info[k] = _first(values[k])`` for ``keys``."""
    for k in keys:
        info[k] = _first(values[k])
