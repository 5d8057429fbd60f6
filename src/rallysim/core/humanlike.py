"""HUMAN-LIKE players (docs/reference.md §10): N x P humanoid upper bodies with rackets in ONE
MuJoCo model.

``HumanLikeBodies`` implements the rulebook's ``PlayerBodies`` protocol, so ``Game`` serves,
flies, judges hits and landings for these players exactly as for the SIMPLE ones (the compiled
steps: ``rallysim.core.kernels``).

Model (``assets/humanlike_player.xml``): kinematic hips at 0.9 m moved in the horizontal plane,
and 8 hinges: spine z, chest z, right upper arm x/y/z, lower arm x, hand x/y. The racket face is
a box (0.20 x 0.05 x 0.23 m: across, thickness, along the handle) on the site ``face``.

Drive: a torque-limited position servo per hinge, solved implicitly. Each physics step the
servo picks a desired joint velocity (toward the target, no faster than the group's rate cap or
than the joint can still stop from at half its strength), then the torques tau, each within
+-(its strength), that bring the velocities closest to the desired ones by the end of the step
under the arm's true coupled dynamics (M a + bias = tau, M the joint-space inertia of this
state). Unsaturated joints get exactly their desired velocity (a deadbeat servo); saturated ones
push with their full strength. Strength zero gives exactly zero torque. A plain per-joint PD
cannot do this at the 0.02 s step: the spine and chest turn about the same axis, and the upper
arm's twist drives a tiny inertia, so a clamped stiff PD chatters and a decoupled one diverges.

One MuJoCo step advances the whole batch; joint limits are hard stops applied after it
(constraints are off, like the SIMPLE arm's). The step of every player, for any N x P, is one
compiled loop (``rallysim.core.humanlike_step``). Own frames (docs/reference.md §1): every player
stands at x < 0 facing +x; player 1's copies are attached turned 180 degrees about z, so one joint
angle means one pose for either player.
"""

from __future__ import annotations

from typing import Any

import mujoco
import numpy as np

from rallysim.assets import asset_path
from rallysim.core import humanlike_step
from rallysim.core.bodies import MjDataViews, build_world
from rallysim.core.rules import FORWARD

XML = "humanlike_player.xml"
# Hinges in the model's order, which is also the action's order of target rotations
# (docs/reference.md §10).
JOINTS = ("spine_z", "chest_z", "upper_arm_x", "upper_arm_y", "upper_arm_z", "lower_arm_x",
          "hand_x", "hand_y")
GROUPS = ("spine", "chest", "upper_arm", "lower_arm", "hand")  # strength groups = observed bodies
N_BODIES = len(GROUPS)
JOINT_GROUP = np.array([0, 1, 2, 2, 2, 3, 4, 4])
N_JOINTS, N_GROUPS = len(JOINTS), len(GROUPS)
# Action layout: movement x, y; one target per joint; one strength per group.
MOVE, TARGET, STRENGTH = slice(0, 2), slice(2, 2 + N_JOINTS), slice(2 + N_JOINTS, None)
N_ACTIONS = 2 + N_JOINTS + N_GROUPS

# Fastest rotation the servo commands, per group (rad/s): trunk rotation in strokes peaks near
# 10 rad/s; shoulder, elbow and wrist reach 20-40 rad/s in smashes.
GROUP_MAX_RATE = np.array([10.0, 10.0, 30.0, 30.0, 30.0])
MAX_JOINT_SPEED = 50.0  # rad/s, a hard ceiling (reached only by a limp arm falling and spinning)
BRAKE_SHARE = 0.5  # share of the strength the servo plans to stop with (the rest: gravity)
ACTIVE_SET_ROUNDS = 8  # rounds of the exact solve (it converges in 2-6); torques are clipped after


