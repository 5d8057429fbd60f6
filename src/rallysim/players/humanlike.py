"""The HUMAN-LIKE player (docs/reference.md §10): a humanoid upper body on kinematic hips, racket
in the right hand, 15 actuators.

Its goal is the racket's velocity at the hit, given as three values in [-1, 1] that map onto
the low-level task's target range: speed 1.5 + 1.5 (g0 + 1) m/s, elevation 40 + 5 (g1 + 1) deg,
azimuth 30 g2 deg (own frame). A high-level network's action is the goal itself.
"""

from __future__ import annotations

import numpy as np

from rallysim.core.humanlike import HumanLikeBodies
from rallysim.core.humanlike_obs import PLAYER_OBS as OBS
from rallysim.core.humanlike_obs import TARGET_SCALE, opponent_positions
from rallysim.core.humanlike_obs import observations_with as observe_with
from rallysim.core.humanlike_obs import player_observations as observe
from rallysim.core.rules import SERVE_DRAWS
from rallysim.core.serve import HumanLikeServe
from rallysim.players.spec import GoalSpec, Layout, PlayerSpec, StartPose
from rallysim.policies.aimed_swing import AimedSwing
from rallysim.policies.callables import GoalConditioned

ACTION = Layout((("movement", 2), ("spine_z", 1), ("chest_z", 1), ("upper_arm", 3),
                 ("lower_arm_x", 1), ("hand", 2), ("strength", 5)))
TARGET_SPEED = (1.5, 4.5)  # m/s
TARGET_ELEVATION = (np.radians(40.0), np.radians(50.0))
TARGET_AZIMUTH = (np.radians(-30.0), np.radians(30.0))
GOAL = GoalSpec(size=3, low=(-1.0, -1.0, -1.0), high=(1.0, 1.0, 1.0), default=(0.0, 0.0, 0.0),
                unit="", mapping="target racket velocity: speed 1.5 + 1.5 (a0 + 1) m/s, "
                "elevation 40 + 5 (a1 + 1) deg, azimuth 30 a2 deg (own frame)")


def sample_targets(u: np.ndarray) -> np.ndarray:
    """Target racket velocities (n, 3), own frame, from uniforms ``u`` (n, 3) in [0, 1)."""
    speed = TARGET_SPEED[0] + u[:, 0] * (TARGET_SPEED[1] - TARGET_SPEED[0])
    elev = TARGET_ELEVATION[0] + u[:, 1] * (TARGET_ELEVATION[1] - TARGET_ELEVATION[0])
    azim = TARGET_AZIMUTH[0] + u[:, 2] * (TARGET_AZIMUTH[1] - TARGET_AZIMUTH[0])
    return speed[:, None] * np.stack([np.cos(elev) * np.cos(azim), np.cos(elev) * np.sin(azim),
                                      np.sin(elev)], axis=1)


def make_bodies(n_envs: int, n_players: int) -> HumanLikeBodies:
    return HumanLikeBodies(n_envs, n_players)


def targets_from_goals(goals: np.ndarray) -> np.ndarray:
    """Goals (M, 3) in [-1, 1] -> target racket velocities (M, 3), m/s, own frame."""
    return sample_targets(0.5 * (np.clip(goals, -1.0, 1.0) + 1.0))


def low_observations(obs: np.ndarray, goals: np.ndarray) -> np.ndarray:
    """Rally observations (M, 86) and goals (M, 3) -> the low-level task's (M, 85)."""
    out = np.empty((len(obs), OBS.size + 3), np.float32)
    out[:, :OBS.size] = obs[:, :OBS.size]
    out[:, OBS.size:] = np.clip(targets_from_goals(goals) / TARGET_SCALE, -1.0, 1.0)
    return out


def scripted_low() -> GoalConditioned:
    return GoalConditioned(AimedSwing(), low_observations)


PLAYER = HUMANLIKE = PlayerSpec(
    name="humanlike", asset="humanlike_player.xml", make_bodies=make_bodies,
    obs=OBS, low_obs=OBS.extended(("target_velocity", 3)),
    rally_obs=OBS.extended(("opponent_position", 3), ("my_turn", 1)),
    action=ACTION, goal=GOAL, start=StartPose(base_x=(-2.7, -2.7), base_y=(0.0, 0.0)),
    # v0's rally drew the machine serve's uniforms, then the HUMAN-LIKE serve's in its place
    serve=HumanLikeServe(unused_before=SERVE_DRAWS),
    observe=observe, observe_with=observe_with, opponent=opponent_positions,
    low_observations=low_observations,
    scripted_low=scripted_low,
    scripted_task_low=AimedSwing, camera="three_quarter_close",
    low_env_id="RallySim/HumanLikeReturn-v0", rig="rallysim.render.players:HumanLikeRig")
