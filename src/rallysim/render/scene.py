"""``SceneRenderer``: pictures of one environment of a batched ``Game``."""

from __future__ import annotations

import math
import weakref
from collections.abc import Sequence

import mujoco
import numpy as np

from rallysim.core.game import Game
from rallysim.core.rules import FORWARD
from rallysim.render.hud import HudFont, draw_text, font_size_for
from rallysim.render.model import (
    CAMERAS,
    HIDDEN_Z,
    MARKER_HALF_HEIGHT,
    SHUTTLE_RGBA,
    build_render_model,
)
from rallysim.render.trail import TRAIL_LENGTH, ShuttleTrail

TargetDepth = float | Sequence[float | None] | np.ndarray | None


class SceneRenderer:
    """Renders the court, the players, the shuttle (with a fading trail) and target markers.

    ``render(game, env_index)`` copies environment ``env_index`` of ``game`` into this
    renderer's own single-world model and returns an (H, W, 3) uint8 RGB frame. The trail
    remembers the shuttle positions of the previous ``render`` calls: call ``reset_trail()``
    when a new episode or rally starts.
    """

    def __init__(self, n_players: int = 1, width: int = 640, height: int = 360,
                 camera: str = "side", trail_length: int = TRAIL_LENGTH) -> None:
        if camera not in CAMERAS:
            raise ValueError(f"unknown camera {camera!r}; valid: {', '.join(map(repr, CAMERAS))}")
        self.n_players, self.width, self.height, self.camera = n_players, width, height, camera
        self.model = build_render_model(n_players)
        self._fit_cameras(width / height)
        # the offscreen buffer court.xml asks for (1280x720) must hold the image
        buf = self.model.vis.global_
        buf.offwidth, buf.offheight = max(buf.offwidth, width), max(buf.offheight, height)
        self.data = mujoco.MjData(self.model)
        self._renderer = mujoco.Renderer(self.model, height, width)
        # Free the GL context before interpreter shutdown tears down PyOpenGL: freeing an
        # OSMesa context from a late __del__ fails with a noisy traceback.
        self._finalizer = weakref.finalize(self, self._renderer.close)
        self._camera_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
        self._bind_ids()
        self.trail = ShuttleTrail(trail_length, SHUTTLE_RGBA[:3])
        self._font = HudFont(font_size_for(height))
        mujoco.mj_forward(self.model, self.data)

    # -- set-up ----------------------------------------------------------------------------
    def _fit_cameras(self, aspect: float) -> None:
        for name, pose in CAMERAS.items():
            cam = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, name)
            self.model.cam_fovy[cam] = pose.fovy(aspect)

    def _bind_ids(self) -> None:
        m = self.model

        def mocap(body: str) -> int:
            return int(m.body_mocapid[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_BODY, body)])

        def qpos(joint: str) -> int:
            return int(m.jnt_qposadr[mujoco.mj_name2id(m, mujoco.mjtObj.mjOBJ_JOINT, joint)])

        p = range(self.n_players)
        self._base_mocap = np.array([mocap(f"p{i}_base") for i in p])
        self._arm_qpos = np.array([qpos(f"p{i}_arm") for i in p])
        self._marker_mocap = np.array([mocap(f"marker{i}") for i in p])
        self._shuttle_mocap = mocap("shuttle")

    @property
    def renderer(self) -> mujoco.Renderer:
        """The ``mujoco.Renderer`` underneath (for custom scene options or raw frames)."""
        return self._renderer

    # -- state -----------------------------------------------------------------------------
    def reset_trail(self) -> None:
        """Forget the shuttle's past positions (call at the start of each episode)."""
        self.trail.reset()

    def set_state(self, game: Game, env_index: int = 0, target_depth: TargetDepth = None,
                  ) -> None:
        """Copy environment ``env_index`` of ``game`` into this renderer's world and record the
        shuttle position in the trail."""
        if game.n_players != self.n_players:
            raise ValueError(f"renderer built for {self.n_players} player(s), game has "
                             f"{game.n_players}")
        b, d = game.bodies, self.data
        e = int(env_index)
        base = d.mocap_pos[self._base_mocap]
        base[:, 0] = b.forward[e] * b.base_x[e]  # own frame -> world
        base[:, 1] = 0.0
        base[:, 2] = b.base_z
        d.mocap_pos[self._base_mocap] = base
        # The same hinge angle means the same swing for both players: player 1's frame is
        # rotated in the model, exactly as in the simulator's model.
        d.qpos[self._arm_qpos] = b.theta[e]
        shuttle = game.shuttle.pos[e]
        d.mocap_pos[self._shuttle_mocap] = shuttle
        self._place_markers(target_depth)
        self.trail.push(shuttle)
        # Positions only: mocap bodies and joints need kinematics; the cameras and the light
        # (mj_camlight) are fixed but computed there too. No dynamics are needed to draw.
        mujoco.mj_kinematics(self.model, d)
        mujoco.mj_camlight(self.model, d)

    def _place_markers(self, target_depth: TargetDepth) -> None:
        depths = _per_player(target_depth, self.n_players)
        for p, depth in enumerate(depths):
            pos = self.data.mocap_pos[self._marker_mocap[p]]
            if depth is None or not math.isfinite(depth):
                pos[:] = (0.0, 0.0, HIDDEN_Z)
            else:
                # a depth beyond the net in player p's own frame
                pos[:] = (FORWARD[p] * depth, 0.0, MARKER_HALF_HEIGHT + 0.002)

    # -- drawing ---------------------------------------------------------------------------
    def render(self, game: Game, env_index: int = 0, target_depth: TargetDepth = None,
               hud_text: str | None = None) -> np.ndarray:
        """(H, W, 3) uint8 RGB frame of environment ``env_index`` of ``game``.

        ``target_depth``: None (no marker), one depth in metres beyond the net for player 0,
        or one per player (None or NaN hides that player's marker). ``hud_text`` is written in
        the top-left corner (newlines allowed)."""
        self.set_state(game, env_index, target_depth)
        return self.render_current(hud_text)

    def render_current(self, hud_text: str | None = None) -> np.ndarray:
        """A frame of the state last set (``set_state`` or ``render``)."""
        r = self._renderer
        r.update_scene(self.data, self._camera_id)
        self.trail.draw(r.scene)
        frame = r.render()
        if hud_text:
            draw_text(frame, hud_text, self._font)
        return frame

    # -- geometry --------------------------------------------------------------------------
    def project(self, points: np.ndarray) -> np.ndarray:
        """Pixel coordinates (..., 2) = (column, row) of world ``points`` (..., 3) in this
        renderer's camera; pixel (i, j) covers columns [j, j + 1) and rows [i, i + 1).
        Points behind the camera give NaN."""
        cam = self._camera_id
        pos = self.data.cam_xpos[cam]
        axes = self.data.cam_xmat[cam].reshape(3, 3)  # columns: right, up, backward
        rel = (np.asarray(points, dtype=np.float64) - pos) @ axes
        depth = -rel[..., 2]
        focal = 0.5 * self.height / math.tan(math.radians(self.model.cam_fovy[cam]) / 2.0)
        with np.errstate(divide="ignore", invalid="ignore"):
            col = 0.5 * self.width + focal * rel[..., 0] / depth
            row = 0.5 * self.height - focal * rel[..., 1] / depth
        out = np.stack([col, row], axis=-1)
        out[depth <= 0] = np.nan
        return out

    # -- lifetime --------------------------------------------------------------------------
    def close(self) -> None:
        """Free the OpenGL context (also done when the renderer is garbage-collected)."""
        self._finalizer()

    def __enter__(self) -> SceneRenderer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


def _per_player(target_depth: TargetDepth, n_players: int) -> list[float | None]:
    if target_depth is None:
        return [None] * n_players
    if np.ndim(target_depth) == 0:
        return [float(target_depth)] + [None] * (n_players - 1)  # type: ignore[arg-type]
    depths = [None if d is None else float(d) for d in target_depth]  # type: ignore[union-attr]
    if len(depths) != n_players:
        raise ValueError(f"expected {n_players} target depths, got {len(depths)}")
    return depths
