"""Stable-Baselines3 on RallySim's fast path: ``make_vec_env(env_id, n_envs, seed=...)``.

SB3's own ``stable_baselines3.common.env_util.make_vec_env`` builds one Python env object per
environment and steps them one after another (``DummyVecEnv``). RallySim's registered ids also
have a *vector entry point*: one batched MuJoCo model that steps all N environments in one
call. This module's ``make_vec_env`` has the signature of SB3's and returns an SB3 ``VecEnv``
over that batched env, so a training script that builds its env from ``env_id``, ``n_envs``,
``seed`` and ``env_kwargs`` changes one import::

    from rallysim.sb3 import make_vec_env      # instead of stable_baselines3's
    env = make_vec_env("RallySim/SimpleReturn-v1", n_envs=256, seed=0)
    model = PPO("MlpPolicy", env, ...)

SB3's other arguments build things around each of its per-environment env objects (a
``Monitor`` and its files: ``monitor_dir``, ``monitor_kwargs``; a gym wrapper:
``wrapper_class``, ``wrapper_kwargs``; the ``VecEnv`` class that steps them: ``vec_env_cls``,
``vec_env_kwargs``; ``start_index``, the first env object's rank). One batched env has no
such objects, so these are accepted by name but refused with a ``ValueError`` saying so unless
left at SB3's defaults; wrap the returned ``VecEnv`` in SB3's ``VecEnv`` wrappers instead
(``VecMonitor(env, filename)`` for monitor files, ``VecNormalize``, ``VecFrameStack``, ...).

The returned ``NativeVecEnv`` (``rallysim.train.sb3_vec``) follows SB3's conventions: a
finished environment is reset in the same step, its last observation is
``infos[i]["terminal_observation"]``, ``infos[i]["TimeLimit.truncated"]`` says whether the
episode was cut by the time limit (SB3 then bootstraps its value), and
``infos[i]["episode"] = {"r", "l", "t"}`` is written as SB3's ``Monitor`` writes it (so
``ep_rew_mean`` shows in the logs without a ``Monitor`` wrapper). Environment *i* of a batch
seeded *s* replays a single environment seeded *s + i*, as with SB3's own ``make_vec_env``.

Needs Stable-Baselines3 (the ``train`` extra).
"""

from __future__ import annotations

import numbers
from typing import Any

import gymnasium as gym
from gymnasium.envs.registration import load_env_creator

from rallysim.core.validation import positive_int, validate_seed
from rallysim.envs.vector_base import NativeVectorEnv

try:
    from rallysim.train.sb3_vec import NativeVecEnv
except ModuleNotFoundError as err:  # SB3 (or torch) is an extra, not a dependency
    if (err.name or "").partition(".")[0] not in ("stable_baselines3", "torch"):
        raise  # something else is missing: its own error says what
    raise ModuleNotFoundError(f"rallysim.sb3 needs Stable-Baselines3 ({err}): install "
                              "torch==2.13.0, then rallysim[train]", name=err.name) from err

# (``import rallysim``, which runs before this module, registered the ids looked up here)

__all__ = ["NativeVecEnv", "make_vec_env", "native_ids"]

# set by this function, not by the caller: the batch size and the autoreset SB3 needs
_RESERVED_KWARGS = ("num_envs", "autoreset_mode", "seed")
_SB3_HINT = ("stable_baselines3.common.env_util.make_vec_env(env_id, n_envs) (one Python env "
             "per environment)")


def native_ids() -> list[str]:
    """The registered ids whose vector entry point is one of RallySim's batched envs."""
    return sorted(k for k, spec in gym.registry.items() if _native_class(spec) is not None)


def _native_class(spec: gym.envs.registration.EnvSpec) -> type | None:
    entry = spec.vector_entry_point
    if entry is None:
        return None
    # Loading a string entry point imports its module; only RallySim's are loaded here, so
    # listing the ids never imports another package's (possibly heavy or missing) modules.
    if isinstance(entry, str) and not entry.startswith("rallysim."):
        return None
    creator = load_env_creator(entry) if isinstance(entry, str) else entry
    native = isinstance(creator, type) and issubclass(creator, NativeVectorEnv)
    return creator if native else None


