"""Gymnasium registration of RallySim's environments (run on ``import rallysim``).

Every id has a single env (``gym.make``) and a native vector env (``gym.make_vec``: its
``vector_entry_point``, all games stepped in one call), both in ``rallysim.envs``:

- ``RallySim/SimpleReturn-v1``: ``simple_return_v0.SimpleReturnEnv`` /
  ``SimpleReturnVectorEnv`` with ``goals="reachable"``; action ``Box(-1, 1, (3,))``. The
  current id of the SIMPLE low-level task: it differs from v0 only in its default goal
  distribution, and ``goals="uniform"`` gives v0's (the paper's), step for step.
- ``RallySim/SimpleReturn-v0``: the same classes, goals uniform over [2, 6] m; kept unchanged for
  old code (Gymnasium warns on ``make`` that v1 exists).
- ``RallySim/HumanLikeReturn-v0``: ``humanlike_return_v0.HumanLikeReturnEnv`` /
  ``HumanLikeReturnVectorEnv``; action ``Box(-1, 1, (15,))``.
- ``RallySim/SimpleRallyTurn-v0``: ``simple_rally_turn_v0.SimpleRallyTurnEnv`` /
  ``SimpleRallyTurnVectorEnv``; action the goal depth in metres, ``Box(2, 6, (1,))``.
- ``RallySim/SimpleRallyTurn-v1``: ``simple_rally_turn_v1.SimpleRallyTurnV1Env`` /
  ``SimpleRallyTurnV1VectorEnv``; action ``Box(-1, 1, (1,))``, the goal depth 4 + 2a metres.
- ``RallySim/HumanLikeRallyTurn-v0``: ``humanlike_rally_turn_v0.HumanLikeRallyTurnEnv`` /
  ``HumanLikeRallyTurnVectorEnv``; action ``Box(-1, 1, (3,))``, the goal racket velocity
  (speed, elevation, azimuth; see ``humanlike_rally_v0``).

The turn ids are the cooperative turn-based rallies as single-agent envs: both players' low
levels are frozen (``low_level``, default ``"scripted"``), one step is one turn, one shared
policy picks the goal of whoever's turn has begun. Prefer ``SimpleRallyTurn-v1`` to v0 (see
``simple_rally_turn_v1``'s version history); Gymnasium's ``make`` of v0 now says so with a
``DeprecationWarning``, as it does for every id that has a newer version.
"""

from __future__ import annotations

import gymnasium as gym

SIMPLE_RETURN_ID = "RallySim/SimpleReturn-v0"
SIMPLE_RETURN_V1_ID = "RallySim/SimpleReturn-v1"
SIMPLE_RALLY_TURN_ID = "RallySim/SimpleRallyTurn-v0"
SIMPLE_RALLY_TURN_V1_ID = "RallySim/SimpleRallyTurn-v1"
HUMANLIKE_RETURN_ID = "RallySim/HumanLikeReturn-v0"
HUMANLIKE_RALLY_TURN_ID = "RallySim/HumanLikeRallyTurn-v0"

_ENVS = "rallysim.envs."
# id -> (entry point, vector entry point, extra register() arguments)
_SPECS: dict[str, tuple[str, str, dict]] = {
    # the return tasks truncate at 1000 decisions themselves (docs/reference.md §2): no
    # TimeLimit wrapper
    HUMANLIKE_RETURN_ID: (_ENVS + "humanlike_return_v0:HumanLikeReturnEnv",
                          _ENVS + "humanlike_return_v0:HumanLikeReturnVectorEnv",
                          {"max_episode_steps": None}),
    SIMPLE_RALLY_TURN_ID: (_ENVS + "simple_rally_turn_v0:SimpleRallyTurnEnv",
                           _ENVS + "simple_rally_turn_v0:SimpleRallyTurnVectorEnv", {}),
    SIMPLE_RALLY_TURN_V1_ID: (_ENVS + "simple_rally_turn_v1:SimpleRallyTurnV1Env",
                              _ENVS + "simple_rally_turn_v1:SimpleRallyTurnV1VectorEnv", {}),
    HUMANLIKE_RALLY_TURN_ID: (_ENVS + "humanlike_rally_turn_v0:HumanLikeRallyTurnEnv",
                              _ENVS + "humanlike_rally_turn_v0:HumanLikeRallyTurnVectorEnv", {}),
    SIMPLE_RETURN_ID: (_ENVS + "simple_return_v0:SimpleReturnEnv",
                       _ENVS + "simple_return_v0:SimpleReturnVectorEnv",
                       {"max_episode_steps": None}),
    # v1: goals the serve makes reachable (envs.simple_return_v0's version history)
    SIMPLE_RETURN_V1_ID: (_ENVS + "simple_return_v0:SimpleReturnEnv",
                          _ENVS + "simple_return_v0:SimpleReturnVectorEnv",
                          {"max_episode_steps": None, "kwargs": {"goals": "reachable"}}),
}


def register_envs() -> None:
    # each id checked on its own: a repeated import must not register twice (Gymnasium warns),
    # and an id registered by hand first is left as it is
    for env_id, (entry_point, vector_entry_point, extra) in _SPECS.items():
        if env_id not in gym.registry:
            gym.register(id=env_id, entry_point=entry_point,
                         vector_entry_point=vector_entry_point, **extra)
