"""MuJoCo-backed player batches. One compiled MjModel holds every player of every environment,
so one ``mj_step`` advances the whole batch and the rulebook reads joint state as arrays.

Players work in their own frame (docs/reference.md §1): each stands at x < 0 and faces +x. Player
1's copies are attached rotated 180 degrees about z, so the same joint angle means the same swing
for both.
"""

from __future__ import annotations

from typing import Any, Protocol

import mujoco
import numpy as np

from rallysim.assets import asset_path
from rallysim.core import native
from rallysim.core.rules import FORWARD

SIMPLE_ACTIONS = ("target_orientation", "force", "movement")


class PlayerBodies(Protocol):
    """What the rulebook (``Game``) needs of a batch of N x P players, in their own frames.

    Arrays are (N, P, ...); "own frame" is the player's (docs/reference.md §1). Implemented by
    ``SimpleBodies`` and ``HumanLikeBodies``, whose motion, face frame and shot the compiled
    steps know (``rallysim.core.kernels``)."""

    n_envs: int
    n_players: int
    forward: np.ndarray  # (N, P): +1 for player 0, -1 for player 1 (own x = forward * world x)
    base_x: np.ndarray  # (N, P) own-frame x of the base (for the approach shaping)
    base_moved: np.ndarray  # (N, P) bool: the base moved in the last physics step
    face_half: np.ndarray  # (3,) half sizes of the racket face box in its own frame

    def reset(self, envs: np.ndarray, base_x: np.ndarray, pose: Any = 0.0) -> None: ...
    def set_actions(self, actions: np.ndarray) -> None: ...
    def snapshot(self, envs: np.ndarray) -> Any: ...
    def restore(self, envs: np.ndarray, saved: Any) -> None: ...


class MjDataViews:
    """A batch of bodies that keeps NumPy views into its ``MjData`` for speed.

    A copy (``copy.deepcopy``, ``pickle``) copies ``data`` but would turn each view into a
    detached array, so writes would no longer move the bodies. The views named in ``_views`` are
    left out of the copied state and bound again to the copy's own ``data`` by ``_bind_views``.
    """

    _views: tuple[str, ...] = ()

    def _bind_views(self) -> None:
        raise NotImplementedError

    def __getstate__(self) -> dict[str, Any]:
        return {k: v for k, v in self.__dict__.items() if k not in self._views}

    def __setstate__(self, state: dict[str, Any]) -> None:
        self.__dict__.update(state)
        self._bind_views()


