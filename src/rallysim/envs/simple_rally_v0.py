"""``simple_rally_v0``: two SIMPLE players rally over the net (SPEC §7-8).

Views of one batched rally core (``RallyTask``):

| view | what | for |
|---|---|---|
| ``parallel_env(**kw)`` | PettingZoo ``ParallelEnv``; both players act every decision (0.1 s) | multi-agent learners |
| ``env(**kw)`` / ``raw_env(**kw)`` | PettingZoo ``AECEnv``: the same rally, ``player_0`` then ``player_1`` each give the decision's action (``env`` adds PettingZoo's ``OrderEnforcingWrapper``) | AEC-only tools |
| ``SimpleRallyVectorEnv(num_rallies, **kw)`` | Gymnasium ``VectorEnv``, one slot per rally-player pair (2N slots) | one policy shared by both players |
| ``turn_env(low_level=..., **kw)`` | PettingZoo ``AECEnv``; the acting agent is the player whose turn just began; its action is its goal | the paper's high level |
| ``SimpleRallyTurnEnv`` / ``SimpleRallyTurnVectorEnv`` (``RallySim/SimpleRallyTurn-v0``, single / vector) | single-agent Gymnasium view of the turn game, cooperative, one shared policy | off-the-shelf trainers |

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
Bases start at x = -2.7 (player 0) and +2.44 (player 1), arms upright. The serve (SPEC §4.3)
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

## Turn-based view
``turn_env(low_level, **kw)``: ``agent_selection`` is the player whose turn has just begun (the
opponent hit, or the serve is coming to it). Its action, ``Box(2, 6, (1,))``, is its goal: the
landing depth in metres it wants beyond the net (values outside are clipped; NaN raises). The
step runs both players' low-level controllers, each on its own latest goal, until the next turn
begins, then reports the summed rewards and ``infos[agent]["decisions"]``, the span's length
in decisions, for gamma^k discounting. ``low_level`` is any batched callable
``(observations (M, 20), goals (M,)) -> actions (M, 3)``, or ``"scripted"`` / ``"random"``.

## PettingZoo conventions
- ``max_cycles`` (every PettingZoo view; default None, no limit): the episode is truncated on
  the ``max_cycles``-th step after ``reset``, for every agent at once (a rally that ends on that
  very step is terminated as well). A step of the parallel env and a cycle of ``env()`` (both
  players acting) is one decision; a step of ``turn_env`` is one turn.
- ``state()``, ``state_space``: player 0's observation, ``Box(-1, 1, (20,), float32)``: both
  bases, the shuttle and player 0's arm (the opponent's arm is not in it).
- ``metadata["is_parallelizable"]``: True for ``env()`` / ``raw_env`` (``aec_to_parallel``
  gives back the parallel env), False for ``turn_env`` (players act in turns, with goals).
- ``reset(options=...)``: the rallies have no reset options. Like PettingZoo's own envs they
  accept a dict and ignore it, silently (PettingZoo's ``api_test`` resets with a made-up key
  and requires that to work); anything but a dict or None raises ``ValueError``.

## ``info`` (per agent)
``hit``, ``racket_speed``, ``hit_point`` (this player), ``net_touch``, ``landed``,
``landing_point``, ``landing_side``, ``landed_in``, ``rally_length``, ``rally_over``,
``point_winner`` (-1 if none), ``score`` (own score first).

## Version history
- v0: first release.
"""

from __future__ import annotations

import inspect
from typing import Any

import gymnasium as gym
import numpy as np
from gymnasium import spaces
from pettingzoo import AECEnv, ParallelEnv
from pettingzoo.utils.conversions import parallel_to_aec_wrapper
from pettingzoo.utils.wrappers import OrderEnforcingWrapper

from rallysim.core.simple_obs import TARGET_DEPTH_RANGE
from rallysim.core.tasks.rally import RallyConfig, RallyTask
from rallysim.core.tasks.turns import TurnTask
from rallysim.core.validation import (
    positive_int,
    validate_actions,
    validate_goals,
    validate_seed,
)
from rallysim.envs.rendering import RENDER_MODES, EnvView
from rallysim.envs.vector_base import NEXT_STEP, NativeVectorEnv
from rallysim.players import SIMPLE, PlayerSpec
from rallysim.policies.types import LowLevel

AGENTS = ("player_0", "player_1")
ACTION_SIZE = 3
PER_PLAYER_INFO = ("hit", "racket_speed", "hit_point")
SCORE_INFO = ("score",)


def _obs_space(spec: PlayerSpec) -> spaces.Box:
    return spaces.Box(-1.0, 1.0, (spec.rally_obs.size,), np.float32)


