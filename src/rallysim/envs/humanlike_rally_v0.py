"""``humanlike_rally_v0``: two HUMAN-LIKE players rally in 3-D, the rally the paper never reached.

The same views as ``simple_rally_v0``, over ``RallyTask`` with the HUMAN-LIKE player spec (the
same rulebook with the HUMAN-LIKE bodies of docs/reference.md §10). The goal-level turn game is its own
module, ``humanlike_rally_turn_v0`` (``RallySim/HumanLikeRallyTurn-v0``).

| view | what |
|---|---|
| ``parallel_env(**kw)`` | PettingZoo ``ParallelEnv``; both players act every decision (0.1 s) |
| ``env(**kw)`` / ``raw_env(**kw)`` | PettingZoo ``AECEnv``: the same rally, ``player_0`` then ``player_1`` each give the decision's action (``env`` adds PettingZoo's ``OrderEnforcingWrapper``) |
| ``HumanLikeRallyVectorEnv(num_rallies, **kw)`` | Gymnasium ``VectorEnv``, one slot per rally-player pair (2N slots) |

## Players, actions, observations
Agents ``"player_0"`` (receives the first serve) and ``"player_1"``. Each acts like the
low-level task's player: ``Box(-1, 1, (15,))`` (``RallySim/HumanLikeReturn-v0``'s actions).
Each observes 86 values in its own frame (player 1's frame is player 0's turned 180 degrees
about z), in [-1, 1]:

| index | value |
|---|---|
| 0-81 | the low-level observation without the target (``rallysim.core.humanlike_obs``) |
| 82-84 | the opponent's hips position (own frame, scaled like positions) |
| 85 | "my turn": 1 while this player's racket is armed |

## Rules
Hips start at own-frame (-2.7, 0) for both, joints in the zero pose. The serve is the low-level
task's HUMAN-LIKE serve, to player 0. After a hit the shuttle leaves along the racket velocity
at min(60, 5 |v|) m/s (docs/reference.md §10). Everything else (arming, net, landing, the cooperative +0.2
per hit and 50-hit cap, competitive badminton scoring) is ``simple_rally_v0``'s; see there.

## PettingZoo conventions
As ``simple_rally_v0``'s: ``max_cycles`` (default None: no limit) truncates every agent on the
``max_cycles``-th step after ``reset`` (a decision for ``parallel_env`` and for a cycle of
``env()``); ``state()`` is player 0's observation, ``state_space``
``Box(-1, 1, (86,), float32)`` (the opponent's joints are not in it);
``metadata["is_parallelizable"]`` is True for ``env()`` / ``raw_env``;
reset ``options`` are accepted and ignored silently (a non-dict raises ``ValueError``).

## Version history
- v0: first release. Earlier, the turn game's views (``turn_env``, ``HumanLikeRallyTurnEnv``,
  ``HumanLikeRallyTurnVectorEnv``, ``HumanLikeRallyTurnAECEnv``) lived here; they are now
  ``humanlike_rally_turn_v0``'s, and the old names still work with a ``DeprecationWarning``.
"""

from __future__ import annotations

from typing import Any

from pettingzoo.utils.wrappers import OrderEnforcingWrapper

from rallysim.envs.deprecated import moved
from rallysim.envs.simple_rally_v0 import (
    SimpleRallyAECEnv,
    SimpleRallyParallelEnv,
    SimpleRallyVectorEnv,
)
from rallysim.players import HUMANLIKE

__all__ = ["HumanLikeRallyAECEnv", "HumanLikeRallyParallelEnv", "HumanLikeRallyVectorEnv",
           "env", "parallel_env", "raw_env"]

# The SIMPLE views read their player kind's spec; these name HUMAN-LIKE's.


class HumanLikeRallyParallelEnv(SimpleRallyParallelEnv):
    """One HUMAN-LIKE rally, both players acting every decision."""

    metadata = {**SimpleRallyParallelEnv.metadata, "name": "humanlike_rally_v0"}
    player_spec = HUMANLIKE


class HumanLikeRallyAECEnv(SimpleRallyAECEnv):
    """The parallel HUMAN-LIKE rally as a PettingZoo ``AECEnv`` (``raw_env``)."""

    metadata = {**HumanLikeRallyParallelEnv.metadata, "is_parallelizable": True}
    parallel = HumanLikeRallyParallelEnv


raw_env = HumanLikeRallyAECEnv


class HumanLikeRallyVectorEnv(SimpleRallyVectorEnv):
    """N HUMAN-LIKE rallies as 2N Gymnasium slots (slot 2e + p: player p of rally e)."""

    player_spec = HUMANLIKE


def parallel_env(**kwargs: Any) -> HumanLikeRallyParallelEnv:
    """The HUMAN-LIKE rally as a PettingZoo ``ParallelEnv`` (arguments as ``simple_rally_v0``)."""
    return HumanLikeRallyParallelEnv(**kwargs)


def env(**kwargs: Any) -> OrderEnforcingWrapper:
    """The HUMAN-LIKE rally as a PettingZoo ``AECEnv`` in PettingZoo's ``OrderEnforcingWrapper``
    (as ``simple_rally_v0.env``)."""
    return OrderEnforcingWrapper(raw_env(**kwargs))


# The turn game moved to its own module; its old names here still work, with a warning.
__getattr__ = moved(__name__, "rallysim.envs.humanlike_rally_turn_v0", {
    "turn_env": "raw_env", "HumanLikeRallyTurnAECEnv": "HumanLikeRallyTurnAECEnv",
    "HumanLikeRallyTurnVectorEnv": "HumanLikeRallyTurnVectorEnv",
    "HumanLikeRallyTurnEnv": "HumanLikeRallyTurnEnv"})
