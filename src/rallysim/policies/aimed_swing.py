"""A scripted HUMAN-LIKE player that hits with a commanded racket velocity (``AimedSwing``).

The racket's velocity at the impact is the sum of two parts the servo and the hips produce
exactly (see docs/humanlike.md, "Drive"):

- the hips, kinematic, move at 5 a m/s in the horizontal plane for the whole decision;
- a wrist at rest, given a far target and a torque limit, turns with a constant angular
  acceleration (limit - gravity torque) / inertia (the servo pushes a far target with its whole
  limit; the other joints hold, so the wrist's inertia is its own diagonal entry): by e in the
  first physics step of a decision and by 2 e in the second (semi-implicit Euler), so the racket
  face moves by the chord between those angles: the wrist's strength sets the vertical speed.

So the player holds a pose in which the face looks up, walks the hips so that at some decision
start the shuttle sits just above the face's hit volume, and at that decision's start flicks the
wrist up (vertical part of the target) while the hips move at the rest of the target (horizontal
part). The shuttle enters the hit volume in the decision's physics step ``hit_step`` (the first
by default), the one the rulebook measures the racket velocity over.

Why ``hit_step = 2`` exists: a deadbeat servo given a slightly different target reaches it in
one step and stands still in the next. Small errors in the pose targets (a raise 0.003 off moves
the face at 0.2 m/s through a step) so move the arm in the first step only; meeting the shuttle
in the second made the aim about 4x less sensitive to noise on the upper arm's targets and 80x
less to the trunk's. A clone of it was measured no better (docs/humanlike.md, Training): its
errors come from where its hips arrive, not from the pose, so the default stays the first step.

Why the strength and not the wrist's target angle sets the flick: a full-strength wrist reaches
a near target in one step too (the servo is deadbeat), but then the speed is e / dt, about
40 m/s of face speed per unit of action; through the strength it is about 4 m/s per unit, a
precision a learned policy imitating this one can reach.

The pose: upper arm swung 30 deg forward (``upper_arm_y``), raised or lowered (``upper_arm_x``)
to put the face at the planned height, the wrist flexed to level the face; the trunk (spine and
chest together, about the vertical) turned to keep the hips inside their range for shuttles
deep or wide. Everything is read from the observation, so one controller drives any batch.
"""

from __future__ import annotations

import mujoco
import numpy as np

from rallysim.assets import asset_path
from rallysim.core.game import PHYSICS_DT, PHYSICS_STEPS_PER_DECISION
from rallysim.core.humanlike import JOINTS, HumanLikeBodies, humanlike_geometry
from rallysim.core.shuttle import ShuttleState, make_shuttle_model
from rallysim.envs.humanlike_obs import HIPS, SHUTTLE
from rallysim.envs.simple_obs import POSITION_CENTRE, POSITION_SCALE, SHUTTLE_SPEED_SCALE

TARGET = slice(82, 85)  # the task's target racket velocity / 5 m/s
TARGET_SCALE = 5.0
FORWARD_SWING = np.radians(30.0)  # upper_arm_y of every pose
RAISE_RANGE = np.radians(np.arange(-60.0, 60.01, 1.0))  # upper_arm_x grid of the pose table
TRUNK_MAX = np.radians(30.0)  # spine + chest turn, +-15 deg each
HALF_DEPTH = 0.125  # the hit volume's half thickness along the face normal (0.025 + 0.1 m)
FACE_TOP = 0.80  # m above the hips centre: the highest planned face (1.7 m)
HIPS_MARGIN = 0.08  # m kept from the hips' range edges (a clamp would change the velocity)
J = {name: i for i, name in enumerate(JOINTS)}
HAND_TARGET = 2 + J["hand_x"]  # action indices
HAND_STRENGTH = 2 + len(JOINTS) + 4


