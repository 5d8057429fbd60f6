"""``RallySim/HumanLikeReturn-v0``: the HUMAN-LIKE low-level task (SPEC §10).

One HUMAN-LIKE player (a humanoid upper body on kinematic hips, racket in the right hand; see
``rallysim.core.humanlike`` and ``assets/humanlike_player.xml``) stands at x < 0. A serve comes
over the net; the player must hit it with the racket moving at ``target_velocity``. One hit per
episode; the episode ends when the shuttle lands.

## Action space: ``Box(-1, 1, (15,), float32)``
| index | name | effect |
|---|---|---|
| 0-1 | movement x, y | hips velocity = 5 * a m/s (own frame), hips centre kept in x in [-6.5, -0.5], y in [-2.8, 2.8] m |
| 2 | spine z | target angle, a in [-1, 1] spanning -15..15 deg |
| 3 | chest z | target angle, -15..15 deg |
| 4-6 | upper arm x, y, z | target angles, -90..90, -75..75, -85..85 deg |
| 7 | lower arm x | target angle, 0..100 deg |
| 8-9 | hand x, y | target angles, -90..90, -25..25 deg |
| 10-14 | strength of spine, chest, upper arm, lower arm, hand | torque limit = (a + 1) / 2 of 100, 100, 60, 40, 10 N m |

Target angle = lo + (a + 1) / 2 * (hi - lo). Actions outside [-1, 1] are clipped; NaN, inf or a
wrong shape raise ``ValueError``. The action is held for the 5 physics steps (0.02 s each) of one
decision (0.1 s).

## Observation space: ``Box(-1, 1, (85,), float32)``
Indices 0-81 are the player observation of ``rallysim.envs.humanlike_obs`` (for each of spine,
chest, upper arm, lower arm and hand: velocity 3, angular velocity 3, position relative to the
hips 3, orientation quaternion 4, torque magnitude 1; then shuttle position 3 and velocity 3,
hips position 3, racket head position 3; all own-frame and scaled); indices 82-84 are the target
racket velocity / 5 m/s. Values are clipped into the bounds.

## Rewards
| term | value |
|---|---|
| hit | 0.5 * (R_hit + exp(-1.5 * d)), R_hit = 1, d = abs(v - v*) in m/s, v the racket face centre's velocity at the impact (own frame), v* the target |
| otherwise | 0 |

The maximum is 1.0 per episode. After the hit the shuttle leaves along v at min(60, 5 abs(v)) m/s.

## Starting state
Serve (SPEC §10): from x0 ~ U[1, 6], y0 ~ U[-1, 1], z0 ~ U[1, 1.5] m on the far side, along
normalise(-3, U(-0.5, 0.5), U(2, 3)) at 15 m/s (with the ``paper`` flight it always clears
the net and lands at x in [-6.3, -0.5] m after 1.5-1.9 s; with ``aero`` 7 % meet the net). Hips at x ~ U[-4.5, -1.5], y ~ U[-1.5, 1.5] m, joints at
the zero pose (a T-pose: arm out to the right, racket continuing it), at rest. Target racket
velocity: speed ~ U[1.5, 4.5] m/s, elevation ~ U[40, 50] deg, azimuth ~ U[-30, 30] deg about
+x (toward the far court).

## Episode end
Terminates when the shuttle's centre drops below z = 0; truncates after 1000 decisions.

## Arguments
| argument | default | meaning |
|---|---|---|
| ``shuttle`` | ``"paper"`` | flight model: ``"paper"``, ``"paper-alg1"`` or ``"aero"`` |
| ``max_decisions`` | ``1000`` | truncation |
| ``render_mode`` | ``None`` | ``"rgb_array"``: ``render()`` returns a 640x360 frame (three-quarter view, the target velocity as a red arrow from the racket head); ``"human"`` (with a display): a viewer window |

``reset(options=...)`` accepts ``target_velocity`` (m/s, own frame, 3 values each in [-5, 5],
a speed of at least 0.5 m/s) and ``hips_position`` (m, own frame x, y within the hips range);
the vector env takes one value for all environments or one per environment.

## ``info``
``hit``, ``racket_velocity`` (m/s, own frame, at the hit), ``velocity_error`` (d, m/s),
``angle_error`` (degrees between v and v*; NaN if the racket was still), ``speed_error``
((abs(v) - abs(v*)) / abs(v*), signed), ``net_touch``, ``landed``, ``landing_point`` (world, m),
``target_velocity``. The single env gives the hit values only on a hit and ``landing_point``
only at the landing; the vector env gives arrays for all keys, with NaN where a value does not
apply and Gymnasium's ``_key`` masks marking where it does.

## Version history
- v0: first release.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np
from gymnasium import spaces

from rallysim.assets import asset_path
from rallysim.core.game import PHYSICS_DT, PHYSICS_STEPS_PER_DECISION, Game
from rallysim.core.humanlike import N_ACTIONS, HumanLikeBodies, humanlike_geometry
from rallysim.core.lanes import column
from rallysim.core.rules import SERVE_DRAWS
from rallysim.core.serve import HumanLikeServe
from rallysim.core.shuttle import ShuttleState, make_shuttle_model
from rallysim.envs.humanlike_obs import HIPS, PLAYER_OBS_SIZE, SHUTTLE, player_observations
from rallysim.envs.rendering import RENDER_MODES, EnvView
from rallysim.envs.simple_obs import POSITION_CENTRE, POSITION_SCALE, SHUTTLE_SPEED_SCALE
from rallysim.envs.task_env import TaskEnv, box_spaces
from rallysim.envs.validation import positive_int, read_options
from rallysim.envs.vector_base import NEXT_STEP, TaskVectorEnv
from rallysim.players.humanlike import (
    TARGET_SCALE,
    sample_targets,
)

OBS_SIZE = PLAYER_OBS_SIZE + 3  # 85
ACTION_SIZE = N_ACTIONS  # 15
MAX_DECISIONS = 1000
R_HIT = 1.0
R_VELOCITY_RATE = 1.5
HIPS_START = np.array([[-4.5, -1.5], [-1.5, 1.5]])  # x and y ranges
MIN_TARGET_SPEED = 0.5  # m/s: a target needs a direction, and the speed error divides by it
HIT_KEYS = ("racket_velocity", "velocity_error", "angle_error", "speed_error")
N_DRAWS = 5  # uniforms one reset draws per environment before its serve's (SERVE below)
# The HUMAN-LIKE serve of SPEC §10 (rallysim.core.serve), drawn after the start's uniforms and
# followed by the machine serve's draws, unused, which keeps v0's seeded episodes.
SERVE = HumanLikeServe(unused_after=SERVE_DRAWS)


class HumanLikeReturnTask:
    """The HUMAN-LIKE low-level task over N batched games: goals, rewards, ends, observations."""

    def __init__(self, num_envs: int, shuttle: str = "paper", seed: int | None = None,
                 max_decisions: int = MAX_DECISIONS) -> None:
        positive_int(max_decisions, "max_decisions")
        self.n = num_envs
        self.bodies = HumanLikeBodies(num_envs, 1)
        self.game = Game(num_envs, 1, shuttle=shuttle, seed=seed, bodies=self.bodies,
                         serve=SERVE)
        self.max_decisions = max_decisions
        self.goal = np.zeros((num_envs, 3))
        self.elapsed = np.zeros(num_envs, np.int64)

    def reset(self, envs: np.ndarray, options: dict[str, Any] | None = None) -> None:
        envs = np.asarray(envs, np.int64)
        k, game = len(envs), self.game
        given = self.reset_options(options, k)
        # One draw per environment from its own stream, whatever the options say, so that
        # an option changes only the value it sets; then the serve's (``SERVE``).
        u = np.stack([game.rngs[e].random(N_DRAWS) for e in envs]).reshape(k, N_DRAWS)
        lo, hi = HIPS_START[:, 0], HIPS_START[:, 1]
        hips = given.get("hips_position", lo + u[:, 0:2] * (hi - lo))
        self.goal[envs] = given.get("target_velocity", sample_targets(u[:, 2:5]))
        game.reset(envs, receiver=0, base_x=hips[:, :1], theta=0.0, base_y=hips[:, 1:])
        self.elapsed[envs] = 0

    def reset_options(self, options: dict[str, Any] | None, k: int) -> dict[str, np.ndarray]:
        """The given reset options for ``k`` environments, checked (``ValueError``)."""
        given = read_options(options, {
            "target_velocity": ((k, 3), np.array([[-TARGET_SCALE, TARGET_SCALE]] * 3)),
            "hips_position": ((k, 2), self.bodies.hips_range)})
        if "target_velocity" in given:
            slow = np.linalg.norm(given["target_velocity"], axis=1) < MIN_TARGET_SPEED
            if slow.any():
                raise ValueError(f"option 'target_velocity' needs a speed of at least "
                                 f"{MIN_TARGET_SPEED} m/s (its direction is the goal), got "
                                 f"{given['target_velocity'][slow][0].tolist()}")
        return given

    def observe(self) -> np.ndarray:
        obs = np.empty((self.n, OBS_SIZE))
        obs[:, :PLAYER_OBS_SIZE] = player_observations(self.game)[:, 0]
        obs[:, PLAYER_OBS_SIZE:] = self.goal / TARGET_SCALE
        return np.clip(obs, -1.0, 1.0).astype(np.float32)

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """Advance all N games by one decision with validated, clipped ``actions`` (N, 15):
        rewards, terminated, truncated and info, as (N,) (or (N, 3)) arrays."""
        reward, terminated, truncated, values = self.outcome(actions)
        info = {key: column(value, self.n) for key, value in values.items()}
        # Gymnasium's vector convention: "_key" marks the environments where "key" applies.
        for key in HIT_KEYS:
            info["_" + key] = info["hit"].copy()
        info["_landing_point"] = info["landed"].copy()
        return (column(reward, self.n), column(terminated, self.n), column(truncated, self.n),
                info)

    def outcome(self, actions: np.ndarray) -> tuple[Any, Any, Any, dict[str, Any]]:
        """``step``'s values as lanes of ``game.ops`` (rallysim.core.lanes: Python values for
        one environment where they are numbers), not yet copied into arrays."""
        game, ops = self.game, self.game.ops
        read = ops.read
        ev = game.step(actions[:, None, :])
        self.elapsed += 1
        hit, landed = read(ev.hit[:, 0]), read(ev.landed)
        if ops.any(hit):
            reward, values = self._hit_values(ev.hit[:, 0], ev.hit_velocity[:, 0])
        else:  # rewards and hit values only come with a hit
            reward = 0.0
            values = {"racket_velocity": np.full((self.n, 3), np.nan), "velocity_error": np.nan,
                      "angle_error": np.nan, "speed_error": np.nan}
        landing = (np.where(ev.landed[:, None], ev.land_point, np.nan) if ops.any(landed)
                   else np.full((self.n, 3), np.nan))
        truncated = ops.logical_not(landed) & (read(self.elapsed) >= self.max_decisions)
        return reward, landed, truncated, {
            "hit": hit, **values, "net_touch": read(ev.net_touch), "landed": landed,
            "landing_point": landing, "target_velocity": self.goal}

    def _hit_values(self, hit: np.ndarray, velocity: np.ndarray
                    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Rewards and hit values (NaN without a hit) of (N,) ``hit`` at racket ``velocity``
        (N, 3)."""
        v = np.where(hit[:, None], velocity, np.nan)
        error = np.linalg.norm(v - self.goal, axis=1)
        reward = np.where(hit, 0.5 * (R_HIT + np.exp(-R_VELOCITY_RATE * np.nan_to_num(error))),
                          0.0)
        speed, goal_speed = np.linalg.norm(v, axis=1), np.linalg.norm(self.goal, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            cos = np.einsum("ij,ij->i", v, self.goal) / (speed * goal_speed)
            angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
            speed_error = (speed - goal_speed) / goal_speed
        return reward, {"racket_velocity": v, "velocity_error": error, "angle_error": angle,
                        "speed_error": speed_error}


def _spaces() -> tuple[spaces.Box, spaces.Box]:
    return box_spaces(OBS_SIZE, ACTION_SIZE)


class HumanLikeReturnEnv(TaskEnv):
    """One environment of the HUMAN-LIKE low-level task. See the module docstring."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 10}
    goal_key = "target_velocity"
    hit_keys = HIT_KEYS
    landing_keys = ("landing_point",)

    def __init__(self, shuttle: str = "paper", max_decisions: int = MAX_DECISIONS,
                 render_mode: str | None = None) -> None:
        task = HumanLikeReturnTask(1, shuttle, None, max_decisions)
        self._init_task(task, OBS_SIZE, ACTION_SIZE, render_mode, {"player": "humanlike"})

    def _frame(self, view: EnvView, env: int) -> np.ndarray | None:
        """The player's half court from behind its right with the target racket velocity as
        a red arrow from the racket head (``"rgb_array"``)."""
        return render_humanlike_return(view, self.task, env)


def render_humanlike_return(view: EnvView, task: HumanLikeReturnTask, env: int,
                            ) -> np.ndarray | None:
    goal = task.goal[env]
    hud = (f"target ({goal[0]:+.1f}, {goal[1]:+.1f}, {goal[2]:+.1f}) m/s   "
           f"t {0.1 * task.elapsed[env]:.1f} s   shuttle {task.game.flight.name}")
    return view.render(task.game, env, hud_text=hud, target_velocity=goal)


class HumanLikeReturnVectorEnv(TaskVectorEnv):
    """N environments of the HUMAN-LIKE low-level task stepped together in one call.

    One MuJoCo model holds all N players and the rules run as array code. ``autoreset_mode``
    is ``"next_step"`` (the Gymnasium default) or ``"same_step"``; see
    ``rallysim.envs.vector_base.NativeVectorEnv``."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 10, "autoreset_mode": NEXT_STEP}

    goal_key = "target_velocity"
    action_size = ACTION_SIZE

    def __init__(self, num_envs: int = 1, shuttle: str = "paper",
                 max_decisions: int = MAX_DECISIONS, autoreset_mode: str = "next_step",
                 render_mode: str | None = None, seed: int | None = None,
                 render_envs: int = 1) -> None:
        num_envs = positive_int(num_envs, "num_envs")
        task = HumanLikeReturnTask(num_envs, shuttle, seed, max_decisions)
        self._init_task(num_envs, autoreset_mode, task, _spaces(), render_mode, render_envs,
                        {"player": "humanlike"})

    def _frame(self, view: EnvView, env: int) -> np.ndarray | None:
        return render_humanlike_return(view, self.task, env)

    def _blank_info(self, info: dict, units: np.ndarray) -> None:
        super()._blank_info(info, units)
        for key in (*HIT_KEYS, "landing_point"):
            info[key][units] = np.nan
        info["target_velocity"][units] = self.task.goal[units]


# -- a scripted player ---------------------------------------------------------------------------
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
        actions = np.empty((n, ACTION_SIZE))
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

