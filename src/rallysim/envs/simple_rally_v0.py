"""``simple_rally_v0``: two SIMPLE players rally over the net (docs/reference.md §7-8).

Views of one batched rally core (``RallyTask``) in which both players act every decision.
The goal-level game the paper's high level plays, one turn per step, is its own module,
``simple_rally_turn_v0`` (``RallySim/SimpleRallyTurn-v0``).

| view | what | for |
|---|---|---|
| ``parallel_env(**kw)`` | PettingZoo ``ParallelEnv``; both players act every decision (0.1 s) | multi-agent learners |
| ``env(**kw)`` / ``raw_env(**kw)`` | PettingZoo ``AECEnv``: the same rally, ``player_0`` then ``player_1`` each give the decision's action (``env`` adds PettingZoo's ``OrderEnforcingWrapper``) | AEC-only tools |
| ``SimpleRallyVectorEnv(num_rallies, **kw)`` | Gymnasium ``VectorEnv``, one slot per rally-player pair (2N slots) | one policy shared by both players |

## Players, actions, observations
Agents ``"player_0"`` (stands at x < 0, receives the first serve) and ``"player_1"``. Each acts
like the low-level task's player: ``Box(-1, 1, (3,))`` = (arm target orientation, force,
movement); out-of-range values are clipped; NaN, inf or a wrong shape raise ``ValueError``.
Each observes 20 values in its own frame (player 1's frame is player 0's turned 180 degrees
about z), scaled to [-1, 1]:

| index | value |
|---|---|
| 0-15 | the low-level observation without the goal (``rallysim.core.simple_obs``) |
| 16-18 | opponent's base position (own frame, scaled like positions) |
| 19 | "my turn": 1 while this player's racket is armed |

## Rules
Bases start at x = -2.7 (player 0) and +2.44 (player 1), arms upright. The serve (docs/reference.md §4.3)
goes to player 0; player 1's racket is disarmed until player 0 hits. A hit disarms the hitter
and arms the other. With the ``paper`` shuttles a net touch re-arms both rackets and the shuttle
flies on (the original builds); with ``aero`` the net blocks it and it drops on the hitter's side.
Rally length = number of hits by both players.

| mode | reward | episode |
|---|---|---|
| ``"cooperative"`` (default, the paper) | +0.2 to both on every hit | one rally: terminated when the shuttle lands, truncated at ``max_hits`` (50) hits |
| ``"competitive"`` | +1 to a point's winner, -1 to its loser | one game to ``points_to_win`` (21), won by ``win_by`` (2), capped at ``max_points`` (30); the point's winner serves next; a rally reaching the cap is replayed |

A point goes against the player in whose half the shuttle lands in bounds, or against the last
hitter if it lands out. Arguments: ``shuttle``, ``mode``, ``max_hits``, ``hit_reward``,
``points_to_win``, ``win_by``, ``max_points``, ``max_decisions`` (a per-rally stall guard).

## PettingZoo conventions
- ``max_cycles`` (every PettingZoo view; default None, no limit): the episode is truncated on
  the ``max_cycles``-th step after ``reset``, for every agent at once (a rally that ends on that
  very step is terminated as well). A step of the parallel env and a cycle of ``env()`` (both
  players acting) is one decision.
- ``state()``, ``state_space``: player 0's observation, ``Box(-1, 1, (20,), float32)``: both
  bases, the shuttle and player 0's arm (the opponent's arm is not in it).
- ``metadata["is_parallelizable"]``: True for ``env()`` / ``raw_env`` (``aec_to_parallel``
  gives back the parallel env).
- A step outside an episode (``rally_views.check_agent_actions``): once it has ended,
  ``step({})`` returns five empty dicts, as PettingZoo's ``aec_to_parallel`` does, and an action
  for a done agent raises ``ValueError``; before the first ``reset()``, ``RuntimeError``.
- ``reset(options=...)``: the rallies have no reset options. Like PettingZoo's own envs they
  accept a dict and ignore it, silently (PettingZoo's ``api_test`` resets with a made-up key
  and requires that to work); anything but a dict or None raises ``ValueError``.

## ``info`` (per agent)
``hit``, ``racket_speed``, ``hit_point`` (this player), ``net_touch``, ``landed``,
``landing_point``, ``landing_side``, ``landed_in``, ``rally_length``, ``rally_over``,
``point_winner`` (-1 if none), ``score`` (own score first).

## Version history
- v0: first release. Earlier, the turn game's views (``turn_env``, ``SimpleRallyTurnEnv``,
  ``SimpleRallyTurnVectorEnv``, ``SimpleRallyTurnAECEnv``) lived here; they are now
  ``simple_rally_turn_v0``'s, and the old names still work with a ``DeprecationWarning``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces
from pettingzoo import ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec_wrapper
from pettingzoo.utils.wrappers import OrderEnforcingWrapper

from rallysim.core.tasks.rally import RallyTask
from rallysim.core.validation import validate_actions, validate_seed
from rallysim.envs.deprecated import moved
from rallysim.envs.rally_views import (
    AGENTS,
    act_space,
    agent_info,
    check_agent_actions,
    check_max_cycles,
    check_options,
    obs_space,
    out_of_cycles,
    rally_config,
    render_rally,
    slot_info,
)
from rallysim.envs.rendering import RENDER_MODES, EnvView
from rallysim.envs.vector_base import NEXT_STEP, NativeVectorEnv
from rallysim.players import SIMPLE, PlayerSpec

__all__ = ["AGENTS", "SimpleRallyAECEnv", "SimpleRallyParallelEnv", "SimpleRallyVectorEnv",
           "env", "parallel_env", "raw_env"]


class SimpleRallyParallelEnv(ParallelEnv):
    """One rally, both players acting every decision. See the module docstring."""

    metadata = {"name": "simple_rally_v0", "render_modes": RENDER_MODES, "render_fps": 10}
    player_spec: PlayerSpec = SIMPLE

    def __init__(self, render_mode: str | None = None, max_cycles: int | None = None,
                 **config: Any) -> None:
        self.max_cycles = check_max_cycles(max_cycles)
        self._view = EnvView(render_mode, n_players=2, player=self.player_spec.name)
        self.task = RallyTask(1, rally_config(self, config), spec=self.player_spec)
        self.possible_agents = list(AGENTS)
        self.agents: list[str] = []
        self.render_mode = render_mode
        self.observation_spaces = {a: obs_space(self.player_spec) for a in AGENTS}
        self.action_spaces = {a: act_space(self.player_spec) for a in AGENTS}
        self.state_space = obs_space(self.player_spec)  # state() is player 0's observation
        self.cycles = 0  # steps since reset, for max_cycles
        self._has_reset = False  # a step before the first reset is refused

    def observation_space(self, agent: str) -> spaces.Box:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        return self.action_spaces[agent]

    def reset(self, seed: int | None = None, options: dict | None = None):
        check_options(options)
        if validate_seed(seed) is not None:
            self.task.game.seed(np.array([0]), seed)
        self.task.reset(np.array([0]))
        self.agents = list(AGENTS)
        self.cycles = 0
        self._has_reset = True
        self._view.new_episode()
        if self.render_mode == "human":
            self.render()
        obs = self.task.observe()[0]
        return {a: obs[i] for i, a in enumerate(AGENTS)}, {a: {} for a in AGENTS}

    def render(self) -> np.ndarray | None:
        """Side view of the rally with its length and score burned in (``"rgb_array"``)."""
        return render_rally(self._view, self.task, 0)

    def close(self) -> None:
        self._view.close()

    def step(self, actions: dict[str, Any]):
        if not check_agent_actions(actions, self.agents, self._has_reset):
            return {}, {}, {}, {}, {}  # the episode has ended: nothing to run
        size = self.player_spec.action.size
        a = np.stack([validate_actions(actions[agent], (size,)) for agent in AGENTS])
        rewards, term, trunc, info = self.task.step(a[None])
        self.cycles += 1
        truncated = bool(trunc[0]) or out_of_cycles(self.cycles, self.max_cycles)
        obs = self.task.observe()[0]
        agents = list(self.agents)
        out = (
            {a: obs[i] for i, a in enumerate(agents)},
            {a: float(rewards[0, i]) for i, a in enumerate(agents)},
            {a: bool(term[0]) for a in agents},
            {a: truncated for a in agents},
            {a: agent_info(info, 0, i) for i, a in enumerate(agents)},
        )
        if term[0] or truncated:
            self.agents = []
        if self.render_mode == "human":
            self.render()
        return out

    def state(self) -> np.ndarray:
        """Player 0's observation (``state_space``): both bases, the shuttle and player 0's
        arm, seen from player 0's side; the opponent's arm is not in it."""
        return self.task.observe()[0, 0]


def parallel_env(**kwargs: Any) -> SimpleRallyParallelEnv:
    """The rally as a PettingZoo ``ParallelEnv`` (see the module docstring for arguments)."""
    return SimpleRallyParallelEnv(**kwargs)


class SimpleRallyAECEnv(parallel_to_aec_wrapper):
    """The parallel rally as a PettingZoo ``AECEnv`` (``raw_env``), through PettingZoo's own
    ``parallel_to_aec`` conversion: ``player_0`` then ``player_1`` give their actions for one
    decision, which runs when the last of them has acted. Arguments as ``parallel_env``."""

    metadata = {**SimpleRallyParallelEnv.metadata, "is_parallelizable": True}
    parallel: type[SimpleRallyParallelEnv] = SimpleRallyParallelEnv

    def __init__(self, render_mode: str | None = None, **kwargs: Any) -> None:
        super().__init__(self.parallel(render_mode=render_mode, **kwargs))

    @property
    def max_cycles(self) -> int | None:
        return self.env.max_cycles

    def step(self, action: Any) -> None:
        agent = self.agent_selection
        if not (self.terminations[agent] or self.truncations[agent]):
            # refused at the agent's own step; the conversion would only pass it on to the
            # parallel env's checks at the last agent's step
            validate_actions(action, (self.parallel.player_spec.action.size,))
        super().step(action)


raw_env = SimpleRallyAECEnv


def env(**kwargs: Any) -> OrderEnforcingWrapper:
    """The rally as a PettingZoo ``AECEnv``, wrapped as PettingZoo wraps its own envs: the
    ``OrderEnforcingWrapper`` refuses steps and reads before ``reset()``. No out-of-bounds
    wrapper: the env clips actions itself and refuses NaN or a wrong shape with ValueError."""
    return OrderEnforcingWrapper(raw_env(**kwargs))


class SimpleRallyVectorEnv(NativeVectorEnv):
    """N rallies as 2N Gymnasium slots, slot 2e + p being player p of rally e, for trainers
    that share one policy across players. Rewards, ends and autoreset as the parallel env;
    ``info`` arrays have one row per slot (the player's own events and score)."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 10, "autoreset_mode": NEXT_STEP}
    slots_per_unit = 2
    player_spec: PlayerSpec = SIMPLE

    def __init__(self, num_rallies: int = 1, autoreset_mode: str = "next_step",
                 seed: int | None = None, render_mode: str | None = None,
                 **config: Any) -> None:
        self._setup(num_rallies, autoreset_mode)
        self.render_mode = render_mode
        self._view = EnvView(render_mode, n_players=2, player=self.player_spec.name)
        self._views = [self._view]
        self.task = RallyTask(self.num_units, rally_config(self, config), seed, self.player_spec)
        spec = self.player_spec
        self.single_observation_space = obs_space(spec)
        self.single_action_space = act_space(spec)
        self.observation_space = spaces.Box(-1.0, 1.0, (self.num_envs, spec.rally_obs.size),
                                            np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (self.num_envs, spec.action.size), np.float32)

    def _seed_units(self, seeds: list[int]) -> None:
        self.task.game.seed_each(seeds)

    def _reset_units(self, units: np.ndarray, options: dict | None) -> None:
        self.task.reset(units)

    def _step_units(self, actions):
        size = self.player_spec.action.size
        a = validate_actions(actions, (self.num_envs, size))
        rewards, term, trunc, info = self.task.step(a.reshape(self.num_units, 2, size))
        return rewards.reshape(-1), term, trunc, slot_info(info)

    def _observe(self) -> np.ndarray:
        return self.task.observe().reshape(self.num_envs, self.player_spec.rally_obs.size)

    def render(self) -> tuple[np.ndarray, ...] | None:
        """A frame of rally 0 (``"rgb_array"``)."""
        frame = render_rally(self._view, self.task, 0)
        return None if frame is None else (frame,)


# The turn game moved to its own module; its old names here still work, with a warning.
__getattr__ = moved(__name__, "rallysim.envs.simple_rally_turn_v0", {
    "turn_env": "raw_env", "SimpleRallyTurnAECEnv": "SimpleRallyTurnAECEnv",
    "SimpleRallyTurnVectorEnv": "SimpleRallyTurnVectorEnv",
    "SimpleRallyTurnEnv": "SimpleRallyTurnEnv"})
