"""``simple_rally_turn_v0``: the SIMPLE rally as a turn game, the paper's high level's view.

Two SIMPLE players rally (``simple_rally_v0``'s game and rules); each player's frozen low
level swings every decision, and the player whose turn has just begun (the opponent hit, or
the serve is coming to it) picks its goal: the landing depth it wants beyond the net.

| view | what |
|---|---|
| ``env(low_level=..., **kw)`` / ``raw_env(low_level=..., **kw)`` | PettingZoo ``AECEnv``: ``agent_selection`` is the turn player; one step is one turn (``env`` adds PettingZoo's ``OrderEnforcingWrapper``) |
| ``SimpleRallyTurnEnv`` / ``SimpleRallyTurnVectorEnv`` (``RallySim/SimpleRallyTurn-v0``, single / vector) | single-agent Gymnasium view, cooperative: one shared policy acts for whoever's turn it is |

``RallySim/SimpleRallyTurn-v1`` (``simple_rally_turn_v1``) is the same game with the action
normalised to [-1, 1].

## Actions, observations
The turn player's action, ``Box(2, 6, (1,))``, is its goal in metres (values outside are
clipped; NaN, inf or a wrong shape raise ``ValueError``). The goal is held until that player's
next turn. Each player observes ``simple_rally_v0``'s 20 values in its own frame.

## A step
It runs both players' low levels, each on its own latest goal, until the next turn begins, then
reports the span's summed rewards (``simple_rally_v0``'s cooperative or competitive rewards) and
``infos[agent]["decisions"]``, the span's length in decisions, for gamma^k discounting.
``low_level`` is ``"scripted"`` (the default), ``"random"``, ``"pretrained"``, a path prefix
of an exported ``SimpleReturn`` policy, or any batched callable ``(observations (M, 20), goals
(M,)) -> actions (M, 3)``. The other keyword arguments are the rally's (``shuttle``, ``mode``,
``max_hits``, ``hit_reward``, ``points_to_win``, ``win_by``, ``max_points``,
``max_decisions``).

## ``info``
PettingZoo view, per agent: ``decisions``, ``rally_length``, ``hits`` (this player's),
``score`` (own first). Gymnasium views: ``decisions``, ``rally_length``, ``player`` (who
acted).

## PettingZoo conventions
- ``max_cycles`` (default None, no limit): every agent is truncated on the ``max_cycles``-th
  turn after ``reset``.
- ``state()``, ``state_space``: player 0's observation, ``Box(-1, 1, (20,), float32)``, as
  ``simple_rally_v0``'s.
- ``metadata["is_parallelizable"]`` is False: the players act in turns, with goals.
- ``reset(options=...)``: a dict is accepted and ignored; anything but a dict or None raises
  ``ValueError``.

## Version history
- v0: first release (earlier inside ``simple_rally_v0`` as ``turn_env``, where that name
  still works with a ``DeprecationWarning``).
"""

from __future__ import annotations

from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from pettingzoo import AECEnv
from pettingzoo.utils.wrappers import OrderEnforcingWrapper

from rallysim.core.tasks.turns import TurnTask
from rallysim.core.validation import validate_goals, validate_seed
from rallysim.envs.rally_views import (
    AGENTS,
    check_max_cycles,
    check_options,
    goal_space,
    obs_space,
    out_of_cycles,
    rally_config,
    render_rally,
)
from rallysim.envs.rendering import RENDER_MODES, EnvView
from rallysim.envs.vector_base import NEXT_STEP, NativeVectorEnv
from rallysim.players import SIMPLE, PlayerSpec
from rallysim.policies.types import LowLevel

__all__ = ["SimpleRallyTurnAECEnv", "SimpleRallyTurnEnv", "SimpleRallyTurnVectorEnv", "env",
           "raw_env"]


