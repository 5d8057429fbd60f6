"""Stable-Baselines3 ``VecEnv`` over one of RallySim's natively batched Gymnasium vector envs.

Users build it by env id with ``rallysim.sb3.make_vec_env`` (the public entry point, also what
``rallysim train`` uses for the low-level tasks); wrapping a vector env by hand works too.

SB3's own ``DummyVecEnv`` holds one Python env object per environment; RallySim's vector envs
step all N environments in one call, so this adapter only translates conventions:

- Gymnasium's ``(obs, reward, terminated, truncated, info-of-arrays)`` becomes SB3's
  ``(obs, reward, dones, infos)`` with ``infos`` a list of N dicts;
- the wrapped env must autoreset in the same step (``autoreset_mode="same_step"``): the returned
  observation of a finished environment is already the first of its next episode, and its last
  observation goes to ``infos[i]["terminal_observation"]`` with ``infos[i]["TimeLimit.truncated"]``
  (SB3 bootstraps the value of truncated episodes from it);
- episode statistics: ``infos[i]["episode"] = {"r": return, "l": length, "t": seconds}`` at the
  end of each episode, as SB3's ``Monitor`` writes them, so the logger shows ``ep_rew_mean``.

Only finished environments get non-empty info dicts. Those also carry the scalar entries of the
env's ``final_info`` (for SimpleReturn: ``landing_error``, ``landed_in``, ...) and, when the env
reports a per-step ``hit``, ``"hit"``: whether the player hit the shuttle during the episode.

``get_attr``/``set_attr``/``env_method`` act on the one batched env: ``get_attr`` returns its
attribute once per requested index, ``env_method`` calls the method once and returns its result
once per requested index.
"""

from __future__ import annotations

import time
from collections.abc import Iterable, Sequence
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium.vector import VectorEnv
from stable_baselines3.common.vec_env.base_vec_env import (
    VecEnv,
    VecEnvIndices,
    VecEnvObs,
    VecEnvStepReturn,
)

from rallysim.envs.vector_base import parse_autoreset_mode