class SimpleBodies(MjDataViews):
    """N x P SIMPLE players (docs/reference.md §5) in one MuJoCo model.

    Per physics step the arm's drive is a stiff position servo solved implicitly (it would reach
    its target within the step), limited to the 7 rad/s rate cap and then to the torque allowed
    by the force action; MuJoCo integrates the arm under that torque. The base is kinematic and
    slides along x at 5 * a2 m/s within its range.
    """

    max_target_angle = np.radians(85.0)
    max_torque = 15.0  # N m at force action +1
    max_rate = 7.0  # rad/s, Unity's default angular-speed cap
    max_base_speed = 5.0  # m/s at movement action +-1
    shot_factor = 2.0  # a hit sends the shuttle off at twice the face's velocity
    base_range = (-6.5, -1.0)  # own-frame x of the base centre

    def __init__(self, n_envs: int, n_players: int = 1, dt: float = 0.02) -> None:
        if n_envs < 1 or n_players not in (1, 2):
            raise ValueError(f"need n_envs >= 1 and n_players in (1, 2), got {n_envs}, {n_players}")
        self.n_envs, self.n_players, self.dt = n_envs, n_players, dt
        self.model = build_simple_world(n_envs, n_players, dt)
        self.data = mujoco.MjData(self.model)
        self._bind_views()
        shape = (n_envs, n_players)
        self.forward = np.broadcast_to(FORWARD[:n_players], shape).copy()

        geo = player_geometry()
        self.pivot_z = geo["pivot_z"]
        self.face_offset = geo["face_offset"]  # pivot -> face centre, along the arm
        self.face_half = geo["face_half"]  # (thickness, across, along) half sizes
        self.inertia = geo["inertia"]  # arm + face about the pivot
        self.limit = geo["limit"]
        self.base_z = geo["base_z"]

        self.base_x = np.full(shape, -2.7)  # own frame
        self.target = np.zeros(shape)
        self.torque_limit = np.zeros(shape)
        self.base_moved = np.zeros(shape, dtype=bool)
        self._neg_limit = np.zeros(shape)
        self._base_step = np.zeros(shape)  # metres per physics step
        self._theta0 = np.zeros(shape)  # arm angles at the start of the last physics step
        # ``set_actions``' constants in each type actions may come in (made once: a call
        # costs less without making them)
        self._act_numbers = {np.dtype(kind): (kind(1.0), kind(0.5 * self.max_torque),
                                              kind(self.max_base_speed * dt))
                             for kind in (np.float32, np.float64)}
        self._sync_mocap()
        mujoco.mj_forward(self.model, self.data)

    _views = ("theta", "omega", "torque", "mocap")

    def _bind_views(self) -> None:
        """Views into MuJoCo's memory: writing them moves the bodies."""
        shape = (self.n_envs, self.n_players)
        self.theta = self.data.qpos.reshape(shape)
        self.omega = self.data.qvel.reshape(shape)
        self.torque = self.data.ctrl.reshape(shape)
        self.mocap = self.data.mocap_pos.reshape((*shape, 3))

    # -- state ---------------------------------------------------------------------------------
    def reset(self, envs: np.ndarray, base_x: np.ndarray, theta: np.ndarray | float = 0.0) -> None:
        """Place the players of ``envs`` at own-frame ``base_x`` (len(envs), P), arms at ``theta``.
        """
        # (filled, not np.broadcast_to: several times cheaper for these few values)
        x, angle = np.empty((2, len(envs), self.n_players))
        x[...], angle[...] = base_x, theta
        lo, hi = self.base_range
        _PLACE.get()(np.asarray(envs, np.int64), x, angle, float(lo), float(hi), self.base_x,
                     self.theta, self.omega, self.torque, self.target, self.torque_limit,
                     self._neg_limit, self._base_step, self.base_moved, self.mocap,
                     self.forward)

    def set_actions(self, actions: np.ndarray) -> None:
        """Hold ``actions`` (N, P, 3), already clipped to [-1, 1], for the next physics steps."""
        if actions.shape[-1] != 3:
            raise ValueError(f"SIMPLE players take 3 actions each, got {actions.shape[-1]}")
        # float32 actions (a policy's) keep NumPy's float32 arithmetic, as the arrays'
        # expressions had it: the constants in that type (the angle stays a float64: the
        # target is one); other types are taken as float64
        numbers = self._act_numbers.get(actions.dtype)
        if numbers is None:
            actions = actions.astype(np.float64)
            numbers = self._act_numbers[actions.dtype]
        _ACT.get()(actions, self.target, self.torque_limit, self._neg_limit, self._base_step,
                   self.max_target_angle, *numbers)

    def _sync_mocap(self) -> None:
        self.mocap[..., 0] = self.forward * self.base_x

    def snapshot(self, envs: np.ndarray) -> tuple:
        return self.theta[envs].copy(), self.omega[envs].copy(), self.base_x[envs].copy()

    def restore(self, envs: np.ndarray, saved: tuple) -> None:
        self.theta[envs], self.omega[envs], self.base_x[envs] = saved
        self._sync_mocap()

    # -- kinematics (own frame) ----------------------------------------------------------------
    def face_centre(self) -> np.ndarray:
        """(N, P, 3) own-frame centre of each racket face."""
        s, c = np.sin(self.theta), np.cos(self.theta)
        out = np.empty((*self.theta.shape, 3))
        out[..., 0] = self.base_x + self.face_offset * s
        out[..., 1] = 0.0
        out[..., 2] = self.pivot_z + self.face_offset * c
        return out


