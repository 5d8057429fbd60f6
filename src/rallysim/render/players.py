"""Player kinds in the rendering model: copying a ``Game``'s players in, and their targets.

``SceneRenderer`` draws the court, the shuttle, its trail and the HUD the same way for every
kind of player; a *rig* does the rest for one kind:

- ``SimpleRig`` (SIMPLE, docs/reference.md §5): base position and arm angle; the target is a
  landing depth, a red disc on the floor (a mocap body of the rendering model).
- ``HumanLikeRig`` (HUMAN-LIKE, docs/reference.md §10): hips position and all 8 hinge angles;
  the target is a racket velocity, a red arrow from the racket head along it,
  ``ARROW_SECONDS`` × the velocity long, added to each frame's scene as a decor geom.

Each player kind's spec names its rig (``PlayerSpec.rig``); the rig supplies the kind's goal and
target markers, floor discs, player 1's colour and keyboard player, so rendering and play switch
on no kind's name.
"""

from __future__ import annotations

import importlib
import math
from collections.abc import Sequence
from typing import Any, ClassVar

import mujoco
import numpy as np

from rallysim.core.bodies import SimpleBodies
from rallysim.core.game import Game
from rallysim.core.humanlike import JOINTS, HumanLikeBodies
from rallysim.core.rules import FORWARD
from rallysim.players import PLAYERS, get_player
from rallysim.players.humanlike import targets_from_goals
from rallysim.render.keyboard import Keyboard, KeyboardGoals, KeyboardPlayer
from rallysim.render.model import HIDDEN_Z, MARKER_HALF_HEIGHT, MARKER_RGBA

TargetDepth = float | Sequence[float | None] | np.ndarray | None
TargetVelocity = Sequence[float] | Sequence[Sequence[float] | None] | np.ndarray | None

ARROW_SECONDS = 0.25  # arrow length = this × the target velocity: 0.4-1.1 m for 1.5-4.5 m/s
ARROW_WIDTH = 0.02  # shaft radius (m); MuJoCo draws the head wider
ARROW_EMISSION = 0.5  # as the SIMPLE marker's material: red reads under the overhead light
_EYE3 = np.eye(3).ravel()


class PlayerRig:
    """What ``SceneRenderer`` needs to draw one kind of player: see the module docstring."""

    bodies_type: ClassVar[type]
    target_keyword: ClassVar[str]  # the ``render`` argument that carries this kind's target
    floor_markers: ClassVar[bool] = False  # the rendering model holds a target disc per player
    player1_material: ClassVar[str]  # the asset's material recoloured on player 1's copy
    keyboard: ClassVar[type[Keyboard]]  # the keyboard player of ``rallysim play``

    @classmethod
    def goal_markers(cls, goals: np.ndarray) -> dict[str, Any]:
        """``render`` / ``set_state`` keyword arguments drawing one rally's turn-based goals
        (2, *goal shape), one per player."""
        return {cls.target_keyword: cls.targets_of_goals(np.asarray(goals))}

    @classmethod
    def targets_of_goals(cls, goals: np.ndarray) -> Any:
        """What a turn-based goal looks like as this kind's drawn target."""
        return goals

    @classmethod
    def target_markers(cls, target: Any) -> dict[str, Any]:
        """The same for a low-level task's own target (as the task states it)."""
        return {cls.target_keyword: target}

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, n_players: int) -> None:
        self.model, self.data, self.n_players = model, data, n_players

    def _mocap(self, body: str) -> int:
        m = self.model
        return int(m.body_mocapid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body)])

    def _qpos(self, joint: str) -> int:
        m = self.model
        return int(m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, joint)])

    def check(self, game: Game) -> None:
        """A clear error for a game of another kind of player (whose state would not fit)."""
        if not isinstance(game.bodies, self.bodies_type):
            raise TypeError(f"this renderer draws {self.bodies_type.__name__} players, the "
                            f"game's bodies are "
                            f"{type(game.bodies).__name__}: use SceneRenderer(..., "
                            f"player={_kind_of(game.bodies)!r})")

    def copy_state(self, game: Game, env: int) -> None:
        """Write environment ``env``'s player poses into ``data`` (before kinematics)."""
        raise NotImplementedError

    def place_targets(self, target: Any) -> None:
        """Record the targets to draw (``None``: none); ``target`` is the value of the
        ``target_keyword`` argument."""
        raise NotImplementedError

    def draw(self, scene: mujoco.MjvScene) -> int:
        """Append per-frame decor (after ``update_scene``, after kinematics); returns the geoms
        added."""
        return 0


