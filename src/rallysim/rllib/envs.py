"""RallySim's envs as RLlib's new API stack sees them.

- ``rallysim_low`` (low): the low-level task, single-agent. An env runner asks for its
  vector entry point (``gym_env_vectorize_mode="vector_entry_point"``) and gets one
  ``SimpleReturnVectorEnv`` (or HUMAN-LIKE) stepping all of its games in one MuJoCo model.
  One env step is a decision.
- ``rallysim_high`` (high): ``TurnRallyMultiAgentEnv``, the turn-based AEC rally with the low
  level frozen; only the player whose turn begins observes and acts. One env step is a turn.
- ``rallysim_mono`` (mono): ``RallyMultiAgentEnv``, the PettingZoo parallel rally; both
  players act every decision.

Both players of a rally map to one RLModule, ``SHARED_MODULE``. The high stage's action is
a in [-1, 1] and the goal 4 + 2a metres (``SIMPLE.goal.from_action``), as in the SB3 path, so
exported networks are interchangeable. Env settings travel in RLlib's ``env_config`` as plain
values (a frozen low level by name or path prefix), so an env runner on any node rebuilds the
same env.
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from ray.rllib.env.multi_agent_env import MultiAgentEnv
from ray.tune.registry import register_env

from rallysim.envs import simple_rally_turn_v0
from rallysim.envs.simple_rally_v0 import AGENTS, parallel_env
from rallysim.players import SIMPLE

SHARED_MODULE = "shared"
ENV_NAMES = {"low": "rallysim_low", "high": "rallysim_high", "mono": "rallysim_mono"}
_RALLY_KEYS = ("shuttle", "mode", "max_hits")


def shared_module(agent_id: str, episode: Any = None, **kwargs: Any) -> str:
    """RLlib's ``policy_mapping_fn``: every player acts with the one shared module."""
    return SHARED_MODULE


def make_return_env(env_config: dict[str, Any]) -> gym.Env | gym.vector.VectorEnv:
    """The low-level task: one env, or ``num_envs`` of them batched when RLlib asks for its
    vector entry point (then Gymnasium's next-step autoreset, which RLlib expects)."""
    player = env_config.get("env", "simple")
    n = env_config.get("num_envs")
    kwargs: dict[str, Any] = {"shuttle": env_config.get("shuttle", "paper")}
    if player == "humanlike":
        from rallysim.envs.humanlike_return_v0 import (
            HumanLikeReturnEnv,
            HumanLikeReturnVectorEnv,
        )

        return HumanLikeReturnEnv(**kwargs) if n is None else HumanLikeReturnVectorEnv(
            int(n), **kwargs)
    from rallysim.core.tasks.simple_return import REWARD_OPTIONS
    from rallysim.envs.simple_return_v0 import SimpleReturnEnv, SimpleReturnVectorEnv

    kwargs["incoming"] = env_config.get("incoming", "serve")
    kwargs["keep_bodies"] = bool(env_config.get("keep_bodies", False))
    kwargs["goals"] = env_config.get("goals", "uniform")
    for name in REWARD_OPTIONS:
        kwargs[name] = env_config.get(name, 0.0)
    return SimpleReturnEnv(**kwargs) if n is None else SimpleReturnVectorEnv(int(n), **kwargs)


def _rally_kwargs(env_config: dict[str, Any]) -> dict[str, Any]:
    return {k: env_config[k] for k in _RALLY_KEYS if k in env_config}


class RallyMultiAgentEnv(MultiAgentEnv):
    """``simple_rally_v0.parallel_env`` as an RLlib ``MultiAgentEnv``: both players observe,
    act and are rewarded every decision; the episode is one rally (or game).

    RLlib's own ``ParallelPettingZooEnv`` keeps the agents in a set, so their order (and with it
    the order of the sampled batch) changes with Python's string hashing from one process to
    the next; this adapter keeps the env's order."""

    def __init__(self, env_config: dict[str, Any] | None = None) -> None:
        super().__init__()
        self.par = parallel_env(**_rally_kwargs(dict(env_config or {})))
        self.agents = self.possible_agents = list(AGENTS)
        self.observation_spaces = {a: self.par.observation_space(a) for a in AGENTS}
        self.action_spaces = {a: self.par.action_space(a) for a in AGENTS}

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        obs, infos = self.par.reset(seed=seed)
        return obs, infos

    def step(self, action_dict: dict[str, Any]):
        obs, rewards, term, trunc, infos = self.par.step(action_dict)
        term["__all__"] = all(term.values())
        trunc["__all__"] = all(trunc.values())
        return obs, rewards, term, trunc, infos


class TurnRallyMultiAgentEnv(MultiAgentEnv):
    """``simple_rally_turn_v0.raw_env`` as an RLlib ``MultiAgentEnv``: one env step is one turn of
    the player whose turn has begun (only it observes); both players get the span's rewards;
    at the rally's end both observe (RLlib drops a player that never acted).

    ``env_config``: ``low_policy`` (the frozen low level: ``scripted``, ``pretrained`` or a
    policy path prefix reachable from every node) and the rally's ``shuttle``, ``mode``."""

    def __init__(self, env_config: dict[str, Any] | None = None) -> None:
        super().__init__()
        from rallysim.policies.registry import resolve

        env_config = dict(env_config or {})
        low = resolve(str(env_config.get("low_policy", "scripted")), "rally_low")
        self.aec = simple_rally_turn_v0.raw_env(low_level=low, **_rally_kwargs(env_config))
        self.agents = self.possible_agents = list(AGENTS)
        self.observation_spaces = {a: self.aec.observation_space(a) for a in AGENTS}
        unit = gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
        self.action_spaces = {a: unit for a in AGENTS}

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        self.aec.reset(seed=seed)
        agent = self.aec.agent_selection
        return {agent: self.aec.observe(agent)}, {}

    def step(self, action_dict: dict[str, Any]):
        agent = self.aec.agent_selection
        self.aec.step(SIMPLE.goal.from_action(np.asarray(action_dict[agent], np.float64)))
        rewards = {a: float(self.aec.rewards[a]) for a in AGENTS}
        terminated = any(self.aec.terminations.values())
        truncated = any(self.aec.truncations.values())
        observers = list(AGENTS) if terminated or truncated else [self.aec.agent_selection]
        obs = {a: self.aec.observe(a) for a in observers}
        infos = {a: dict(self.aec.infos[a]) for a in observers}
        return (obs, rewards, {"__all__": terminated}, {"__all__": truncated and not terminated},
                infos)


def make_rally_env(env_config: dict[str, Any]) -> RallyMultiAgentEnv:
    return RallyMultiAgentEnv(env_config)


def make_turn_env(env_config: dict[str, Any]) -> TurnRallyMultiAgentEnv:
    return TurnRallyMultiAgentEnv(env_config)


CREATORS = {"low": make_return_env, "high": make_turn_env, "mono": make_rally_env}


def register_rllib_envs() -> None:
    """Register the three env creators with Ray's registry (call after ``ray.init``: the
    registry lives in the cluster, so env runners on every node find them)."""
    for stage, name in ENV_NAMES.items():
        register_env(name, CREATORS[stage])