def _act(actions, target, torque_limit, neg_limit, base_step, angle, one, half_torque, step):
    """SIMPLE players' actions (N, P, 3) as their drive's target angle, its torque limits and
    the base's movement per physics step (compiled: ``_ACT``), computed in the actions' type,
    float32 or float64 (``one``, ``half_torque`` and ``step`` are of it)."""
    for e in range(actions.shape[0]):
        for j in range(actions.shape[1]):
            target[e, j] = actions[e, j, 0] * angle
            torque = (actions[e, j, 1] + one) * half_torque
            torque_limit[e, j] = torque
            neg_limit[e, j] = -torque
            base_step[e, j] = actions[e, j, 2] * step


_ACT = native.Kernel(lambda: native.jit(_act))


def _place(envs, x, theta, lo, hi, base_x, q, qd, torque, target, torque_limit, neg_limit,
           base_step, moved, mocap, forward):
    """SIMPLE players of games ``envs`` placed at own-frame ``x`` clipped into [lo, hi] (as
    ``np.clip`` clips), arms at rest at ``theta``, no drive, no movement (compiled:
    ``_PLACE``)."""
    for i in range(envs.shape[0]):
        if not 0 <= envs[i] < base_x.shape[0]:  # (before anything is written)
            raise IndexError("a game index is out of range")
    for i in range(envs.shape[0]):
        e = envs[i]
        for j in range(base_x.shape[1]):
            v = x[i, j]
            v = v if v > lo or v != v else lo  # np.maximum(v, lo)
            v = v if v < hi or v != v else hi  # np.minimum(v, hi)
            base_x[e, j] = v
            q[e, j] = target[e, j] = theta[i, j]
            qd[e, j] = torque[e, j] = torque_limit[e, j] = neg_limit[e, j] = 0.0
            base_step[e, j] = 0.0
            moved[e, j] = False
            mocap[e, j, 0] = forward[e, j] * v


_PLACE = native.Kernel(lambda: native.jit(_place))


def build_simple_world(n_envs: int, n_players: int, dt: float = 0.02) -> mujoco.MjModel:
    """One MjModel with ``n_envs * n_players`` SIMPLE players, ordered env-major
    (``build_world``); the arms are gravity-compensated (docs/reference.md §5)."""
    return build_world("simple_player.xml", n_envs, n_players, dt)


def build_world(xml: str, n_envs: int, n_players: int, dt: float) -> mujoco.MjModel:
    """One MjModel with ``n_envs * n_players`` copies of the player file ``xml``, env-major,
    player 1's copies turned 180 degrees about z; Euler steps of ``dt``.

    Nothing in it collides and the bodies apply their joints' hard stops themselves, so
    contact and constraint handling are switched off."""
    spec = mujoco.MjSpec()
    spec.option.timestep = dt
    spec.option.integrator = mujoco.mjtIntegrator.mjINT_EULER
    spec.option.disableflags |= (
        mujoco.mjtDisableBit.mjDSBL_CONTACT | mujoco.mjtDisableBit.mjDSBL_CONSTRAINT
    )
    player_xml = asset_path(xml).read_text()
    for e in range(n_envs):
        for p in range(n_players):
            frame = spec.worldbody.add_frame()
            if p == 1:
                frame.quat = [0.0, 0.0, 0.0, 1.0]  # 180 degrees about z
            spec.attach(mujoco.MjSpec.from_string(player_xml), prefix=f"e{e}p{p}_", frame=frame)
    return spec.compile()


_GEOMETRY: dict | None = None


def player_geometry() -> dict:
    """Dimensions the rulebook needs, read from the compiled player model."""
    global _GEOMETRY
    if _GEOMETRY is None:
        m = mujoco.MjModel.from_xml_path(str(asset_path("simple_player.xml")))
        d = mujoco.MjData(m)
        mujoco.mj_forward(m, d)
        arm = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "arm")
        base = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, "base")
        face = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_GEOM, "face")
        joint = mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, "arm")
        full = np.zeros((m.nv, m.nv))
        mujoco.mj_fullM(m, d, full)
        _GEOMETRY = {
            "base_z": float(m.body_pos[base][2]),
            "pivot_z": float(m.body_pos[base][2] + m.body_pos[arm][2]),
            "face_offset": float(m.geom_pos[face][2]),
            "face_half": m.geom_size[face].copy(),
            "inertia": float(full[0, 0]),
            "limit": float(m.jnt_range[joint][1]),
        }
    return _GEOMETRY
