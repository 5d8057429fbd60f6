"""A scripted HUMAN-LIKE player that hits with a commanded racket velocity (``AimedSwing``).

The racket face's velocity at the impact is the sum of two motions that the drive makes exact
(docs/humanlike.md, "Drive"):

- the hips are kinematic: they move at 5 a m/s in the horizontal plane for a whole decision;
- the straight arm turns about the shoulder's forward axis (the raise, ``upper_arm_x``). That
  hinge is the first of the arm's chain and its axis stays horizontal, so while every other
  joint holds still (their servos are deadbeat) the arm turns as one rigid body:
  I w' = L - G cos(theta), with I and G constants of the pose and L the upper arm's strength
  whenever the servo pushes a far target (it then saturates at exactly L). ``ArmSwing``
  integrates that with MuJoCo's own semi-implicit Euler step, so its angles are the
  simulator's to rounding.

The swing has two decisions. The player holds a pose (arm straight, swung 30 deg forward, face
level, raised to theta0) while its hips walk to the meeting; then

1. *accelerate*: the raise's target jumps to the top of its range and the strength L_acc speeds
   the arm up;
2. *coast*: the strength drops to the gravity torque at the meeting angle, so the arm turns at
   an almost constant rate through the whole decision: from one physics step to the next the
   face's vertical speed changes by at most 2.5 % and its direction by w dt (at most 4.4 deg).

The shuttle is met in the coasting decision's middle (``MEET_STEP``, its third physics step),
which the rulebook measures the racket velocity over. A meeting one or two steps early or late
(a clone's hips or arm a little off) still hits near the target velocity. The first design,
a flick of the wrist whose speed doubled from one step to the next, lost the aim whenever the
meeting moved by one step, which is where a clone of it failed (docs/humanlike.md, Training).

In the two swinging decisions the strength is recomputed from the arm's observed angle and rate
(``arm_state``) rather than taken from the plan: a swing started late, early or too fast is
steered back to the target's vertical speed, so DAgger's labels teach a clone to recover.
Everything is read from the observation, so one controller drives any batch.
"""

from __future__ import annotations

import mujoco
import numpy as np

from rallysim.assets import asset_path
from rallysim.core.game import PHYSICS_DT, PHYSICS_STEPS_PER_DECISION
from rallysim.core.humanlike import GROUPS, JOINTS, HumanLikeBodies, humanlike_geometry
from rallysim.core.humanlike_obs import (
    BODY_OBS_SIZE,
    BODY_RATE_SCALE,
    HIPS,
    SHUTTLE,
    TARGET_SCALE,
)
from rallysim.core.shuttle import ShuttleState, make_shuttle_model
from rallysim.core.simple_obs import POSITION_CENTRE, POSITION_SCALE, SHUTTLE_SPEED_SCALE

TARGET = slice(82, 85)  # the task's target racket velocity / TARGET_SCALE
FORWARD_SWING = np.radians(30.0)  # upper_arm_y of every pose
MEET_STEP = 3  # the coasting decision's physics step (1-based) the shuttle is met in
RAISE_HIGHEST = np.radians(20.0)  # the highest meeting: face 0.83 m above the hips centre
RAISE_LOWEST = np.radians(-45.0)
TRUNK_MAX = np.radians(30.0)  # spine + chest turn, +-15 deg each
HALF_DEPTH = 0.125  # the hit volume's half thickness along the face normal (0.025 + 0.1 m)
AIM_WEIGHT = 4.0  # a clone's loss weight of the aiming actions (``imitation_weights``)
HIPS_MARGIN = 0.08  # m kept from the hips' range edges (a clamp would change the velocity)
J = {name: i for i, name in enumerate(JOINTS)}
RAISE_TARGET = 2 + J["upper_arm_x"]  # action indices
ARM_STRENGTH = 2 + len(JOINTS) + GROUPS.index("upper_arm")
CHEST, UPPER_ARM = 1, 2  # observed bodies
SPD = PHYSICS_STEPS_PER_DECISION