class SimpleRallyTurnAECEnv(AECEnv):
    """The turn-based rally as a PettingZoo ``AECEnv``. See the module docstring."""

    metadata = {"name": "simple_rally_turn_v0", "render_modes": RENDER_MODES,
                "is_parallelizable": False, "render_fps": 1}
    player_spec: PlayerSpec = SIMPLE

    def __init__(self, low_level: LowLevel | str = "scripted", render_mode: str | None = None,
                 max_cycles: int | None = None, **config: Any) -> None:
        super().__init__()
        self.max_cycles = check_max_cycles(max_cycles)
        self._view = EnvView(render_mode, n_players=2, player=self.player_spec.name)
        self.turns = TurnTask(1, low_level, rally_config(self, config), player=self.player_spec)
        self.possible_agents = list(AGENTS)
        self.agents = []
        self.render_mode = render_mode
        self.observation_spaces = {a: obs_space(self.player_spec) for a in AGENTS}
        self.action_spaces = {a: goal_space(self.player_spec) for a in AGENTS}
        self.state_space = obs_space(self.player_spec)  # state() is player 0's observation
        self.cycles = 0  # turns played since reset, for max_cycles

    def observation_space(self, agent: str) -> spaces.Box:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        return self.action_spaces[agent]

    def observe(self, agent: str) -> np.ndarray:
        return self.turns.rally.observe()[0, AGENTS.index(agent)]

    def reset(self, seed: int | None = None, options: dict | None = None) -> None:
        check_options(options)
        if validate_seed(seed) is not None:
            self.turns.seed([seed])
        self.turns.reset(np.array([0]))
        self.agents = list(AGENTS)
        self.cycles = 0
        self.rewards = {a: 0.0 for a in AGENTS}
        self._cumulative_rewards = {a: 0.0 for a in AGENTS}
        self.terminations = {a: False for a in AGENTS}
        self.truncations = {a: False for a in AGENTS}
        self.infos = {a: {} for a in AGENTS}
        self.agent_selection = AGENTS[self.turns.turn_player[0]]
        self._view.new_episode()

    def render(self) -> np.ndarray | None:
        """The rally at the start of the current turn, goals as red markers (``"rgb_array"``)."""
        return render_rally(self._view, self.turns.rally, 0, self.turns.goals[0])

    def state(self) -> np.ndarray:
        """Player 0's observation (``state_space``), as the parallel env's ``state()``."""
        return self.turns.rally.observe()[0, 0]

    def close(self) -> None:
        self._view.close()

    def step(self, action: Any) -> None:
        agent = self.agent_selection
        if self.terminations[agent] or self.truncations[agent]:
            self._was_dead_step(action)
            return
        goal = validate_goals(action, (self.player_spec.goal.size,))
        self._cumulative_rewards[agent] = 0.0
        out = self.turns.step(goal)
        self.cycles += 1
        truncated = bool(out["truncated"][0]) or out_of_cycles(self.cycles, self.max_cycles)
        for i, a in enumerate(AGENTS):
            self.rewards[a] = float(out["reward"][0, i])
            self.infos[a] = {"decisions": int(out["decisions"][0]),
                             "rally_length": int(out["rally_length"][0]),
                             "hits": int(out["hits"][0, i]),
                             "score": out["score"][0, [i, 1 - i]].copy()}
        if out["terminated"][0] or truncated:
            for a in AGENTS:
                self.terminations[a] = bool(out["terminated"][0])
                self.truncations[a] = truncated
        else:
            self.agent_selection = AGENTS[self.turns.turn_player[0]]
        self._accumulate_rewards()
        if self.render_mode == "human":
            self.render()


raw_env = SimpleRallyTurnAECEnv


def env(low_level: LowLevel | str = "scripted", **kwargs: Any) -> OrderEnforcingWrapper:
    """The turn game as a PettingZoo ``AECEnv`` in PettingZoo's ``OrderEnforcingWrapper`` (steps
    and reads before ``reset()`` are refused); arguments as ``raw_env``."""
    return OrderEnforcingWrapper(raw_env(low_level, **kwargs))