def _refuse_per_env_arguments(**given: Any) -> None:
    """SB3's ``make_vec_env`` arguments that act on its per-environment objects: refused
    unless left at SB3's defaults (``start_index`` 0, the others None or an empty dict)."""
    def is_default(name: str, value: Any) -> bool:
        if name == "start_index":
            return (isinstance(value, numbers.Integral) and not isinstance(value, bool)
                    and value == 0)
        return value is None or (name.endswith("_kwargs") and isinstance(value, dict)
                                 and not value)

    refused = [name for name, value in given.items() if not is_default(name, value)]
    if refused:
        raise ValueError(
            f"rallysim.sb3.make_vec_env cannot apply {', '.join(refused)}: it builds one batched "
            "env (one MuJoCo model for all n_envs environments), not one env object per "
            "environment, so there is nothing to give a per-environment wrapper, Monitor, "
            "start_index or vec_env_cls. Wrap the returned VecEnv in SB3's VecEnv wrappers "
            "instead (VecMonitor(env, filename) for monitor files, VecNormalize, "
            f"VecFrameStack, ...), or use {_SB3_HINT}")


def make_vec_env(env_id: str, n_envs: int = 1, seed: int | None = None,
                 start_index: int = 0, monitor_dir: str | None = None,
                 wrapper_class: Any = None, env_kwargs: dict[str, Any] | None = None,
                 vec_env_cls: Any = None, vec_env_kwargs: dict[str, Any] | None = None,
                 monitor_kwargs: dict[str, Any] | None = None,
                 wrapper_kwargs: dict[str, Any] | None = None) -> NativeVecEnv:
    """An SB3 ``VecEnv`` of ``n_envs`` environments of ``env_id`` in one batched MuJoCo model.

    The arguments are SB3's ``make_vec_env``'s, in its order. ``seed``: environment *i* is
    seeded ``seed + i`` at the first ``reset()`` (as SB3's ``make_vec_env`` does; an
    algorithm given its own ``seed`` re-seeds the same way). ``env_kwargs``: the env's own
    arguments (``shuttle``, ``target_depth_range``, ``max_decisions``, ...; see its docs).
    ``start_index``, ``monitor_dir``, ``wrapper_class``, ``vec_env_cls``, ``vec_env_kwargs``,
    ``monitor_kwargs`` and ``wrapper_kwargs`` apply to SB3's per-environment env objects, which
    a batched env does not have: anything but their defaults (0, None or an empty dict) raises
    ``ValueError`` (see the module's docs for what to use instead). Raises ``ValueError`` for
    an id that is not registered or has no RallySim vector entry point, saying what to use.
    """
    _refuse_per_env_arguments(start_index=start_index, monitor_dir=monitor_dir,
                              wrapper_class=wrapper_class, vec_env_cls=vec_env_cls,
                              vec_env_kwargs=vec_env_kwargs, monitor_kwargs=monitor_kwargs,
                              wrapper_kwargs=wrapper_kwargs)
    if not isinstance(env_id, str):
        raise ValueError(f"env_id must be a registered id string, got {type(env_id).__name__}")
    n_envs = positive_int(n_envs, "n_envs")
    seed = validate_seed(seed)
    if not isinstance(env_kwargs, dict | None):
        raise ValueError(f"env_kwargs must be a dict, got {type(env_kwargs).__name__}")
    kwargs = dict(env_kwargs or {})
    reserved = [k for k in _RESERVED_KWARGS if k in kwargs]
    if reserved:
        raise ValueError(f"env_kwargs may not set {reserved}: make_vec_env sets them (use its "
                         "n_envs and seed arguments; the autoreset is always same-step)")
    try:
        spec = gym.spec(env_id)
    except gym.error.Error as err:  # NameNotFound, VersionNotFound, a malformed id, ...
        raise ValueError(f"unknown environment id {env_id!r} ({err}); RallySim's batched ids: "
                         f"{', '.join(native_ids())}") from None
    if spec.vector_entry_point is None:
        raise ValueError(f"{env_id!r} has no native vector entry point (no batched env): use "
                         f"{_SB3_HINT}; RallySim's batched ids: {', '.join(native_ids())}")
    cls = _native_class(spec)
    if cls is None:
        raise ValueError(f"the vector entry point of {env_id!r} ({spec.vector_entry_point}) "
                         f"is not a RallySim batched env, which this adapter needs for its "
                         f"same-step autoreset: use {_SB3_HINT}")
    if seed is not None:
        # also to the constructor, so nothing drawn before the first reset is unseeded
        kwargs["seed"] = seed
    try:
        venv = gym.make_vec(env_id, num_envs=n_envs, vectorization_mode="vector_entry_point",
                            autoreset_mode="same_step", **kwargs)
    except TypeError as err:  # every env names an argument it does not take, and the valid ones
        if "unexpected keyword argument" not in str(err):
            raise
        raise ValueError(f"{env_id} {err}") from None
    vec = NativeVecEnv(venv)
    if seed is not None:
        # SB3's convention: seeds seed + i are used at the next reset (SB3's VecEnv.seed(None)
        # would draw a random seed instead, so it is called only for a given seed)
        vec.seed(seed)
    return vec
