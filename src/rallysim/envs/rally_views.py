"""What the rally views share: agent names, spaces, the rules from keyword arguments, ``info``
per agent or slot, rendering, and PettingZoo's checks (options, ``max_cycles``, actions).

The views themselves are one module per game: ``simple_rally_v0`` / ``humanlike_rally_v0``
(both players act every decision) and ``simple_rally_turn_v0`` / ``humanlike_rally_turn_v0``
(the goal-level turn game).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from rallysim.core.tasks.rally import RallyConfig, RallyTask
from rallysim.core.validation import keyword_names, positive_int
from rallysim.envs.rendering import EnvView
from rallysim.players import PlayerSpec

AGENTS = ("player_0", "player_1")
PER_PLAYER_INFO = ("hit", "racket_speed", "hit_point")
SCORE_INFO = ("score",)


def obs_space(spec: PlayerSpec) -> spaces.Box:
    return spaces.Box(-1.0, 1.0, (spec.rally_obs.size,), np.float32)


def act_space(spec: PlayerSpec) -> spaces.Box:
    return spaces.Box(-1.0, 1.0, (spec.action.size,), np.float32)


def goal_space(spec: PlayerSpec) -> spaces.Box:
    """The turn game's action: one goal of the spec's range."""
    return spaces.Box(np.array(spec.goal.low, np.float32), np.array(spec.goal.high, np.float32),
                      (spec.goal.size,), np.float32)


def rally_config(view: object, config: dict[str, Any]) -> RallyConfig:
    """A view's rules from its extra keyword arguments; an unknown one is named along with every
    valid argument, the view constructor's own included."""
    return RallyConfig.from_kwargs(config, keyword_names(type(view).__init__))


def render_rally(view: EnvView, task: RallyTask, env: int,
                 goals: np.ndarray | None = None) -> np.ndarray | None:
    score = task.score[env]
    hud = f"rally {int(task.game.hits[env])}   score {score[0]}-{score[1]}"
    if task.spec.goal.size != 1:  # the landing-depth markers are SIMPLE's
        goals = None
    return view.render(task.game, env, None if goals is None else list(goals), hud)


def agent_info(info: dict, env: int, player: int) -> dict[str, Any]:
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


def slot_info(info: dict[str, np.ndarray]) -> dict[str, np.ndarray]:
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


def check_options(options: Any) -> None:
    """The rallies have no reset options. A dict is accepted and ignored without a word, as
    PettingZoo's own envs do: its ``api_test`` resets with the made-up ``{"options": 1}`` and
    requires that to pass, so unknown keys cannot be refused. A non-dict is a plain mistake."""
    if options is not None and not isinstance(options, dict):
        raise ValueError(f"options must be a dict or None, got {type(options).__name__}")


def check_max_cycles(max_cycles: Any) -> int | None:
    return None if max_cycles is None else positive_int(max_cycles, "max_cycles")


def out_of_cycles(cycles: int, max_cycles: int | None) -> bool:
    """Whether ``cycles`` steps since reset reach the ``max_cycles`` limit (None: none)."""
    return max_cycles is not None and cycles >= max_cycles


def check_agent_actions(actions: Any, live: list[str], has_reset: bool) -> bool:
    """PettingZoo's rule for a parallel step's ``actions`` (every parallel rally view): whether
    there is a decision to run. Before the first ``reset()``: ``RuntimeError``. Once the episode
    has ended (``live`` empty), ``{}`` is no decision: the step returns five empty dicts, as
    PettingZoo's own parallel envs (``aec_to_parallel``) do for the usual loop's
    ``{a: pi(o[a]) for a in env.agents}``. An action for an unknown or finished agent, a
    missing one or a non-dict: ``ValueError``."""
    if not has_reset:
        raise RuntimeError("step() before reset(): call reset() first")
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
    return bool(live)
