"""A scripted HUMAN-LIKE player for the low-level task: it hits reliably, it does not aim."""

from __future__ import annotations

import mujoco
import numpy as np

from rallysim.assets import asset_path
from rallysim.core.game import PHYSICS_DT, PHYSICS_STEPS_PER_DECISION
from rallysim.core.humanlike import N_ACTIONS, HumanLikeBodies, humanlike_geometry
from rallysim.core.humanlike_obs import HIPS, SHUTTLE
from rallysim.core.shuttle import ShuttleState, make_shuttle_model
from rallysim.core.simple_obs import POSITION_CENTRE, POSITION_SCALE, SHUTTLE_SPEED_SCALE


class ScriptedSwing:
    """A scripted HUMAN-LIKE player: ``controller(observations (N, 85)) -> actions (N, 15)``.

    It predicts the shuttle with the task's flight model, walks the hips so that the racket face
    of its contact pose (arm out to the right, swung 30 degrees forward, face up) will be under
    the shuttle when it falls to the face's height, holds the arm low (the wind-up pose) and,
    ``lead`` seconds before that meeting, raises it through the contact pose toward the
    follow-through pose: the face rises into the falling shuttle, which tolerates timing errors
    of a decision or more. The upper arm swings at ``arm_strength`` (an action value; -0.3 is
    35 % strength, a 2.5-4.5 m/s lift, the targets' speeds); the other joints hold their pose at
    full strength. It reads only the observation, so it serves any batch of the task. It hits
    reliably; it does not aim at the target velocity (its lift is nearly vertical).
    """

    # joint angles (degrees, in JOINTS order) of the three poses
    wind_up = (0.0, 0.0, -35.0, 30.0, 0.0, 0.0, 0.0, 0.0)
    contact = (0.0, 0.0, 0.0, 30.0, 0.0, 0.0, 0.0, 0.0)
    follow_through = (0.0, 0.0, 35.0, 30.0, 0.0, 0.0, 0.0, 0.0)
    horizon_steps = 200  # physics steps of shuttle prediction (4 s)

    def __init__(self, shuttle: str = "paper", lead: float = 0.1, arm_strength: float = -0.3
                 ) -> None:
        self.flight = make_shuttle_model(shuttle, PHYSICS_DT)
        self.lead, self.arm_strength = lead, arm_strength
        offset = _face_offset(np.radians(self.contact))  # face centre - hips centre
        self.reach = offset[:2]
        self.contact_height = HumanLikeBodies.hips_height + offset[2]
        geo = humanlike_geometry()
        lo, hi = geo["joint_lo"], geo["joint_hi"]
        self._pose_actions = {name: 2.0 * (np.radians(pose) - lo) / (hi - lo) - 1.0
                              for name, pose in (("wind_up", self.wind_up),
                                                 ("follow_through", self.follow_through))}

    def predict_meeting(self, pos: np.ndarray, vel: np.ndarray
                        ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Seconds until each shuttle (N, 3) falls to the contact height, its x, y there, and
        whether it does within the horizon."""
        s = ShuttleState(pos.copy(), vel.copy(), np.zeros(len(pos)), np.zeros(len(pos)))
        n = len(pos)
        t = np.full(n, np.inf)
        xy = pos[:, :2].copy()
        for k in range(1, self.horizon_steps + 1):
            self.flight.advance(s, PHYSICS_DT)
            new = ~np.isfinite(t) & (s.pos[:, 2] <= self.contact_height) & (s.vel[:, 2] < 0)
            t[new] = k * PHYSICS_DT
            xy[new] = s.pos[new, :2]
            if np.isfinite(t).all():
                break
        return t, xy, np.isfinite(t)

    def __call__(self, observations: np.ndarray) -> np.ndarray:
        obs = np.asarray(observations, dtype=np.float64)
        n = len(obs)
        pos = obs[:, SHUTTLE][:, :3] * POSITION_SCALE + POSITION_CENTRE
        vel = obs[:, SHUTTLE][:, 3:] * SHUTTLE_SPEED_SCALE
        hips = (obs[:, HIPS] * POSITION_SCALE + POSITION_CENTRE)[:, :2]
        t, xy, found = self.predict_meeting(pos, vel)
        actions = np.empty((n, N_ACTIONS))
        goal = np.where(found[:, None], xy - self.reach, hips)
        step = HumanLikeBodies.max_hips_speed * PHYSICS_DT * PHYSICS_STEPS_PER_DECISION
        actions[:, 0:2] = np.clip((goal - hips) / step, -1.0, 1.0)
        swing = found & (t <= self.lead + 1e-9)
        actions[:, 2:10] = np.where(swing[:, None], self._pose_actions["follow_through"],
                                    self._pose_actions["wind_up"])
        actions[:, 10:] = 1.0  # full strength, but for the swinging upper arm
        actions[:, 12] = self.arm_strength
        return actions


def _face_offset(pose: np.ndarray) -> np.ndarray:
    """Face centre minus hips centre (own frame) for joint angles ``pose`` (radians)."""
    m = mujoco.MjModel.from_xml_path(str(asset_path("humanlike_player.xml")))
    d = mujoco.MjData(m)
    d.qpos[:] = pose
    mujoco.mj_kinematics(m, d)
    return d.site_xpos[0] - d.mocap_pos[0]