class HumanLikeBodies(MjDataViews):
    """N x P HUMAN-LIKE players (docs/reference.md §10) for ``Game``; see the module docstring.

    Actions (N, P, 15) in [-1, 1]: hips velocity x, y = ``max_hips_speed`` * a (own frame);
    target angles spanning each joint's range; strength = (a + 1) / 2 of each group's maximum
    torque (``group_max_torque``, read from the MJCF's motor ranges)."""

    hips_height = 0.9
    max_hips_speed = 5.0  # m/s, a badminton player's lunge; the SIMPLE base's speed
    hips_range = np.array([[-6.5, -0.5], [-2.8, 2.8]])  # own-frame x and y of the hips centre

    def __init__(self, n_envs: int, n_players: int = 1, dt: float = 0.02) -> None:
        if n_envs < 1 or n_players not in (1, 2):
            raise ValueError(f"need n_envs >= 1 and n_players in (1, 2), got {n_envs}, {n_players}")
        self.n_envs, self.n_players, self.dt = n_envs, n_players, dt
        self.model = build_humanlike_world(n_envs, n_players, dt)
        self.data = mujoco.MjData(self.model)
        m, shape = self.model, (n_envs, n_players)
        _check_layout(m, n_envs * n_players)
        self.hips = np.zeros((*shape, 2))  # own-frame x, y
        self.hips[..., 0] = -2.7
        self._bind_views()
        self._m_index = _inertia_index(m, n_envs, n_players)

        geo = humanlike_geometry()
        self.lo, self.hi = geo["joint_lo"], geo["joint_hi"]
        self.face_half = geo["face_half"]
        self.group_max_torque = geo["group_max_torque"]
        self._joint_max_torque = self.group_max_torque[JOINT_GROUP]
        self._joint_max_rate = GROUP_MAX_RATE[JOINT_GROUP]
        self._body_ids = _body_ids(m, n_envs, n_players, GROUPS)
        self._hips_ids = _body_ids(m, n_envs, n_players, ("hips",))[..., 0]

        self.forward = np.broadcast_to(FORWARD[:n_players], shape).copy()
        # own-frame factors of x, y, z: x and y change sign in player 1's frame
        self.flip = np.stack([self.forward, self.forward, np.ones(shape)], axis=-1)
        self.base_moved = np.zeros(shape, dtype=bool)
        self.hips_velocity = np.zeros((*shape, 2))  # own frame, over the last physics step
        self.target = np.zeros((*shape, N_JOINTS))
        self.torque_limit = np.zeros((*shape, N_JOINTS))
        self._hips_step = np.zeros((*shape, 2))
        self._face0 = np.zeros((*shape, 3))  # world face centre at the last step's start
        self._side = np.zeros((*shape, N_JOINTS), dtype=np.int8)  # servos saturated at +-limit
        hips_lo, hips_hi = self.hips_range[:, 0], self.hips_range[:, 1]
        self._constants = humanlike_step.body_constants(
            lo=self.lo, hi=self.hi, max_rate=self._joint_max_rate, dt=dt,
            brake=2.0 * BRAKE_SHARE, max_speed=MAX_JOINT_SPEED, hips_lo=hips_lo,
            hips_hi=hips_hi, hips_height=self.hips_height, rounds=ACTIVE_SET_ROUNDS)
        self._dirty = True  # kinematics must be recomputed before they are read
        self._sync_mocap()
        self._sync()

    _views = ("qpos", "qvel", "torque", "_bias", "_mass", "_mocap", "_face_pos", "_face_mat",
              "base_x")

    def _bind_views(self) -> None:
        """Views into MuJoCo's memory (players are env-major and contiguous in every array),
        and the rulebook's base position as a view of the hips."""
        d, shape = self.data, (self.n_envs, self.n_players)
        self.qpos = d.qpos.reshape((*shape, N_JOINTS))
        self.qvel = d.qvel.reshape((*shape, N_JOINTS))
        self.torque = d.ctrl.reshape((*shape, N_JOINTS))
        self._bias = d.qfrc_bias.reshape((*shape, N_JOINTS))
        self._mass = d.M  # the sparse joint-space inertia
        self._mocap = d.mocap_pos.reshape((*shape, 3))
        self._face_pos = d.site_xpos.reshape((*shape, 3))  # world frame
        self._face_mat = d.site_xmat.reshape((*shape, 3, 3))
        self.base_x = self.hips[..., 0]

    # -- state ---------------------------------------------------------------------------------
    def reset(self, envs: np.ndarray, base_x: np.ndarray, pose: Any = 0.0,
              base_y: np.ndarray | float = 0.0) -> None:
        """Place the players of ``envs`` with hips at own-frame (``base_x``, ``base_y``), each
        (len(envs), P), joints at ``pose``: 0.0 for the zero pose (a T-pose), or angles
        (len(envs), P, 8) in radians, clipped into the joint ranges. Bodies come to rest."""
        envs = np.asarray(envs, dtype=np.int64)
        self.hips[envs, :, 0] = np.clip(base_x, *self.hips_range[0])
        self.hips[envs, :, 1] = np.clip(base_y, *self.hips_range[1])
        pose = np.clip(np.broadcast_to(pose, (len(envs), self.n_players, N_JOINTS)),
                       self.lo, self.hi)
        self.qpos[envs] = pose
        self.qvel[envs] = 0.0
        self.torque[envs] = 0.0
        self.target[envs] = pose
        self.torque_limit[envs] = 0.0
        self._side[envs] = 0
        self._hips_step[envs] = 0.0
        self.hips_velocity[envs] = 0.0
        self.base_moved[envs] = False
        self._sync_mocap()
        self._dirty = True

    def set_actions(self, actions: np.ndarray) -> None:
        """Hold ``actions`` (N, P, 15), already clipped to [-1, 1], for the next physics steps."""
        np.multiply(actions[..., MOVE], self.max_hips_speed * self.dt, out=self._hips_step)
        frac = 0.5 * (actions[..., TARGET] + 1.0)
        np.add(self.lo, frac * (self.hi - self.lo), out=self.target)
        strength = 0.5 * (actions[..., STRENGTH] + 1.0)
        np.multiply(strength[..., JOINT_GROUP], self._joint_max_torque, out=self.torque_limit)

    def physics_step(self) -> None:
        """One 0.02 s step: servo torques, MuJoCo's integration, joint stops, hips motion.

        MuJoCo's step is split (``mj_step2`` then ``mj_step1``, the same work as one
        ``mj_step``) so that afterwards the kinematics, inertia and bias forces describe the new
        state: the rulebook reads the face there, and the next servo solve needs them."""
        self._sync()
        humanlike_step.compiled_step()(
            self.model._address, self.data._address, self._mass, self._m_index, self.qpos,
            self.qvel, self.torque, self._bias, self.target, self.torque_limit, self._side,
            self._face0, self._face_pos, self.hips, self._hips_step, self.hips_velocity,
            self.base_moved, self._mocap, self.forward, self._constants)

    def _sync_mocap(self) -> None:
        np.multiply(self.hips, self.forward[..., None], out=self._mocap[..., :2])
        self._mocap[..., 2] = self.hips_height

    def _sync(self) -> None:
        """Recompute kinematics, inertia and bias forces after the state was set by hand."""
        if self._dirty:
            mujoco.mj_step1(self.model, self.data)
            self._dirty = False

    def snapshot(self, envs: np.ndarray) -> tuple:
        return tuple(a[envs].copy() for a in self._state_arrays())

    def restore(self, envs: np.ndarray, saved: tuple) -> None:
        for a, s in zip(self._state_arrays(), saved, strict=True):
            a[envs] = s
        self._sync_mocap()
        self._dirty = True

    def _state_arrays(self) -> tuple[np.ndarray, ...]:
        return (self.qpos, self.qvel, self.torque, self.hips, self.hips_velocity, self.target,
                self.torque_limit, self._side)

    # -- kinematics (own frame) ----------------------------------------------------------------
    def hips_position(self) -> np.ndarray:
        """(N, P, 3) own-frame hips centre."""
        out = np.empty((self.n_envs, self.n_players, 3))
        out[..., :2] = self.hips
        out[..., 2] = self.hips_height
        return out

    def face_centre(self) -> np.ndarray:
        """(N, P, 3) own-frame centre of each racket face."""
        self._sync()
        return self._face_pos * self.flip

    def body_states(self) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
        """Own-frame states of the 5 driven bodies (spine, chest, upper arm, lower arm, hand):
        velocity of the body's origin (its joint), angular velocity, origin relative to the
        hips, orientation quaternion (w, x, y, z) with w >= 0; shapes (N, P, 5, 3 or 4)."""
        rows = self._body_rows()
        return rows[..., 0:3], rows[..., 3:6], rows[..., 6:9], rows[..., 9:13]

    def body_effort(self) -> np.ndarray:
        """(N, P, 5) magnitude of each body's joint torques in the last physics step, as a
        fraction of its group's maximum: |tau| / (max torque * sqrt(joints)), in [0, 1]."""
        return self._body_rows()[..., 13]

    def _body_rows(self) -> np.ndarray:
        """(N, P, 5, 14): ``body_states`` and ``body_effort`` in a row per body, computed by
        ``humanlike_step`` (the observation's own code)."""
        self._sync()
        d = self.data
        rows = np.empty((self.n_envs, self.n_players, N_BODIES, 14))
        humanlike_step.compiled_observations()[0](
            d.xpos, d.xquat, d.cvel, d.subtree_com, self._body_ids, self._hips_ids,
            self.hips_velocity, self.hips, self.torque, self._joint_max_torque, self.forward,
            self.hips_height, rows)
        return rows