class SimpleRallyTurnVectorEnv(NativeVectorEnv):
    """N cooperative turn-based rallies as a single-agent Gymnasium vector env: each slot is a
    rally, observed by whoever's turn it is; its action is that player's goal; its reward is the
    span's cooperative reward; ``info["decisions"]`` is the span's length."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 1, "autoreset_mode": NEXT_STEP}
    player_spec: PlayerSpec = SIMPLE

    def __init__(self, num_envs: int = 1, low_level: LowLevel | str = "scripted",
                 autoreset_mode: str = "next_step", seed: int | None = None,
                 render_mode: str | None = None, **config: Any) -> None:
        cfg = rally_config(self, config)
        if cfg.mode != "cooperative":
            raise ValueError("the single-agent turn view is cooperative; use this module's env() or raw_env() for "
                             "the competitive game")
        self._setup(num_envs, autoreset_mode)
        self.render_mode = render_mode
        self._view = EnvView(render_mode, n_players=2, player=self.player_spec.name)
        self._views = [self._view]
        self.turns = TurnTask(self.num_units, low_level, cfg, seed, player=self.player_spec)
        self.decisions_simulated = 0  # low-level decisions run inside all turns so far
        spec = self.player_spec
        goal = goal_space(spec)
        self.single_observation_space, self.single_action_space = obs_space(spec), goal
        self.observation_space = spaces.Box(-1.0, 1.0, (self.num_envs, spec.rally_obs.size),
                                            np.float32)
        self.action_space = spaces.Box(goal.low[0], goal.high[0],
                                       (self.num_envs, spec.goal.size), np.float32)

    def _seed_units(self, seeds: list[int]) -> None:
        self.turns.seed(seeds)

    def _reset_units(self, units: np.ndarray, options: dict | None) -> None:
        self.turns.reset(units)

    def _step_units(self, actions):
        size = self.player_spec.goal.size
        goals = validate_goals(actions, (self.num_envs, size))
        if size == 1:
            goals = goals[:, 0]
        # rallies waiting for their next-step reset do not play
        playing = np.setdiff1d(np.arange(self.num_units), self._pending)
        if len(self._pending):
            goals = goals.copy()
            goals[self._pending] = self.player_spec.goal.default
        out = self.turns.step(goals, playing)
        acted = out["acted"]
        self.decisions_simulated += int(out["decisions"].sum())
        reward = out["reward"][np.arange(self.num_envs), acted]
        info = {"decisions": out["decisions"], "rally_length": out["rally_length"],
                "player": acted}
        return reward, out["terminated"], out["truncated"], info

    def _observe(self) -> np.ndarray:
        return self.turns.observe()

    def render(self) -> tuple[np.ndarray, ...] | None:
        """A frame of rally 0 at its current turn (``"rgb_array"``)."""
        frame = render_rally(self._view, self.turns.rally, 0, self.turns.goals[0])
        return None if frame is None else (frame,)

class SimpleRallyTurnEnv(gym.Env):
    """One cooperative turn-based rally as a single-agent Gymnasium env (one shared policy)."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 1}
    vector_env: type[SimpleRallyTurnVectorEnv] = SimpleRallyTurnVectorEnv

    def __init__(self, low_level: LowLevel | str = "scripted", render_mode: str | None = None,
                 **config: Any) -> None:
        self.render_mode = render_mode
        self.vec = self.vector_env(1, low_level=low_level, render_mode=render_mode, **config)
        spec = self.vec.player_spec
        self.observation_space, self.action_space = obs_space(spec), goal_space(spec)
        self._done = True

    def reset(self, *, seed: int | None = None, options: dict | None = None):
        self.vec._check_options(options)  # checked before any stream restarts
        super().reset(seed=validate_seed(seed))
        obs, _ = self.vec.reset(seed=seed, options=options)
        self._done = False
        return obs[0], {}

    def step(self, action):
        if self._done:
            raise RuntimeError("the rally has ended (or never began): call reset() first")
        goal = validate_goals(action, (self.vec.player_spec.goal.size,))
        obs, r, term, trunc, info = self.vec.step(goal[None])
        self._done = bool(term[0] or trunc[0])
        return (obs[0], float(r[0]), bool(term[0]), bool(trunc[0]),
                {k: v[0].item() for k, v in info.items()})

    def render(self) -> np.ndarray | None:
        frames = self.vec.render()
        return None if frames is None else frames[0]

    def close(self) -> None:
        self.vec.close()