class PoseTable:
    """The levelled contact poses over the raise angle (trunk straight): for each, the wrist
    angle that turns the face normal most nearly up, the face centre relative to the hips
    centre, the normal, and the wrist's axis and lever (face centre minus wrist anchor)."""

    def __init__(self) -> None:
        m = mujoco.MjModel.from_xml_path(str(asset_path("humanlike_player.xml")))
        d = mujoco.MjData(m)
        site = 0
        hand = m.joint("hand_x").id
        flex = np.radians(np.arange(-90.0, 90.01, 0.25))
        rows = []
        for raise_ in RAISE_RANGE:
            q = np.zeros(m.nq)
            q[J["upper_arm_x"]], q[J["upper_arm_y"]] = raise_, FORWARD_SWING
            best = (-2.0, 0.0)
            for psi in flex:
                q[J["hand_x"]] = psi
                d.qpos[:] = q
                mujoco.mj_kinematics(m, d)
                nz = d.site_xmat[site].reshape(3, 3)[2, 1]
                if nz > best[0]:
                    best = (nz, psi)
            q[J["hand_x"]] = best[1]
            d.qpos[:] = q
            d.qvel[:] = 0.0
            mujoco.mj_forward(m, d)
            hips = d.mocap_pos[0]
            face = d.site_xpos[site] - hips
            normal = d.site_xmat[site].reshape(3, 3)[:, 1]
            axis = d.xaxis[hand]
            lever = d.site_xpos[site] - d.xanchor[hand]
            full = np.zeros((m.nv, m.nv))
            mujoco.mj_fullM(m, d, full)
            dof = m.jnt_dofadr[hand]
            rows.append(np.concatenate([[best[1]], face, normal, axis, lever,
                                        [full[dof, dof], d.qfrc_bias[dof]]]))
        t = np.array(rows)
        self.raise_ = RAISE_RANGE
        self.wrist, self.face, self.normal = t[:, 0], t[:, 1:4], t[:, 4:7]
        self.axis, self.lever = t[:, 7:10], t[:, 10:13]
        self.inertia, self.gravity = t[:, 13], t[:, 14]  # the wrist's, at rest in the pose

    def raise_for_height(self, z: np.ndarray) -> np.ndarray:
        """Raise angles putting the face centre ``z`` m above the hips (clipped to the table)."""
        return np.interp(z, self.face[:, 2], self.raise_)

    def at(self, raise_: np.ndarray) -> dict[str, np.ndarray]:
        """The table's rows interpolated at raise angles (n,)."""
        def col(a: np.ndarray) -> np.ndarray:
            return np.stack([np.interp(raise_, self.raise_, a[:, i]) for i in range(3)], axis=1)

        def one(a: np.ndarray) -> np.ndarray:
            return np.interp(raise_, self.raise_, a)

        return {"wrist": one(self.wrist), "face": col(self.face), "normal": col(self.normal),
                "axis": col(self.axis), "lever": col(self.lever),
                "inertia": one(self.inertia), "gravity": one(self.gravity)}


def _turn(v: np.ndarray, yaw: np.ndarray) -> np.ndarray:
    """Vectors (n, 3) turned by ``yaw`` (n,) about the vertical."""
    c, s = np.cos(yaw), np.sin(yaw)
    return np.stack([c * v[:, 0] - s * v[:, 1], s * v[:, 0] + c * v[:, 1], v[:, 2]], axis=1)


