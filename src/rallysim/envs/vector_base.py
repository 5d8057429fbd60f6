"""Autoreset and seeding for RallySim's native vector envs, written once.

A native vector env steps *units* (games) in one call; each unit fills ``slots_per_unit``
consecutive slots of the batch (1 for the low-level task, 2 for a rally seen player by player).
Subclasses implement ``_seed_units``, ``_reset_units``, ``_step_units`` and ``_observe``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium.vector import VectorEnv

from rallysim.core.validation import (
    check_options,
    positive_int,
    validate_actions,
    validate_seed,
)

try:  # Gymnasium >= 1.1
    from gymnasium.vector import AutoresetMode

    NEXT_STEP, SAME_STEP = AutoresetMode.NEXT_STEP, AutoresetMode.SAME_STEP
except ImportError:  # pragma: no cover - Gymnasium 1.0
    NEXT_STEP, SAME_STEP = "NextStep", "SameStep"

AUTORESET_MODES = {"next_step": NEXT_STEP, "same_step": SAME_STEP}


def parse_autoreset_mode(mode: Any) -> str:
    """``"next_step"`` or ``"same_step"`` from a string or Gymnasium's ``AutoresetMode``."""
    value = getattr(mode, "value", mode)
    key = {"NextStep": "next_step", "SameStep": "same_step"}.get(value, value)
    if key not in AUTORESET_MODES:
        raise ValueError(f"unknown autoreset_mode {mode!r}; valid: "
                         f"{', '.join(map(repr, AUTORESET_MODES))}")
    return key