def _act_space(spec: PlayerSpec) -> spaces.Box:
    return spaces.Box(-1.0, 1.0, (spec.action.size,), np.float32)


def _goal_space(spec: PlayerSpec) -> spaces.Box:
    if spec.goal.size == 1:
        return spaces.Box(*TARGET_DEPTH_RANGE, (1,), np.float32)
    return spaces.Box(-1.0, 1.0, (spec.goal.size,), np.float32)


def rally_config(view: object, config: dict[str, Any]) -> RallyConfig:
    """A view's rules from its extra keyword arguments; an unknown one is named along with every
    valid argument, the view constructor's own included."""
    params = inspect.signature(type(view).__init__).parameters.values()
    named = (inspect.Parameter.POSITIONAL_OR_KEYWORD, inspect.Parameter.KEYWORD_ONLY)
    own = [p.name for p in params if p.kind in named and p.name != "self"]
    return RallyConfig.from_kwargs(config, own)


def render_rally(view: EnvView, task: RallyTask, env: int,
                 goals: np.ndarray | None = None) -> np.ndarray | None:
    score = task.score[env]
    hud = f"rally {int(task.game.hits[env])}   score {score[0]}-{score[1]}"
    if task.spec.goal.size != 1:  # the landing-depth markers are SIMPLE's
        goals = None
    return view.render(task.game, env, None if goals is None else list(goals), hud)


def _agent_info(info: dict, env: int, player: int) -> dict[str, Any]:
    """One player's view of rally ``env``'s event arrays."""
    out = {}
    for key, value in info.items():
        v = value[env]
        if key in PER_PLAYER_INFO:
            v = v[player]
        elif key in SCORE_INFO:
            v = v[[player, 1 - player]]
        out[key] = v.item() if np.ndim(v) == 0 else v.copy()
    return out