def chord_terms(axis: np.ndarray, lever: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Rodrigues' form of a point at ``lever`` turned by e about ``axis``: its displacement is
    across * sin(e) + inward * (1 - cos(e)); returns (across, inward), each (n, 3)."""
    across = np.cross(axis, lever)
    inward = axis * np.einsum("ij,ij->i", axis, lever)[:, None] - lever
    return across, inward


def wrist_flick(terms: tuple[np.ndarray, np.ndarray], rise: np.ndarray, before: float = 0.0,
                after: float = 1.0) -> np.ndarray:
    """Wrist angles e (n,) such that turning from ``before`` e to ``after`` e moves the face
    centre up by ``rise`` m (``terms``: ``chord_terms`` of the wrist's axis and the face's
    lever), solved by Newton's method."""
    a, b = terms[0][:, 2], terms[1][:, 2]
    e = rise / np.where(np.abs(a) > 1e-6, a, 1e-6) / (after - before)
    for _ in range(8):
        f = a * (np.sin(after * e) - np.sin(before * e)) \
            + b * (np.cos(before * e) - np.cos(after * e)) - rise
        df = a * (after * np.cos(after * e) - before * np.cos(before * e)) \
            + b * (after * np.sin(after * e) - before * np.sin(before * e))
        e = e - f / df
    return e


def chord(terms: tuple[np.ndarray, np.ndarray], e: np.ndarray) -> np.ndarray:
    """The face centre's displacement (n, 3) when the wrist turns by ``e``."""
    across, inward = terms
    return across * np.sin(e)[:, None] + inward * (1.0 - np.cos(e))[:, None]


class AimedSwing:
    """``controller(observations (N, 85)) -> actions (N, 15)`` for ``HumanLikeReturn-v0``:
    hits the shuttle with the racket moving at the observed target velocity. See the module
    docstring for how."""

    horizon_steps = 200  # physics steps of shuttle prediction (4 s)
    hit_step = 1  # the decision's physics step (1-based) the shuttle is met in (see above)

    def __init__(self, shuttle: str = "paper") -> None:
        self.flight = make_shuttle_model(shuttle, PHYSICS_DT)
        self.table = PoseTable()
        geo = humanlike_geometry()
        self._lo, self._hi = geo["joint_lo"], geo["joint_hi"]
        self._yaw = np.linspace(-TRUNK_MAX, TRUNK_MAX, 61)
        self._hand_max = float(geo["group_max_torque"][-1])

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

    def plan(self, obs: np.ndarray) -> dict[str, np.ndarray]:
        """The meeting each observation leads to: in how many decisions (0: this one), the
        pose (raise, wrist, trunk yaw), where the hips must be then and how they move in it,
        and the wrist's flick."""
        n = len(obs)
        pos = obs[:, SHUTTLE][:, :3] * POSITION_SCALE + POSITION_CENTRE
        vel = obs[:, SHUTTLE][:, 3:] * SHUTTLE_SPEED_SCALE
        goal = obs[:, TARGET] * TARGET_SCALE
        p, v = self.predict(pos, vel)
        spd = PHYSICS_STEPS_PER_DECISION
        starts = np.arange(0, self.horizon_steps, spd)  # physics steps of decision starts
        j = self.hit_step
        # The wrist accelerates evenly from rest: its angle after step i is i (i + 1) / 2 times
        # step 1's turn e_1, so step j turns it from `before` to `after` e_1.
        before, after = j * (j - 1) / 2, j * (j + 1) / 2
        mid = 0.5 * (p[:, starts + j - 1] + p[:, starts + j])  # the shuttle half into step j
        # The face centre wanted at each decision start: the shuttle on the hit volume's top
        # half into step j, the face having risen by then (in small-angle chords: step j rises
        # the target's vertical travel, so half into it the face has risen (before + after) / 2
        # over (after - before) of that travel, j / 2).
        risen = 0.5 * (before + after) / (after - before)
        face_z = mid[..., 2] - HALF_DEPTH - risen * PHYSICS_DT * goal[:, None, 2]
        falling = v[:, starts, 2] < 0.0
        z_need = face_z - HumanLikeBodies.hips_height
        ok = falling & (z_need <= FACE_TOP)
        found = ok.any(axis=1)
        k = np.where(found, ok.argmax(axis=1), 0)
        rows = np.arange(n)
        z_rel = z_need[rows, k]
        raise_ = self.table.raise_for_height(z_rel)
        pose = self.table.at(raise_)
        # one correction for the normal's tilt in the volume's depth
        z_rel = z_rel + HALF_DEPTH * (1.0 - pose["normal"][:, 2])
        raise_ = self.table.raise_for_height(z_rel)
        pose = self.table.at(raise_)
        # the trunk's turn: as far forward as the hips' back edge allows
        face_mid = mid[rows, k]
        hips_lo, hips_hi = HumanLikeBodies.hips_range[:, 0], HumanLikeBodies.hips_range[:, 1]
        reach_x = np.cos(self._yaw)[None] * pose["face"][:, :1] \
            - np.sin(self._yaw)[None] * pose["face"][:, 1:2]  # (n, yaws), increasing
        room = face_mid[:, :1] - (hips_lo[0] + HIPS_MARGIN)
        yaw = np.array([np.interp(r, x, self._yaw) for r, x in zip(room[:, 0], reach_x,
                                                                   strict=True)])
        face = _turn(pose["face"], yaw)
        terms = chord_terms(_turn(pose["axis"], yaw), _turn(pose["lever"], yaw))
        flick = wrist_flick(terms, goal[:, 2] * PHYSICS_DT, before, after)
        start = chord(terms, before * flick)  # the face's travel before step j
        move = chord(terms, after * flick) - start  # ... and in it
        hips_vel = goal[:, :2] - move[:, :2] / PHYSICS_DT
        # hips at the decision start: the face's horizontal position half into step j is mid
        hips = face_mid[:, :2] - (j - 0.5) * PHYSICS_DT * hips_vel \
            - (start[:, :2] + 0.5 * move[:, :2]) - face[:, :2]
        hips = np.clip(hips, hips_lo + HIPS_MARGIN, hips_hi - HIPS_MARGIN)
        # the wrist torque turning it by the flick in one step from rest: M e / dt^2 + bias
        torque = pose["inertia"] * flick / PHYSICS_DT ** 2 + pose["gravity"]
        return {"found": found, "decisions": k, "raise": raise_, "wrist": pose["wrist"],
                "yaw": yaw, "flick": flick, "torque": torque, "hips": hips,
                "hips_vel": hips_vel}

    def imitation_weights(self) -> np.ndarray:
        """Per-environment weights of the last call's actions for a clone's loss: 10 in the
        decision of the hit and the one before (the ones that decide it), 1 elsewhere."""
        plan = self.last_plan
        return 1.0 + 9.0 * (plan["found"] & (plan["decisions"] <= 1))

    def __call__(self, observations: np.ndarray) -> np.ndarray:
        obs = np.asarray(observations, dtype=np.float64)
        n = len(obs)
        plan = self.last_plan = self.plan(obs)
        hips = (obs[:, HIPS] * POSITION_SCALE + POSITION_CENTRE)[:, :2]
        now = plan["found"] & (plan["decisions"] == 0)
        # The hips chase a waypoint that reaches the meeting point moving at the hit's hips
        # velocity: once caught, they move at exactly that velocity, in the decisions before
        # the hit as in the hit's own, so nothing has to switch at the hit.
        decision = PHYSICS_DT * PHYSICS_STEPS_PER_DECISION
        lead = plan["decisions"][:, None] * decision
        lo, hi = HumanLikeBodies.hips_range[:, 0], HumanLikeBodies.hips_range[:, 1]
        waypoint = plan["hips"] - plan["hips_vel"] * lead
        step = HumanLikeBodies.max_hips_speed * decision
        move = (waypoint + plan["hips_vel"] * decision - hips) / step
        # Where that waypoint lies outside the hips' range (meetings at the back edge), go
        # straight to the meeting point and move at the hit's velocity in the hit's decision.
        outside = ((waypoint < lo) | (waypoint > hi)).any(axis=1)
        direct = np.where(now[:, None], plan["hips_vel"] * decision, plan["hips"] - hips) / step
        move = np.where(outside[:, None], direct, move)
        angles = np.zeros((n, len(JOINTS)))
        angles[:, J["spine_z"]] = angles[:, J["chest_z"]] = 0.5 * plan["yaw"]
        angles[:, J["upper_arm_x"]] = plan["raise"]
        angles[:, J["upper_arm_y"]] = FORWARD_SWING
        angles[:, J["hand_x"]] = plan["wrist"]
        actions = np.empty((n, 2 + len(JOINTS) + 5))
        actions[:, 0:2] = np.clip(move, -1.0, 1.0)
        actions[:, 2:2 + len(JOINTS)] = 2.0 * (angles - self._lo) / (self._hi - self._lo) - 1.0
        actions[:, 2 + len(JOINTS):] = 1.0  # full strength: every joint is deadbeat
        # The flick: the wrist's target jumps to its far end; its strength is the torque the
        # flick needs, held from the start (it also holds the level pose against gravity), so
        # only the target has to switch at the hit, and any target 0.2 rad or more away works.
        flick_to = np.sign(plan["torque"])
        actions[:, HAND_TARGET] = np.where(now, flick_to, actions[:, HAND_TARGET])
        actions[:, HAND_STRENGTH] = 2.0 * np.abs(plan["torque"]) / self._hand_max - 1.0
        return actions