class SimpleRig(PlayerRig):
    bodies_type = SimpleBodies
    target_keyword = "target_depth"
    floor_markers = True
    player1_material = "base"
    keyboard = KeyboardPlayer  # the keys drive the arm and the base

    @classmethod
    def targets_of_goals(cls, goals: np.ndarray) -> Any:
        return list(goals)  # landing depths, drawn as they are

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, n_players: int) -> None:
        super().__init__(model, data, n_players)
        p = range(n_players)
        self._base_mocap = np.array([self._mocap(f"p{i}_base") for i in p])
        self._arm_qpos = np.array([self._qpos(f"p{i}_arm") for i in p])
        self._marker_mocap = np.array([self._mocap(f"marker{i}") for i in p])

    def copy_state(self, game: Game, env: int) -> None:
        b, d = game.bodies, self.data
        base = d.mocap_pos[self._base_mocap]
        base[:, 0] = b.forward[env] * b.base_x[env]  # own frame -> world
        base[:, 1] = 0.0
        base[:, 2] = b.base_z
        d.mocap_pos[self._base_mocap] = base
        # The same hinge angle means the same swing for both players: player 1's frame is
        # rotated in the model, exactly as in the simulator's model.
        d.qpos[self._arm_qpos] = b.theta[env]

    def place_targets(self, target: TargetDepth) -> None:
        for p, depth in enumerate(_per_player_depth(target, self.n_players)):
            pos = self.data.mocap_pos[self._marker_mocap[p]]
            if depth is None or not math.isfinite(depth):
                pos[:] = (0.0, 0.0, HIDDEN_Z)
            else:
                # a depth beyond the net in player p's own frame
                pos[:] = (FORWARD[p] * depth, 0.0, MARKER_HALF_HEIGHT + 0.002)