class ArmSwing:
    """The straight arm (swung ``FORWARD_SWING`` forward, wrist straight, face level at raise 0)
    turning about the shoulder's raise axis, in the player's frame with the trunk straight:
    the face centre, its normal and the swing's angles, all from one MuJoCo evaluation."""

    def __init__(self) -> None:
        m = mujoco.MjModel.from_xml_path(str(asset_path("humanlike_player.xml")))
        d = mujoco.MjData(m)
        d.qpos[J["upper_arm_y"]] = FORWARD_SWING
        mujoco.mj_forward(m, d)
        full = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, full)
        raise_ = J["upper_arm_x"]
        joint = m.joint("upper_arm_x").id
        anchor = d.xanchor[joint] - d.mocap_pos[0]
        lever = d.site_xpos[0] - d.xanchor[joint]
        # the raise turns about -x: the lever must lie in the level plane, out to the right
        if not (np.allclose(d.xaxis[joint], [-1.0, 0.0, 0.0]) and abs(lever[2]) < 1e-9
                and lever[1] < 0.0):
            raise RuntimeError("unexpected arm geometry in humanlike_player.xml")
        self.inertia = float(full[raise_, raise_])
        self.gravity = float(d.qfrc_bias[raise_])  # the holding torque at raise 0 (level arm)
        self.radius = float(-lever[1])  # the face centre's distance from the raise axis
        self._x = float(anchor[0] + lever[0])
        self._y, self._z = float(anchor[1]), float(anchor[2])

    def face(self, theta: np.ndarray) -> np.ndarray:
        """Face centres (..., 3) relative to the hips centre at raise angles ``theta``."""
        return np.stack([np.full_like(theta, self._x),
                         self._y - self.radius * np.cos(theta),
                         self._z + self.radius * np.sin(theta)], axis=-1)

    def top(self, theta: np.ndarray) -> np.ndarray:
        """Centres (..., 3) of the hit volume's top (the face centre plus the half depth along
        its normal, which tilts with the raise)."""
        normal = np.stack([np.zeros_like(theta), np.sin(theta), np.cos(theta)], axis=-1)
        return self.face(theta) + HALF_DEPTH * normal

    def angles(self, theta: np.ndarray, rate: np.ndarray, first: np.ndarray, then: np.ndarray,
               steps: int) -> np.ndarray:
        """Raise angles (n, steps + 1) from angle ``theta`` and rate ``rate`` (n,) with the
        strength ``first`` for a decision's physics steps and ``then`` after them."""
        out = np.empty((len(theta), steps + 1))
        out[:, 0] = theta
        w = rate.copy()
        for i in range(steps):
            strength = first if i < SPD else then
            w = w + PHYSICS_DT * (strength - self.gravity * np.cos(out[:, i])) / self.inertia
            out[:, i + 1] = out[:, i] + PHYSICS_DT * w
        return out

    def lift(self, theta: np.ndarray, step: int | np.ndarray) -> np.ndarray:
        """The face's vertical velocity over physics step ``step`` (1-based; one for every row
        or one per row) of ``angles``."""
        rows = np.arange(len(theta))
        end = np.broadcast_to(step, rows.shape)
        z = self.radius * (np.sin(theta[rows, end]) - np.sin(theta[rows, end - 1]))
        return z / PHYSICS_DT