class NativeVectorEnv(VectorEnv):
    """Base of the batched envs: next-step or same-step autoreset over units of slots.

    With ``"next_step"`` (Gymnasium's default) a finished unit is reset by the following
    ``step``, which ignores its actions and returns its first observation with zero reward.
    With ``"same_step"`` it is reset at once; its last observation and info are in
    ``info["final_obs"]`` and ``info["final_info"]``, masked by ``info["_final_obs"]``.
    """

    slots_per_unit = 1
    _views: list = []  # renderers of the first units, whose trails restart with each episode

    def _setup(self, num_units: int, autoreset_mode: Any) -> None:
        num_units = positive_int(num_units, "the number of environments")
        key = parse_autoreset_mode(autoreset_mode)
        # both places Gymnasium's own vector envs declare it (TorchRL reads the attribute)
        self.autoreset_mode = AUTORESET_MODES[key]
        self.metadata = {**self.metadata, "autoreset_mode": self.autoreset_mode}
        self._same_step = key == "same_step"
        self.num_units = int(num_units)
        self.num_envs = self.num_units * self.slots_per_unit
        self._needs_reset = np.ones(self.num_units, bool)
        self._pending = np.zeros(0, np.int64)

    def close_extras(self, **kwargs: Any) -> None:
        # (a constructor refused before its views exist leaves the class's empty list)
        for v in self._views:
            v.close()

    # -- for subclasses -------------------------------------------------------------------------
    def _check_options(self, options: dict[str, Any] | None) -> None:
        """Raise ``ValueError`` for reset options this env refuses (default: any)."""
        check_options(options, ())

    def _seed_units(self, seeds: list[int]) -> None:
        raise NotImplementedError

    def _reset_units(self, units: np.ndarray, options: dict | None) -> None:
        raise NotImplementedError

    def _step_units(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """One decision for every unit: slot rewards, unit terminated, unit truncated, info."""
        raise NotImplementedError

    def _observe(self) -> np.ndarray:
        raise NotImplementedError

    def _reset_info(self) -> dict:
        return {}

    def _observe_again(self, obs: np.ndarray, units: np.ndarray) -> np.ndarray:
        """The observation after ``units`` were reset, given ``obs`` from before (which
        it may update in place)."""
        return self._observe()

    def _restart(self, units: np.ndarray, options: dict | None) -> None:
        self._reset_units(units, options)
        if self._views:
            for u in units:
                if u < len(self._views):
                    self._views[u].new_episode()

    def _blank_info(self, info: dict, units: np.ndarray) -> None:
        """Clear the events of ``units`` that were only being reset this step."""
        slots = self._slots(units)
        for key, value in info.items():
            if not isinstance(value, np.ndarray) or len(value) not in (self.num_units,
                                                                      self.num_envs):
                continue
            rows = units if len(value) == self.num_units else slots
            if value.dtype == bool:
                value[rows] = False
            elif np.issubdtype(value.dtype, np.floating):
                value[rows] = np.nan if key.startswith("landing_") else 0.0
            else:
                value[rows] = 0

    # -- the Gymnasium API ----------------------------------------------------------------------
    def _slots(self, units: np.ndarray) -> np.ndarray:
        k = self.slots_per_unit
        return (np.asarray(units)[:, None] * k + np.arange(k)).reshape(-1)

    def reset(self, *, seed: int | list[int] | None = None,
              options: dict[str, Any] | None = None):
        # Seeds and options are checked before a stream is restarted: a rejected reset
        # changes nothing.
        seeds = None if seed is None else self._check_seeds(seed)
        self._check_options(options)
        if seeds is not None:
            self._seed_units(seeds)
        self._restart(np.arange(self.num_units), options)
        self._needs_reset[:] = False
        return self._observe(), self._reset_info()

    def _check_seeds(self, seed: Any) -> list[int]:
        if np.ndim(seed) == 0 and not isinstance(seed, dict | str | bytes):
            first = validate_seed(seed.item() if isinstance(seed, np.ndarray) else seed)
            seeds = [validate_seed(first + i) for i in range(self.num_units)]
        elif isinstance(seed, list | tuple | np.ndarray):
            seeds = [validate_seed(s) for s in seed]
        else:
            raise ValueError(f"seed must be an integer or a list of integers, got {seed!r}")
        if len(seeds) == self.num_envs != self.num_units:  # one per slot: a unit's first
            seeds = seeds[:: self.slots_per_unit]
        if len(seeds) != self.num_units:
            raise ValueError(f"expected {self.num_units} seeds, got {len(seeds)}")
        return seeds

    def step(self, actions):
        pending = np.flatnonzero(self._needs_reset)
        self._pending = pending  # units whose actions are ignored this step
        reward, term, trunc, info = self._step_units(actions)
        if len(pending):  # next-step autoreset: these units ignore their actions and reset
            self._restart(pending, None)
            reward[self._slots(pending)] = 0.0
            term[pending] = trunc[pending] = False
            self._blank_info(info, pending)
        done = term | trunc
        obs = self._observe()
        k = self.slots_per_unit
        if k > 1:
            term, trunc = np.repeat(term, k), np.repeat(trunc, k)
        if self._same_step and done.any():
            slot_done = np.repeat(done, k) if k > 1 else done
            final_info = {key: v.copy() if isinstance(v, np.ndarray) else v
                          for key, v in info.items()}
            final = np.full(obs.shape, np.nan, np.float32)
            final[slot_done] = obs[slot_done]
            info["final_obs"] = final
            info["_final_obs"] = slot_done
            info["final_info"] = final_info
            info["_final_info"] = slot_done.copy()
            units = np.flatnonzero(done)
            self._restart(units, None)
            obs = self._observe_again(obs, units)
        else:
            self._needs_reset = done
        return obs, reward, term, trunc, info


class TaskVectorEnv(NativeVectorEnv):
    """A native vector env over a one-player task object: ``task.game`` (seeded per env),
    ``task.reset(units, options)``, ``task.step(actions)``, ``task.observe(rows=None,
    out=None)`` (with ``rows`` and an earlier observation ``out``: the observation after those
    games were reset, which may reuse ``out``) and ``task.goal``. Subclasses set ``goal_key``
    and ``action_size`` and draw frames in ``_frame(view, env)``."""

    goal_key = "goal"
    action_size = 0

    def _init_task(self, num_envs: int, autoreset_mode: Any, task: Any, spaces: tuple,
                   render_mode: str | None, render_envs: int, view_kwargs: dict) -> None:
        from gymnasium import spaces as gym_spaces

        from rallysim.envs.rendering import EnvView

        self._setup(num_envs, autoreset_mode)
        render_envs = positive_int(render_envs, "render_envs")
        self.render_mode = render_mode
        # one view per rendered environment (each keeps its own shuttle trail)
        self._views = [EnvView(render_mode, 1, **view_kwargs)
                       for _ in range(min(render_envs, self.num_envs))]
        n = self.num_envs
        self.single_observation_space, self.single_action_space = spaces
        obs_size = spaces[0].shape[0]
        self.observation_space = gym_spaces.Box(-1.0, 1.0, (n, obs_size), np.float32)
        self.action_space = gym_spaces.Box(-1.0, 1.0, (n, self.action_size), np.float32)
        self.task = task

    def _seed_units(self, seeds: list[int]) -> None:
        self.task.game.seed_each(seeds)

    def _check_options(self, options: dict[str, Any] | None) -> None:
        self.task.reset_options(options, self.num_units)

    def _reset_units(self, units: np.ndarray, options: dict | None) -> None:
        self.task.reset(units, options)

    def _reset_info(self) -> dict:
        return {self.goal_key: self.task.goal.copy()}

    def _step_units(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        return self.task.step(validate_actions(actions, (self.num_envs, self.action_size)))

    def _observe(self) -> np.ndarray:
        return self.task.observe()

    def _observe_again(self, obs: np.ndarray, units: np.ndarray) -> np.ndarray:
        return self.task.observe(units, obs)

    def _frame(self, view: Any, env: int) -> np.ndarray | None:
        raise NotImplementedError

    def render(self) -> tuple[np.ndarray, ...] | None:
        """Frames of the first ``render_envs`` environments (``"rgb_array"``)."""
        if self.render_mode is None:
            return None
        return tuple(self._frame(v, e) for e, v in enumerate(self._views))

