"""``RallySim/SimpleRallyTurn-v1``: the cooperative turn-based SIMPLE rally, normalised action.

The same game as ``RallySim/SimpleRallyTurn-v0`` (``simple_rally_v0``'s single-agent turn view:
two SIMPLE players, their low levels frozen, one shared high-level policy choosing the goal of
whoever's turn has just begun; see that module for rules, rewards and ``info``); only the
action differs.

| id | single env | vector env (``gym.make_vec``) |
|---|---|---|
| ``RallySim/SimpleRallyTurn-v1`` | ``SimpleRallyTurnV1Env`` | ``SimpleRallyTurnV1VectorEnv`` |

## Action space: ``Box(-1, 1, (1,), float32)``
The turn player's goal, a landing depth beyond the net, is ``4 + 2 a`` metres (a = -1: 2 m,
a = 0: 4 m, a = 1: 6 m): ``rallysim.players.SIMPLE.goal.from_action``, the mapping the
trainers (SB3's ``RescaleAction`` in ``rallysim.train.stages``, RLlib's ``rallysim_high``) and
the exported high-level policies already use, so a network trained there drives v1 directly.
The depth is computed in float64 from the (clipped) action, so action ``a`` plays exactly the
episode that v0 plays given the goal ``4 + 2 a``. Values outside [-1, 1] are clipped; NaN, inf
or a wrong shape raise ``ValueError`` before anything moves. The single env takes shape (1,)
(or a scalar), the vector env (num_envs, 1) (or (num_envs,)).

## Observation space: ``Box(-1, 1, (20,), float32)``
The turn player's rally observation in its own frame (``simple_rally_v0``'s table), unchanged.

## Rewards, episode end, ``info``
As v0: +0.2 per hit summed over the turn's span; terminated when the shuttle lands, truncated at
50 hits; ``info["decisions"]`` (the span's length, for gamma^k discounting), ``rally_length``,
``player`` (who acted).

## Arguments
``low_level`` (``"scripted"``, ``"random"`` or a callable ``(observations (M, 20), goals (M,))
-> actions (M, 3)``), ``render_mode``, the rally's ``shuttle``, ``max_hits``, ``hit_reward``,
``max_decisions``; the vector env also ``num_envs``, ``autoreset_mode`` (``"next_step"`` or
``"same_step"``) and ``seed``. Env i of a vector env reset with seed s plays the episode of a
single env reset with seed s + i. Rendering: ``docs/rendering.md``.

## Version history
- v1: the action is normalised to [-1, 1]. v0's action is the goal in metres,
  ``Box(2, 6, (1,))``: Gymnasium's env checker and Stable-Baselines3 warn about an asymmetric,
  unnormalised Box, and a default Gaussian policy (mean 0, std 1) starts with nearly every action
  clipped to 2 m, the shortest goal. v0 is unchanged (its seeded episodes are pinned).
- v0 (``rallysim.envs.simple_rally_v0``): first release.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from rallysim.core.validation import real_array, validate_actions
from rallysim.envs.simple_rally_turn_v0 import SimpleRallyTurnEnv, SimpleRallyTurnVectorEnv
from rallysim.players import SIMPLE
from rallysim.policies.types import LowLevel

__all__ = ["SimpleRallyTurnV1Env", "SimpleRallyTurnV1VectorEnv", "action_space",
           "checked_actions", "goals_from_actions"]


def action_space(num_envs: int | None = None) -> spaces.Box:
    """v1's action space: one env's ``Box(-1, 1, (1,))``, or ``num_envs`` rows of it."""
    shape = (1,) if num_envs is None else (num_envs, 1)
    return spaces.Box(-1.0, 1.0, shape, np.float32)


def checked_actions(actions: Any, shape: tuple[int, ...]) -> np.ndarray:
    """Actions of ``shape`` (its trailing 1 may be left out, as v0's goals may) as float64,
    clipped to [-1, 1]; NaN, inf or another shape raise ``ValueError`` naming the actions."""
    a = real_array(actions, "actions", shape)
    if a.shape == shape[:-1]:
        a = a.reshape(shape)
    return validate_actions(a, shape)


def goals_from_actions(actions: Any, shape: tuple[int, ...]) -> np.ndarray:
    """Actions of ``shape`` -> goal depths 4 + 2 clip(a, -1, 1) metres, float64, of ``shape``."""
    # float64 before the mapping (checked_actions): 4 + 2a is then exact for a float32 a, so v1
    # given a and v0 given 4 + 2a play the same episode bit for bit
    return SIMPLE.goal.from_action(checked_actions(actions, shape)).reshape(shape)


class SimpleRallyTurnV1VectorEnv(SimpleRallyTurnVectorEnv):
    """N cooperative turn-based SIMPLE rallies (v0's vector env) whose actions a in [-1, 1]
    set the goals 4 + 2a metres. See the module docstring."""

    def __init__(self, num_envs: int = 1, low_level: LowLevel | str = "scripted",
                 autoreset_mode: str = "next_step", seed: int | None = None,
                 render_mode: str | None = None, **config: Any) -> None:
        super().__init__(num_envs, low_level=low_level, autoreset_mode=autoreset_mode,
                         seed=seed, render_mode=render_mode, **config)
        self.single_action_space = action_space()
        self.action_space = action_space(self.num_envs)

    def _step_units(self, actions: Any):
        return super()._step_units(goals_from_actions(actions, (self.num_envs, 1)))


class SimpleRallyTurnV1Env(SimpleRallyTurnEnv):
    """One cooperative turn-based SIMPLE rally (v0's single env) whose action a in [-1, 1] sets
    the goal 4 + 2a metres. See the module docstring."""

    vector_env = SimpleRallyTurnV1VectorEnv

    def __init__(self, low_level: LowLevel | str = "scripted", render_mode: str | None = None,
                 **config: Any) -> None:
        super().__init__(low_level=low_level, render_mode=render_mode, **config)
        self.action_space = action_space()

    def step(self, action: Any):
        # checked before v0's step, which would report a NaN as a bad *goal*; the vector env
        # maps the clipped action onto the goal
        return super().step(checked_actions(action, (1,)))
