"""Gymnasium registration of RallySim's environments (run on ``import rallysim``)."""

from __future__ import annotations

import gymnasium as gym

SIMPLE_RETURN_ID = "RallySim/SimpleReturn-v0"
SIMPLE_RALLY_TURN_ID = "RallySim/SimpleRallyTurn-v0"
HUMANLIKE_RETURN_ID = "RallySim/HumanLikeReturn-v0"


def register_envs() -> None:
    if HUMANLIKE_RETURN_ID not in gym.registry:
        gym.register(
            id=HUMANLIKE_RETURN_ID,
            entry_point="rallysim.envs.humanlike_return_v0:HumanLikeReturnEnv",
            vector_entry_point="rallysim.envs.humanlike_return_v0:HumanLikeReturnVectorEnv",
            max_episode_steps=None,  # the env truncates at 1000 decisions itself
        )
    if SIMPLE_RALLY_TURN_ID not in gym.registry:
        gym.register(
            id=SIMPLE_RALLY_TURN_ID,
            entry_point="rallysim.envs.simple_rally_v0:SimpleRallyTurnEnv",
            vector_entry_point="rallysim.envs.simple_rally_v0:SimpleRallyTurnVectorEnv",
        )
    if SIMPLE_RETURN_ID in gym.registry:
        return
    gym.register(
        id=SIMPLE_RETURN_ID,
        entry_point="rallysim.envs.simple_return_v0:SimpleReturnEnv",
        vector_entry_point="rallysim.envs.simple_return_v0:SimpleReturnVectorEnv",
        max_episode_steps=None,  # the env truncates at 1000 decisions itself (SPEC §2)
    )