class HumanLikeRig(PlayerRig):
    bodies_type = HumanLikeBodies
    target_keyword = "target_velocity"
    player1_material = "shirt"
    keyboard = KeyboardGoals  # the keys set the goal the low level swings for

    @classmethod
    def targets_of_goals(cls, goals: np.ndarray) -> Any:
        return targets_from_goals(goals)  # the target racket velocities the goals ask for

    def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, n_players: int) -> None:
        super().__init__(model, data, n_players)
        p = range(n_players)
        self._hips_mocap = np.array([self._mocap(f"p{i}_hips") for i in p])
        self._joint_qpos = np.array([[self._qpos(f"p{i}_{j}") for j in JOINTS] for i in p])
        self._face_site = np.array([mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE,
                                                      f"p{i}_face") for i in p])
        self._arrows = np.full((n_players, 3), np.nan)  # world-frame arrow vectors (m)
        self._rgba = np.asarray(MARKER_RGBA, np.float32)

    def copy_state(self, game: Game, env: int) -> None:
        b, d = game.bodies, self.data
        hips = d.mocap_pos[self._hips_mocap]
        hips[:, :2] = b.forward[env][:, None] * b.hips[env]  # own frame -> world
        hips[:, 2] = b.hips_height
        d.mocap_pos[self._hips_mocap] = hips
        # player 1's copy is turned in the model as in the simulator's: the same angles
        d.qpos[self._joint_qpos] = b.qpos[env]

    def place_targets(self, target: TargetVelocity) -> None:
        own = _per_player_velocity(target, self.n_players)
        self._arrows[:] = own * ARROW_SECONDS
        self._arrows[:, :2] *= FORWARD[:self.n_players, None]  # own frame -> world

    def draw(self, scene: mujoco.MjvScene) -> int:
        added = 0
        for p in range(self.n_players):
            vec = self._arrows[p]
            if not np.all(np.isfinite(vec)) or not vec.any():
                continue
            if scene.ngeom >= scene.maxgeom:
                break
            start = self.data.site_xpos[self._face_site[p]]
            geom = scene.geoms[scene.ngeom]
            size = np.array([ARROW_WIDTH, ARROW_WIDTH, 1.0])
            mujoco.mjv_initGeom(geom, mujoco.mjtGeom.mjGEOM_ARROW, size, start, _EYE3,
                                self._rgba)
            mujoco.mjv_connector(geom, mujoco.mjtGeom.mjGEOM_ARROW, ARROW_WIDTH, start,
                                 start + vec)
            # MuJoCo draws an arrow of size[2] only size[2] / 2 long (shaft to a third, head
            # to a half), while mjv_connector sets size[2] to the distance: double it, so that
            # the tip is at the end (tested against the camera projection)
            geom.size[2] *= 2.0
            geom.emission = ARROW_EMISSION
            geom.category = mujoco.mjtCatBit.mjCAT_DECOR
            scene.ngeom += 1
            added += 1
        return added

    def arrow(self, player: int = 0) -> tuple[np.ndarray, np.ndarray] | None:
        """World (start, end) of player ``player``'s target arrow as last drawn, or None."""
        vec = self._arrows[player]
        if not np.all(np.isfinite(vec)) or not vec.any():
            return None
        start = self.data.site_xpos[self._face_site[player]].copy()
        return start, start + vec


def rig_class(player: str) -> type[PlayerRig]:
    """The rig a player kind's spec names (``PlayerSpec.rig``, ``"module:Class"``)."""
    module, _, name = get_player(player).rig.partition(":")
    rig = getattr(importlib.import_module(module), name)
    if not (isinstance(rig, type) and issubclass(rig, PlayerRig)):
        raise TypeError(f"player kind {player!r}: rig {module}:{name} is not a PlayerRig")
    return rig


def _kind_of(bodies: Any) -> str:
    """The player kind whose rig draws ``bodies`` (``"?"`` if none does)."""
    kinds = [name for name in PLAYERS if isinstance(bodies, rig_class(name).bodies_type)]
    return kinds[0] if kinds else "?"


def default_camera(player: str) -> str:
    return get_player(player).camera


def _per_player_depth(target_depth: TargetDepth, n_players: int) -> list[float | None]:
    if target_depth is None:
        return [None] * n_players
    if np.ndim(target_depth) == 0:
        return [float(target_depth)] + [None] * (n_players - 1)  # type: ignore[arg-type]
    depths = [None if d is None else float(d) for d in target_depth]  # type: ignore[union-attr]
    if len(depths) != n_players:
        raise ValueError(f"expected {n_players} target depths, got {len(depths)}")
    return depths


def _per_player_velocity(target: TargetVelocity, n_players: int) -> np.ndarray:
    """(P, 3) own-frame target velocities, NaN rows where a player has none: ``target`` is
    None, one velocity (3,) for player 0, or one per player (None or NaN hides one)."""
    out = np.full((n_players, 3), np.nan)
    if target is None:
        return out
    rows = list(target)
    if len(rows) == 3 and all(r is not None and np.ndim(r) == 0 for r in rows):
        rows = [rows] + [None] * (n_players - 1)  # one velocity: player 0's
    if len(rows) != n_players:
        raise ValueError(f"expected a velocity (3,) or {n_players} target velocities, got "
                         f"{len(rows)} rows")
    for p, row in enumerate(rows):
        if row is not None:
            v = np.asarray(row, dtype=np.float64)
            if v.shape != (3,):
                raise ValueError(f"a target velocity has 3 components, got shape {v.shape}")
            out[p] = v
    return out