class NativeVecEnv(VecEnv):
    """SB3 ``VecEnv`` view of a batched Gymnasium ``VectorEnv`` with same-step autoreset.

    ``venv``: e.g. ``SimpleReturnVectorEnv(64, autoreset_mode="same_step")``. Observations must
    be one array (N, ...) and actions a ``Box``; rewards are returned as float32 like SB3's own
    vector envs.
    """

    def __init__(self, venv: VectorEnv) -> None:
        mode = parse_autoreset_mode(venv.metadata.get("autoreset_mode", "next_step"))
        if mode != "same_step":
            raise ValueError("NativeVecEnv needs a vector env with autoreset_mode='same_step', "
                             f"got {mode!r}")
        if not isinstance(venv.single_action_space, gym.spaces.Box):
            raise TypeError("NativeVecEnv supports Box action spaces only")
        self.venv = venv
        n = int(venv.num_envs)
        super().__init__(n, venv.single_observation_space, venv.single_action_space)
        self._actions: np.ndarray | None = None
        self._ep_return = np.zeros(n)
        self._ep_length = np.zeros(n, np.int64)
        self._ep_hit = np.zeros(n, bool)
        self._t0 = time.perf_counter()

    # -- core API -------------------------------------------------------------------------------
    def reset(self) -> VecEnvObs:
        seeds = None if all(s is None for s in self._seeds) else list(self._seeds)
        options = _merge_options(self._options)
        obs, info = self.venv.reset(seed=seeds, options=options)
        self.reset_infos = _split_info(info, self.num_envs)
        self._reset_seeds()
        self._reset_options()
        self._ep_return[:] = 0.0
        self._ep_length[:] = 0
        self._ep_hit[:] = False
        return obs

    def step_async(self, actions: np.ndarray) -> None:
        self._actions = actions

    def step_wait(self) -> VecEnvStepReturn:
        if self._actions is None:
            raise RuntimeError("step_wait() without a pending step_async()")
        obs, reward, terminated, truncated, info = self.venv.step(self._actions)
        self._actions = None
        self._ep_return += reward
        self._ep_length += 1
        hit = info.get("hit")
        if hit is not None:
            self._ep_hit |= hit
        dones = terminated | truncated
        infos: list[dict[str, Any]] = [{} for _ in range(self.num_envs)]
        if dones.any():
            final_obs = info["final_obs"]
            final_info = info.get("final_info", {})
            scalars = {k: v for k, v in final_info.items()
                       if not k.startswith("_") and isinstance(v, np.ndarray) and v.ndim == 1}
            now = round(time.perf_counter() - self._t0, 6)
            for e in np.flatnonzero(dones).tolist():
                d = infos[e]
                for key, value in scalars.items():
                    d[key] = value[e].item()
                if hit is not None:
                    d["hit"] = bool(self._ep_hit[e])
                d["terminal_observation"] = final_obs[e]
                d["TimeLimit.truncated"] = bool(truncated[e] and not terminated[e])
                d["episode"] = {"r": float(self._ep_return[e]), "l": int(self._ep_length[e]),
                                "t": now}
            self._ep_return[dones] = 0.0
            self._ep_length[dones] = 0
            self._ep_hit[dones] = False
        return obs, reward.astype(np.float32), dones, infos

    def close(self) -> None:
        self.venv.close()

    # -- attribute access (one batched env behind every index) ---------------------------------
    def _count(self, indices: VecEnvIndices) -> int:
        if indices is None:
            return self.num_envs
        if isinstance(indices, int | np.integer):
            return 1
        return len(list(indices)) if isinstance(indices, Iterable) else 1

    def get_attr(self, attr_name: str, indices: VecEnvIndices = None) -> list[Any]:
        value = getattr(self.venv, attr_name)
        return [value] * self._count(indices)

    def set_attr(self, attr_name: str, value: Any, indices: VecEnvIndices = None) -> None:
        if indices is not None and self._count(indices) != self.num_envs:
            raise NotImplementedError("set_attr on a subset of a batched env")
        setattr(self.venv, attr_name, value)

    def env_method(self, method_name: str, *method_args: Any, indices: VecEnvIndices = None,
                   **method_kwargs: Any) -> list[Any]:
        result = getattr(self.venv, method_name)(*method_args, **method_kwargs)
        return [result] * self._count(indices)

    def env_is_wrapped(self, wrapper_class: type[gym.Wrapper],
                       indices: VecEnvIndices = None) -> list[bool]:
        return [False] * self._count(indices)

    def get_images(self) -> Sequence[np.ndarray | None]:
        """The frames of the environments the batched env draws (its first ``render_envs``;
        one rally for the rally envs), so SB3's ``render()`` and ``VecVideoRecorder`` tile
        those, not one image per environment."""
        frames = self.venv.render()
        if frames is None:
            return [None] * self.num_envs
        return list(frames) if isinstance(frames, tuple | list) else [frames]


def _split_info(info: dict[str, Any], n: int) -> list[dict[str, Any]]:
    """A Gymnasium vector info of arrays -> N dicts of scalars (for ``reset_infos``)."""
    out: list[dict[str, Any]] = [{} for _ in range(n)]
    for key, value in info.items():
        if key.startswith("_") or not isinstance(value, np.ndarray) or len(value) != n:
            continue
        for e in range(n):
            out[e][key] = value[e].item() if value.ndim == 1 else value[e]
    return out


def _merge_options(options: list[dict[str, Any]]) -> dict[str, Any] | None:
    """SB3's per-env option dicts -> one vector-env options dict (per-env values stacked)."""
    if not any(options):
        return None
    keys = set().union(*options)
    if any(set(o) != keys for o in options):
        raise ValueError("every environment must be given the same option keys")
    return {k: np.array([o[k] for o in options]) for k in sorted(keys)}