def _slot_info(info: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
    """Rally event arrays (N, ...) and (N, 2, ...) -> one row per slot (2N, ...): a player's
    own events, the rally's shared ones repeated, its own score and the opponent's."""
    out = {}
    for key, value in info.items():
        if key in PER_PLAYER_INFO:
            out[key] = value.reshape(-1, *value.shape[2:])
        elif key in SCORE_INFO:
            out[key] = value.reshape(-1)
            out["opponent_" + key] = value[:, ::-1].reshape(-1)
        else:
            out[key] = np.repeat(value, 2, axis=0)
    return out


def _check_options(options: Any) -> None:
    """The rallies have no reset options. A dict is accepted and ignored without a word, as
    PettingZoo's own envs do: its ``api_test`` resets with the made-up ``{"options": 1}`` and
    requires that to pass, so unknown keys cannot be refused. A non-dict is a plain mistake."""
    if options is not None and not isinstance(options, dict):
        raise ValueError(f"options must be a dict or None, got {type(options).__name__}")


def _check_max_cycles(max_cycles: Any) -> int | None:
    return None if max_cycles is None else positive_int(max_cycles, "max_cycles")


def _out_of_cycles(cycles: int, max_cycles: int | None) -> bool:
    """Whether ``cycles`` steps since reset reach the ``max_cycles`` limit (None: none)."""
    return max_cycles is not None and cycles >= max_cycles


def _check_agent_actions(actions: Any, live: list[str]) -> None:
    if not isinstance(actions, dict):
        raise ValueError(f"actions must be a dict keyed by agent, got {type(actions).__name__}")
    for agent in actions:
        if agent not in AGENTS:
            raise ValueError(f"unknown agent {agent!r}; agents are {list(AGENTS)}")
        if agent not in live:
            raise ValueError(f"agent {agent!r} is done; call reset() to start a new episode")
    missing = [a for a in live if a not in actions]
    if missing:
        raise ValueError(f"missing actions for {missing}")


class SimpleRallyParallelEnv(ParallelEnv):
    """One rally, both players acting every decision. See the module docstring."""

    metadata = {"name": "simple_rally_v0", "render_modes": RENDER_MODES, "render_fps": 10}
    player_spec: PlayerSpec = SIMPLE

    def __init__(self, render_mode: str | None = None, max_cycles: int | None = None,
                 **config: Any) -> None:
        self.max_cycles = _check_max_cycles(max_cycles)
        self._view = EnvView(render_mode, n_players=2, player=self.player_spec.name)
        self.task = RallyTask(1, rally_config(self, config), spec=self.player_spec)
        self.possible_agents = list(AGENTS)
        self.agents: list[str] = []
        self.render_mode = render_mode
        self.observation_spaces = {a: _obs_space(self.player_spec) for a in AGENTS}
        self.action_spaces = {a: _act_space(self.player_spec) for a in AGENTS}
        self.state_space = _obs_space(self.player_spec)  # state() is player 0's observation
        self.cycles = 0  # steps since reset, for max_cycles

    def observation_space(self, agent: str) -> spaces.Box:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        return self.action_spaces[agent]

    def reset(self, seed: int | None = None, options: dict | None = None):
        _check_options(options)
        if validate_seed(seed) is not None:
            self.task.game.seed(np.array([0]), seed)
        self.task.reset(np.array([0]))
        self.agents = list(AGENTS)
        self.cycles = 0
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
        _check_agent_actions(actions, self.agents)
        size = self.player_spec.action.size
        a = np.stack([validate_actions(actions[agent], (size,)) for agent in AGENTS])
        rewards, term, trunc, info = self.task.step(a[None])
        self.cycles += 1
        truncated = bool(trunc[0]) or _out_of_cycles(self.cycles, self.max_cycles)
        obs = self.task.observe()[0]
        agents = list(self.agents)
        out = (
            {a: obs[i] for i, a in enumerate(agents)},
            {a: float(rewards[0, i]) for i, a in enumerate(agents)},
            {a: bool(term[0]) for a in agents},
            {a: truncated for a in agents},
            {a: _agent_info(info, 0, i) for i, a in enumerate(agents)},
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
        self.single_observation_space = _obs_space(spec)
        self.single_action_space = _act_space(spec)
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
        return rewards.reshape(-1), term, trunc, _slot_info(info)

    def _observe(self) -> np.ndarray:
        return self.task.observe().reshape(self.num_envs, self.player_spec.rally_obs.size)

    def render(self) -> tuple[np.ndarray, ...] | None:
        """A frame of rally 0 (``"rgb_array"``)."""
        frame = render_rally(self._view, self.task, 0)
        return None if frame is None else (frame,)

class SimpleRallyTurnAECEnv(AECEnv):
    """The turn-based rally as a PettingZoo ``AECEnv``. See the module docstring."""

    metadata = {"name": "simple_rally_turn_v0", "render_modes": RENDER_MODES,
                "is_parallelizable": False, "render_fps": 1}
    player_spec: PlayerSpec = SIMPLE

    def __init__(self, low_level: LowLevel | str = "scripted", render_mode: str | None = None,
                 max_cycles: int | None = None, **config: Any) -> None:
        super().__init__()
        self.max_cycles = _check_max_cycles(max_cycles)
        self._view = EnvView(render_mode, n_players=2, player=self.player_spec.name)
        self.turns = TurnTask(1, low_level, rally_config(self, config), player=self.player_spec)
        self.possible_agents = list(AGENTS)
        self.agents = []
        self.render_mode = render_mode
        self.observation_spaces = {a: _obs_space(self.player_spec) for a in AGENTS}
        self.action_spaces = {a: _goal_space(self.player_spec) for a in AGENTS}
        self.state_space = _obs_space(self.player_spec)  # state() is player 0's observation
        self.cycles = 0  # turns played since reset, for max_cycles

    def observation_space(self, agent: str) -> spaces.Box:
        return self.observation_spaces[agent]

    def action_space(self, agent: str) -> spaces.Box:
        return self.action_spaces[agent]

    def observe(self, agent: str) -> np.ndarray:
        return self.turns.rally.observe()[0, AGENTS.index(agent)]

    def reset(self, seed: int | None = None, options: dict | None = None) -> None:
        _check_options(options)
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
        truncated = bool(out["truncated"][0]) or _out_of_cycles(self.cycles, self.max_cycles)
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


def turn_env(low_level: LowLevel | str = "scripted", **kwargs: Any) -> SimpleRallyTurnAECEnv:
    """The turn-based rally (PettingZoo AEC) driven by ``low_level``; see the module docstring."""
    return SimpleRallyTurnAECEnv(low_level=low_level, **kwargs)


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
            raise ValueError("the single-agent turn view is cooperative; use turn_env() for "
                             "the competitive game")
        self._setup(num_envs, autoreset_mode)
        self.render_mode = render_mode
        self._view = EnvView(render_mode, n_players=2, player=self.player_spec.name)
        self._views = [self._view]
        self.turns = TurnTask(self.num_units, low_level, cfg, seed, player=self.player_spec)
        self.decisions_simulated = 0  # low-level decisions run inside all turns so far
        spec = self.player_spec
        goal = _goal_space(spec)
        self.single_observation_space, self.single_action_space = _obs_space(spec), goal
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
        self.observation_space, self.action_space = _obs_space(spec), _goal_space(spec)
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