def arm_state(obs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """The raise angle and rate (each (n,)) read from observations of the swing's pose family
    (trunk turned about the vertical, arm swung forward, twist 0): the angle from the upper
    arm's direction beside the chest's lateral axis, the rate from its angular velocity about
    the raise axis."""
    o = np.asarray(obs, dtype=np.float64)
    chest = o[:, CHEST * BODY_OBS_SIZE + 9:CHEST * BODY_OBS_SIZE + 13]
    yaw = 2.0 * np.arctan2(chest[:, 3], chest[:, 0])  # the chest turns about z only
    w, x, y, z = o[:, UPPER_ARM * BODY_OBS_SIZE + 9:UPPER_ARM * BODY_OBS_SIZE + 13].T
    along = np.stack([2 * (x * z + w * y), 2 * (y * z - w * x), 1 - 2 * (x * x + y * y)], 1)
    out = np.sin(yaw) * along[:, 0] - np.cos(yaw) * along[:, 1]  # toward the right hand
    spin = o[:, UPPER_ARM * BODY_OBS_SIZE + 3:UPPER_ARM * BODY_OBS_SIZE + 6] * BODY_RATE_SCALE
    rate = -(np.cos(yaw) * spin[:, 0] + np.sin(yaw) * spin[:, 1])
    return np.arctan2(along[:, 2], out), rate


def _turn(v: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Vectors (n, 3) turned by ``yaw`` (n,) about the vertical."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]], axis=1)


class AimedSwing:
    """``controller(observations (N, 85)) -> actions (N, 15)`` for ``HumanLikeReturn-v0``:
    hits the shuttle with the racket moving at the observed target velocity. See the module
    docstring for how."""

    horizon_steps = 200  # physics steps of shuttle prediction (4 s)

    def __init__(self, shuttle: str = "paper") -> None:
        self.flight = make_shuttle_model(shuttle, PHYSICS_DT)
        self.arm = ArmSwing()
        geo = humanlike_geometry()
        self._lo, self._hi = geo["joint_lo"], geo["joint_hi"]
        self._arm_max = float(geo["group_max_torque"][GROUPS.index("upper_arm")])
        self._yaw = np.linspace(-TRUNK_MAX, TRUNK_MAX, 61)
        self._raise = np.linspace(-np.pi / 2, np.pi / 2, 721)  # top() is monotone over it
        self._top_z = self.arm.top(self._raise)[:, 2]
        self._aim_weights = np.ones(2 + len(JOINTS) + len(GROUPS))
        self._aim_weights[[0, 1, RAISE_TARGET, ARM_STRENGTH]] = AIM_WEIGHT

    def predict(self, pos: np.ndarray, vel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """The shuttles' positions and velocities (N, H + 1, 3) at every physics step."""
        s = ShuttleState(pos.copy(), vel.copy(), np.zeros(len(pos)), np.zeros(len(pos)))
        p = np.empty((len(pos), self.horizon_steps + 1, 3))
        v = np.empty_like(p)
        p[:, 0], v[:, 0] = pos, vel
        for k in range(1, self.horizon_steps + 1):
            self.flight.advance(s, PHYSICS_DT)
            p[:, k], v[:, k] = s.pos, s.vel
        return p, v

    def swing(self, meet: np.ndarray, lift: np.ndarray) -> tuple[np.ndarray, ...]:
        """The swing from rest that, half into the coasting decision's ``MEET_STEP``, puts the
        hit volume's top at raise angle ``meet`` and moves the face up at ``lift`` m/s: the
        held angle theta0, the strengths of accelerating and coasting, and the angles (n, 11).
        Newton's method on (theta0, L_acc); coasting balances gravity at ``meet``."""
        arm, step = self.arm, SPD + MEET_STEP
        coast = arm.gravity * np.cos(meet)
        rate = lift / (arm.radius * np.cos(meet))
        x = np.stack([meet - rate * PHYSICS_DT * (SPD + MEET_STEP + 0.5),
                      coast + arm.inertia * rate / (SPD * PHYSICS_DT)], axis=1)
        goal = np.stack([arm.top(meet)[:, 2], lift], axis=1)
        rest = np.zeros(len(meet))

        def outcome(x: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
            th = arm.angles(x[:, 0], rest, x[:, 1], coast, 2 * SPD)
            height = 0.5 * (arm.top(th[:, step - 1])[:, 2] + arm.top(th[:, step])[:, 2])
            return np.stack([height, arm.lift(th, step)], axis=1) - goal, th

        for _ in range(6):
            r, _ = outcome(x)
            jac = np.stack([(outcome(x + h)[0] - r) / h[0, i]
                            for i, h in enumerate((np.array([[1e-6, 0.0]]),
                                                   np.array([[0.0, 1e-4]])))], axis=2)
            x = x - np.linalg.solve(jac, r[..., None])[..., 0]
        return x[:, 0], x[:, 1], coast, outcome(x)[1]

    def steer(self, obs: np.ndarray, lift: np.ndarray, coast: np.ndarray,
              accelerating: np.ndarray) -> np.ndarray:
        """The upper arm's strength now, from the arm's observed state, that gives the face
        the vertical velocity ``lift`` in the meeting step: accelerating (then coasting with
        ``coast``) or coasting; Newton's method."""
        theta, rate = arm_state(obs)
        step = np.where(accelerating, SPD + MEET_STEP, MEET_STEP)

        def lift_at(strength: np.ndarray) -> np.ndarray:
            then = np.where(accelerating, coast, strength)
            return self.arm.lift(self.arm.angles(theta, rate, strength, then, SPD + MEET_STEP),
                                 step)

        strength = coast.copy()  # the lift is nearly linear in the strength
        for _ in range(4):
            f = lift_at(strength) - lift
            strength = strength - f * 1e-3 / (lift_at(strength + 1e-3) - lift_at(strength))
        return np.clip(strength, 0.0, self._arm_max)

    def plan(self, obs: np.ndarray) -> dict[str, np.ndarray]:
        """The meeting each observation leads to: whether there is one (a shuttle coming in),
        the coasting decision (0: this one), the swing, the trunk's turn, where the hips must be
        at that decision's start and how they move through it."""
        n = len(obs)
        pos = obs[:, SHUTTLE][:, :3] * POSITION_SCALE + POSITION_CENTRE
        vel = obs[:, SHUTTLE][:, 3:] * SHUTTLE_SPEED_SCALE
        goal = obs[:, TARGET] * TARGET_SCALE
        p, v = self.predict(pos, vel)
        starts = np.arange(0, self.horizon_steps - SPD, SPD)  # physics steps of decision starts
        mid = 0.5 * (p[:, starts + MEET_STEP - 1] + p[:, starts + MEET_STEP])
        meet = np.interp(mid[..., 2] - HumanLikeBodies.hips_height, self._top_z, self._raise)
        ok = ((v[:, starts + MEET_STEP, 2] < 0.0) & (vel[:, None, 0] < 0.0)
              & (meet <= RAISE_HIGHEST) & (meet >= RAISE_LOWEST))
        found = ok.any(axis=1)
        k = np.where(found, ok.argmax(axis=1), 0)
        rows = np.arange(n)
        meet, at = np.clip(meet[rows, k], RAISE_LOWEST, RAISE_HIGHEST), mid[rows, k]
        held, accelerate, coast, th = self.swing(meet, goal[:, 2])
        # the trunk's turn: as far forward as the hips' back edge allows
        meeting = th[:, SPD + MEET_STEP - 1:SPD + MEET_STEP + 1]  # the step's two ends
        top = 0.5 * (self.arm.top(meeting[:, 0]) + self.arm.top(meeting[:, 1]))
        hips_lo, hips_hi = HumanLikeBodies.hips_range[:, 0], HumanLikeBodies.hips_range[:, 1]
        reach_x = np.cos(self._yaw)[None] * top[:, :1] - np.sin(self._yaw)[None] * top[:, 1:2]
        room = at[:, 0] - (hips_lo[0] + HIPS_MARGIN)
        yaw = np.array([np.interp(r, x, self._yaw) for r, x in zip(room, reach_x, strict=True)])
        # the hips supply the horizontal velocity the arm does not
        arm_vel = _turn((self.arm.face(meeting[:, 1]) - self.arm.face(meeting[:, 0]))
                        / PHYSICS_DT, yaw)
        hips_vel = goal[:, :2] - arm_vel[:, :2]
        hips = at[:, :2] - _turn(top, yaw)[:, :2] - (MEET_STEP - 0.5) * PHYSICS_DT * hips_vel
        hips = np.clip(hips, hips_lo + HIPS_MARGIN, hips_hi - HIPS_MARGIN)
        return {"found": found, "decisions": k, "meet": meet, "held": held,
                "accelerate": accelerate, "coast": coast, "yaw": yaw, "hips": hips,
                "hips_vel": hips_vel}

    def imitation_weights(self) -> np.ndarray:
        """Weights (N, 15) of the last call's actions for a clone's loss: 10 in the swing's two
        decisions and the one before (the ones that decide the hit), 1 elsewhere; times
        ``AIM_WEIGHT`` for the actions that aim (hips movement, the raise's target, the upper
        arm's strength), which the rest hold constant."""
        plan = self.last_plan
        swing = 1.0 + 9.0 * (plan["found"] & (plan["decisions"] <= 2))
        return swing[:, None] * self._aim_weights

    def __call__(self, observations: np.ndarray) -> np.ndarray:
        obs = np.asarray(observations, dtype=np.float64)
        n = len(obs)
        plan = self.last_plan = self.plan(obs)
        found, k = plan["found"], plan["decisions"]
        hips = (obs[:, HIPS] * POSITION_SCALE + POSITION_CENTRE)[:, :2]
        # The hips chase a waypoint that reaches the meeting point moving at the hit's hips
        # velocity: once caught, they move at exactly that velocity before the hit as in it.
        decision = PHYSICS_DT * SPD
        lo, hi = HumanLikeBodies.hips_range[:, 0], HumanLikeBodies.hips_range[:, 1]
        waypoint = plan["hips"] - plan["hips_vel"] * k[:, None] * decision
        step = HumanLikeBodies.max_hips_speed * decision
        move = (waypoint + plan["hips_vel"] * decision - hips) / step
        # Where the waypoint two decisions before the hit lies outside the hips' range
        # (meetings at the back edge), go straight to the meeting point and wait there.
        early = plan["hips"] - plan["hips_vel"] * np.maximum(k, 2)[:, None] * decision
        outside = ((early < lo) | (early > hi)).any(axis=1)
        move = np.where(outside[:, None], (plan["hips"] - hips) / step, move)
        # In the swing's decisions the hips move at the hit's velocity whatever their place:
        # the face's size absorbs a few centimetres, the aim would not (and a meeting come
        # early, in the accelerating decision, is still aimed where they have caught up).
        paced = found & ((k == 0) | ((k == 1) & ~outside))
        move = np.where(paced[:, None], plan["hips_vel"] / HumanLikeBodies.max_hips_speed,
                        move)
        angles = np.zeros((n, len(JOINTS)))
        angles[:, J["spine_z"]] = angles[:, J["chest_z"]] = 0.5 * plan["yaw"]
        # with no shuttle coming in (it was hit, or it is out of reach): stand still, arm level
        angles[:, J["upper_arm_x"]] = np.where(found, plan["held"], 0.0)
        move[~found] = 0.0
        angles[:, J["upper_arm_y"]] = FORWARD_SWING
        actions = np.empty((n, 2 + len(JOINTS) + len(GROUPS)))
        actions[:, 0:2] = np.clip(move, -1.0, 1.0)
        actions[:, 2:2 + len(JOINTS)] = 2.0 * (angles - self._lo) / (self._hi - self._lo) - 1.0
        actions[:, 2 + len(JOINTS):] = 1.0  # full strength: every other joint is deadbeat
        # The held pose waits with the strength that will accelerate the arm, so that only the
        # raise's target switches when the swing starts and only the strength when it coasts.
        strength = np.where(found, plan["accelerate"], self._arm_max)
        swinging = found & (k <= 1)
        if swinging.any():
            strength[swinging] = self.steer(obs[swinging], obs[swinging, TARGET][:, 2]
                                            * TARGET_SCALE, plan["coast"][swinging],
                                            k[swinging] == 1)
        actions[:, RAISE_TARGET] = np.where(swinging, 1.0, actions[:, RAISE_TARGET])
        actions[:, ARM_STRENGTH] = 2.0 * strength / self._arm_max - 1.0
        return actions
