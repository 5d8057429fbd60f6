"""The rendering model: the court, the players (SIMPLE or HUMAN-LIKE), a shuttle and target
markers in one world.

The simulator's own model (``rallysim.core.bodies``) batches players and carries no shuttle, so
rendering builds this separate single-world model and copies one environment's state into it.
Everything movable is a mocap body or a hinge, so a frame needs only kinematics, no dynamics.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import TYPE_CHECKING

import mujoco
import numpy as np

from rallysim.assets import asset_path
from rallysim.core.shuttle import RADIUS
from rallysim.players import get_player

if TYPE_CHECKING:
    from rallysim.render.players import PlayerRig

SHUTTLE_RGBA = (1.0, 0.9, 0.15, 1.0)  # yellow: stands out against the green floor and the sky
MARKER_RGBA = (0.95, 0.05, 0.05, 1.0)
MARKER_RADIUS = 0.3
MARKER_HALF_HEIGHT = 0.01  # a thin disc, lifted clear of the court lines (0.002 high)
PLAYER1_BASE_RGBA = (0.85, 0.5, 0.15, 1.0)  # player 0 keeps the asset's blue
HIDDEN_Z = -5.0  # where a marker with no target waits, under the hall floor, out of view
HALL_FLOOR_RGBA = (0.27, 0.29, 0.33, 1.0)
HALL_WALL_RGBA = (0.5, 0.58, 0.7, 1.0)
# (name, centre, half sizes, material): a floor around the court, and walls behind it and at
# its ends, far enough to stay out of the way of every camera.
_HALL = (
    ("hall_floor", (0.0, 0.0, -0.05), (40.0, 40.0, 0.045), "hall_floor"),
    ("hall_wall_back", (0.0, 22.0, 15.0), (40.0, 0.1, 15.0), "hall_wall"),
    ("hall_wall_end1", (28.0, 0.0, 15.0), (0.1, 40.0, 15.0), "hall_wall"),
    ("hall_wall_end0", (-28.0, 0.0, 15.0), (0.1, 40.0, 15.0), "hall_wall"),
)


@dataclass(frozen=True)
class CameraPose:
    """A fixed camera aimed at ``target`` that keeps a ``span`` (width, height) metres window
    around the target in view at any image aspect ratio."""

    eye: tuple[float, float, float]
    target: tuple[float, float, float]
    span: tuple[float, float]

    def quat(self) -> np.ndarray:
        """MuJoCo camera orientation: x right, y up, looking along -z."""
        forward = np.subtract(self.target, self.eye)
        forward /= np.linalg.norm(forward)
        right = np.cross(forward, (0.0, 0.0, 1.0))
        right /= np.linalg.norm(right)
        up = np.cross(right, forward)
        mat = np.column_stack([right, up, -forward])
        quat = np.zeros(4)
        mujoco.mju_mat2Quat(quat, mat.ravel())
        return quat

    def fovy(self, aspect: float) -> float:
        """Vertical field of view (degrees) that fits the span at this width / height."""
        dist = float(np.linalg.norm(np.subtract(self.target, self.eye)))
        half = max(0.5 * self.span[1], 0.5 * self.span[0] / aspect)
        return math.degrees(2.0 * math.atan(half / dist))


# "side" frames the whole 13.4 m court and shots up to about 7 m high, from the side (the
# paper's Fig. 2); "three_quarter" looks across the net from behind player 0's right (its
# racket side; the player faces +x, so its right is -y); "three_quarter_close" is nearer,
# framing player 0's half (every hips position, arm raised), the net and the far court's
# front, where serves come from: the HUMAN-LIKE default.
CAMERAS: dict[str, CameraPose] = {
    "side": CameraPose(eye=(0.0, -12.5, 3.6), target=(0.0, 0.0, 2.9), span=(15.0, 8.0)),
    "three_quarter": CameraPose(eye=(-13.0, -11.0, 7.0), target=(-0.3, 0.0, 1.2),
                                span=(14.0, 7.0)),
    "three_quarter_close": CameraPose(eye=(-16.0, -8.5, 6.0), target=(-2.0, 0.0, 1.3),
                                      span=(11.0, 6.2)),
}


def fit_cameras(model: mujoco.MjModel, aspect: float) -> None:
    """Refit every ``CAMERAS`` camera's vertical field of view to an image of this width /
    height, so each keeps its span in view."""
    for name, pose in CAMERAS.items():
        cam = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_CAMERA, name)
        model.cam_fovy[cam] = pose.fovy(aspect)


def build_render_model(n_players: int, player: str, rig: type[PlayerRig]) -> mujoco.MjModel:
    """court.xml + ``n_players`` players of kind ``player`` (its spec's asset, named ``p0_``,
    ``p1_``) + ``shuttle``, cameras posed by ``CAMERAS``. With a ``rig`` whose targets are floor
    markers (SIMPLE's landing depths) each player gets one (``marker0``, ``marker1``, discs on
    the floor); other targets (HUMAN-LIKE's racket velocities) are drawn per frame by the rig
    (``rallysim.render.players``), not as bodies."""
    if n_players not in (1, 2):
        raise ValueError(f"n_players must be 1 or 2, got {n_players!r}")
    spec = mujoco.MjSpec.from_file(str(asset_path("court.xml")))
    # The player asset sets the simulator's 0.02 s step; matching it keeps attach() quiet
    # (nothing is ever stepped in this model).
    spec.option.timestep = 0.02
    _lighten(spec)
    _add_players(spec, n_players, get_player(player).asset, rig.player1_material)
    _add_shuttle(spec)
    if rig.floor_markers:
        for p in range(n_players):
            _add_marker(spec, p)
    _pose_cameras(spec)
    return spec.compile()


def _lighten(spec: mujoco.MjSpec) -> None:
    """Make the scene cheap for a software rasteriser (llvmpipe), whose cost on these frames
    is per triangle and per textured pixel rather than per geom:
    - coarse tessellation: a 0.1 m sphere is a few pixels wide, and MuJoCo's default 28 x 16
      slices made the shuttle trail's spheres a large share of a frame's cost;
    - the court's floor drawn as a few quads, not the 8,000 of its 0.1 m render grid;
    - the textured skybox replaced by flat, untextured walls and floor of a hall around the
      court. docs/rendering.md gives the measured costs."""
    quality = spec.visual.quality
    quality.numslices, quality.numstacks, quality.numquads = 12, 6, 1
    floor = spec.geom("floor")
    floor.size = [floor.size[0], floor.size[1], 10.0]  # render-grid spacing, no physics
    spec.delete(spec.texture("sky"))
    # Lighting is per vertex: a spotlight (court.xml's "sun" is one) leaves the corners of a
    # large, coarsely tessellated floor outside its cone, i.e. black. A sun is directional.
    spec.light("sun").type = mujoco.mjtLightType.mjLIGHT_DIRECTIONAL
    spec.add_material(name="hall_floor", rgba=HALL_FLOOR_RGBA)
    # the walls face the cameras, lit only by the weak headlight: glow a little
    spec.add_material(name="hall_wall", rgba=HALL_WALL_RGBA, emission=0.6)
    for name, pos, size, material in _HALL:
        spec.worldbody.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_BOX, pos=list(pos),
                                size=list(size), material=material, contype=0, conaffinity=0)


def _add_players(spec: mujoco.MjSpec, n_players: int, asset: str, player1_material: str) -> None:
    """The simulator's own player asset, attached as the simulator attaches it (player 1
    turned 180 degrees about z): one joint angle draws the same pose on either side. Sites
    (HUMAN-LIKE's hit box ``face``) are in group 3, which MuJoCo does not draw by default."""
    player_xml = asset_path(asset).read_text()
    for p in range(n_players):
        frame = spec.worldbody.add_frame()
        if p == 1:
            frame.quat = [0.0, 0.0, 0.0, 1.0]  # 180 degrees about z, as in the simulator
        spec.attach(mujoco.MjSpec.from_string(player_xml), prefix=f"p{p}_", frame=frame)
    if n_players == 2:  # tell the two players apart
        spec.material(f"p1_{player1_material}").rgba = PLAYER1_BASE_RGBA


def _add_shuttle(spec: mujoco.MjSpec) -> None:
    # The rules judge the shuttle as a sphere of this radius, so that is what is drawn.
    spec.add_material(name="shuttle", rgba=SHUTTLE_RGBA, emission=0.6)
    body = spec.worldbody.add_body(name="shuttle", mocap=True, pos=[0.0, 0.0, -1.0])
    body.add_geom(name="shuttle", type=mujoco.mjtGeom.mjGEOM_SPHERE, size=[RADIUS, 0, 0],
                  material="shuttle", contype=0, conaffinity=0)


def _add_marker(spec: mujoco.MjSpec, player: int) -> None:
    name = f"marker{player}"
    if player == 0:
        spec.add_material(name="marker", rgba=MARKER_RGBA, emission=0.5)
    body = spec.worldbody.add_body(name=name, mocap=True, pos=[0.0, 0.0, HIDDEN_Z])
    body.add_geom(name=name, type=mujoco.mjtGeom.mjGEOM_CYLINDER,
                  size=[MARKER_RADIUS, MARKER_HALF_HEIGHT, 0], material="marker",
                  contype=0, conaffinity=0)


def _pose_cameras(spec: mujoco.MjSpec) -> None:
    for name, pose in CAMERAS.items():
        cam = spec.camera(name)
        if cam is None:
            cam = spec.worldbody.add_camera(name=name)
        cam.pos = list(pose.eye)
        # court.xml orients its cameras with xyaxes, which would win over a quaternion
        cam.alt.type = mujoco.mjtOrientation.mjORIENTATION_QUAT
        cam.quat = list(pose.quat())
        cam.fovy = pose.fovy(16 / 9)  # refitted to the renderer's aspect by SceneRenderer