def build_humanlike_world(n_envs: int, n_players: int, dt: float = 0.02) -> mujoco.MjModel:
    """One MjModel with ``n_envs * n_players`` HUMAN-LIKE players, ordered env-major
    (``bodies.build_world``); plain Euler integration is exact for the servo, which plans each
    step's velocity change with Euler's own update."""
    return build_world(XML, n_envs, n_players, dt)


def _check_layout(m: mujoco.MjModel, n: int) -> None:
    """The (N, P, ...) views assume each player's hinges, motors, face site and mocap body are
    contiguous and in the player file's order."""
    ok = (m.nq == m.nv == m.nu == n * N_JOINTS and m.nsite == n and m.nmocap == n
          and np.array_equal(m.actuator_trnid[:, 0], np.arange(m.nu))
          and np.array_equal(m.jnt_qposadr, np.arange(m.nq)))
    if not ok:
        raise RuntimeError(f"unexpected layout of {XML}: one site, one mocap body and one "
                           "motor per hinge, in joint order, are required")


def _inertia_index(m: mujoco.MjModel, n_envs: int, n_players: int) -> np.ndarray:
    """(N, P, 8, 8) indices into MuJoCo's sparse inertia ``data.M`` (lower-triangular rows)
    that gather each player's dense block. Players are separate trees, so every stored entry
    belongs to one player's block."""
    rows = np.repeat(np.arange(m.nv), m.M_rownnz)
    player, i = np.divmod(rows, N_JOINTS)
    j = m.M_colind - player * N_JOINTS
    if np.any((j < 0) | (j >= N_JOINTS)):
        raise RuntimeError("players' inertia blocks overlap")
    block = np.zeros((n_envs * n_players, N_JOINTS, N_JOINTS), dtype=np.int64)
    block[player, i, j] = np.arange(m.nM)
    block[player, j, i] = np.arange(m.nM)
    return block.reshape(n_envs, n_players, N_JOINTS, N_JOINTS)


