"""The SIMPLE player (docs/reference.md §5-8): a base sliding along x and one arm swinging in the
x-z plane.

Its goal is a landing depth beyond the net, in [2, 6] m; a high-level network's action a in
[-1, 1] sets it to 4 + 2a m, the original's mapping.
"""

from __future__ import annotations

import numpy as np

from rallysim.core.bodies import SimpleBodies
from rallysim.core.game import PHYSICS_DT
from rallysim.core.serve import MachineServe
from rallysim.core.simple_obs import PLAYER_OBS as OBS
from rallysim.core.simple_obs import TARGET_DEPTH_RANGE, normalise_depth, opponent_positions
from rallysim.core.simple_obs import observations_with as observe_with
from rallysim.core.simple_obs import player_observations as observe
from rallysim.players.spec import GoalSpec, Layout, PlayerSpec, StartPose
from rallysim.policies.scripted import ScriptedController
from rallysim.policies.types import Policy

ACTION = Layout((("target_orientation", 1), ("force", 1), ("movement", 1)))
GOAL = GoalSpec(size=1, low=(TARGET_DEPTH_RANGE[0],), high=(TARGET_DEPTH_RANGE[1],), default=4.0,
                unit="m", mapping="goal_m = 4 + 2 * clip(action, -1, 1)")


def make_bodies(n_envs: int, n_players: int) -> SimpleBodies:
    return SimpleBodies(n_envs, n_players, PHYSICS_DT)


def low_observations(obs: np.ndarray, goals: np.ndarray) -> np.ndarray:
    """Rally observations (M, 20) and goal depths (M,) -> the low-level task's (M, 17)."""
    x = np.empty((len(obs), OBS.size + 1), np.float32)
    x[:, :OBS.size] = obs[:, :OBS.size]
    x[:, OBS.size] = normalise_depth(goals)
    return x


def scripted_task_low() -> Policy:
    return ScriptedController().act_return


PLAYER = SIMPLE = PlayerSpec(
    name="simple", asset="simple_player.xml", make_bodies=make_bodies,
    obs=OBS, low_obs=OBS.extended(("goal_depth", 1)),
    rally_obs=OBS.extended(("opponent_position", 3), ("my_turn", 1)),
    action=ACTION, goal=GOAL, start=StartPose(base_x=(-2.7, -2.44)), serve=MachineServe(),
    observe=observe, observe_with=observe_with, opponent=opponent_positions,
    low_observations=low_observations, scripted_low=ScriptedController,
    scripted_task_low=scripted_task_low, camera="side",
    low_env_id="RallySim/SimpleReturn-v0", rig="rallysim.render.players:SimpleRig")
