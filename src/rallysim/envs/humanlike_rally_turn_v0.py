"""``humanlike_rally_turn_v0``: the HUMAN-LIKE 3-D rally as a turn game (the high level's view).

The same turn game as ``simple_rally_turn_v0`` over ``humanlike_rally_v0``'s rally: each
player's frozen low level swings every decision, and the player whose turn has just begun picks
its goal.

| view | what |
|---|---|
| ``env(low_level=..., **kw)`` / ``raw_env(low_level=..., **kw)`` | PettingZoo ``AECEnv``: ``agent_selection`` is the turn player; one step is one turn (``env`` adds PettingZoo's ``OrderEnforcingWrapper``) |
| ``HumanLikeRallyTurnEnv`` / ``HumanLikeRallyTurnVectorEnv`` (``RallySim/HumanLikeRallyTurn-v0``, single / vector) | single-agent Gymnasium view, cooperative: one shared high-level policy |

Observations: ``humanlike_rally_v0``'s 86 values in the turn player's own frame. Rewards, ``info``,
``max_cycles`` (one turn per step), ``state()`` / ``state_space`` (86 values), reset options and
``metadata["is_parallelizable"]`` (False) are as ``simple_rally_turn_v0``'s.

## The high level's 3-D goal
The player whose turn has just begun picks a goal, ``Box(-1, 1, (3,))``, mapped onto the low level's target racket velocity: speed 1.5 + 1.5 (g0 + 1) m/s
(1.5-4.5), elevation 40 + 5 (g1 + 1) degrees (40-50), azimuth 30 g2 degrees (-30-30, toward +y
for positive g2), own frame. The goal is held until the player's next turn; both players' low
levels act every decision; one step covers the span to the next turn (``infos[agent]
["decisions"]`` gives its length). ``low_level``: ``"scripted"`` (``AimedSwing``, the default),
``"random"``, ``"pretrained"``, a path prefix of an exported ``HumanLikeReturn-v0`` policy, or a
callable ``(observations (M, 86), goals (M, 3)) -> actions (M, 15)``.

## Version history
- v0: first release (earlier inside ``humanlike_rally_v0`` as ``turn_env``, where that name
  still works with a ``DeprecationWarning``).
"""

from __future__ import annotations

from typing import Any

from pettingzoo.utils.wrappers import OrderEnforcingWrapper

from rallysim.envs.simple_rally_turn_v0 import (
    SimpleRallyTurnAECEnv,
    SimpleRallyTurnEnv,
    SimpleRallyTurnVectorEnv,
)
from rallysim.players import HUMANLIKE
from rallysim.policies.types import LowLevel

__all__ = ["HumanLikeRallyTurnAECEnv", "HumanLikeRallyTurnEnv", "HumanLikeRallyTurnVectorEnv",
           "env", "raw_env"]


class HumanLikeRallyTurnAECEnv(SimpleRallyTurnAECEnv):
    """The turn-based HUMAN-LIKE rally as a PettingZoo ``AECEnv`` (``raw_env``)."""

    metadata = {**SimpleRallyTurnAECEnv.metadata, "name": "humanlike_rally_turn_v0"}
    player_spec = HUMANLIKE


raw_env = HumanLikeRallyTurnAECEnv


def env(low_level: LowLevel | str = "scripted", **kwargs: Any) -> OrderEnforcingWrapper:
    """The HUMAN-LIKE turn game in PettingZoo's ``OrderEnforcingWrapper`` (as
    ``simple_rally_turn_v0.env``)."""
    return OrderEnforcingWrapper(raw_env(low_level, **kwargs))


class HumanLikeRallyTurnVectorEnv(SimpleRallyTurnVectorEnv):
    """N cooperative turn-based HUMAN-LIKE rallies, single-agent: the action is the goal."""

    player_spec = HUMANLIKE


class HumanLikeRallyTurnEnv(SimpleRallyTurnEnv):
    """One cooperative turn-based HUMAN-LIKE rally as a single-agent Gymnasium env."""

    vector_env = HumanLikeRallyTurnVectorEnv