def _body_ids(m: mujoco.MjModel, n_envs: int, n_players: int,
              names: tuple[str, ...]) -> np.ndarray:
    """(N, P, len(names)) ids of the named bodies of every player."""
    return np.array([[[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, f"e{e}p{p}_{b}")
                       for b in names] for p in range(n_players)] for e in range(n_envs)])


_GEOMETRY: dict | None = None


def humanlike_geometry() -> dict:
    """Dimensions, limits and masses read from the player MJCF (the single source of each)."""
    global _GEOMETRY
    if _GEOMETRY is None:
        m = mujoco.MjModel.from_xml_path(str(asset_path(XML)))
        joint = [mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, j) for j in JOINTS]
        site = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_SITE, "face")
        first_of_group = [int(np.flatnonzero(g == JOINT_GROUP)[0]) for g in range(N_GROUPS)]
        _GEOMETRY = {
            "joint_lo": m.jnt_range[joint, 0].copy(),
            "joint_hi": m.jnt_range[joint, 1].copy(),
            "face_half": m.site_size[site].copy(),  # across, normal, along the handle
            "face_offset": m.site_pos[site].copy(),  # in the hand's frame
            "group_max_torque": m.actuator_ctrlrange[first_of_group, 1].copy(),
            "body_mass": {m.body(b).name: float(m.body_mass[b]) for b in range(1, m.nbody)},
        }
    return _GEOMETRY
