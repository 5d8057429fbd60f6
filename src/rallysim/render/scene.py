"""``SceneRenderer``: pictures of one environment of a batched ``Game``."""

from __future__ import annotations

import math
import weakref

import mujoco
import numpy as np

from rallysim.core.game import Game
from rallysim.render.hud import HudFont, draw_text, font_size_for
from rallysim.render.model import CAMERAS, SHUTTLE_RGBA, build_render_model, fit_cameras
from rallysim.render.players import (
    PlayerRig,
    TargetDepth,
    TargetVelocity,
    default_camera,
    rig_class,
)
from rallysim.render.trail import TRAIL_LENGTH, ShuttleTrail

__all__ = ["SceneRenderer", "TargetDepth", "TargetVelocity"]


class SceneRenderer:
    """Renders the court, the players, the shuttle (with a fading trail) and target markers.

    ``render(game, env_index)`` copies environment ``env_index`` of ``game`` into this
    renderer's own single-world model and returns an (H, W, 3) uint8 RGB frame. The trail
    remembers the shuttle positions of the previous ``render`` calls: call ``reset_trail()``
    when a new episode or rally starts.

    ``player`` is the kind of player the games have: ``"simple"`` (SIMPLE robots; targets are
    landing depths, red discs on the floor) or ``"humanlike"`` (HUMAN-LIKE upper bodies, every
    joint and the hips copied; targets are racket velocities, red arrows from the racket head).
    ``camera`` defaults to ``"side"`` for SIMPLE and ``"three_quarter_close"`` for HUMAN-LIKE.

    ``offscreen=False`` builds the world without an OpenGL renderer, for a live viewer that draws
    ``model`` and ``data`` itself (``set_state`` works, the frame methods raise).
    """

    def __init__(self, n_players: int = 1, width: int = 640, height: int = 360,
                 camera: str | None = None, trail_length: int = TRAIL_LENGTH,
                 player: str = "simple", offscreen: bool = True) -> None:
        camera = default_camera(player) if camera is None else camera
        if camera not in CAMERAS:
            raise ValueError(f"unknown camera {camera!r}; valid: {', '.join(map(repr, CAMERAS))}")
        self.n_players, self.width, self.height, self.camera = n_players, width, height, camera
        self.player = player
        rig = rig_class(player)
        self.model = build_render_model(n_players, player, rig)
        fit_cameras(self.model, width / height)
        # the offscreen buffer court.xml asks for (1280x720) must hold the image
        buf = self.model.vis.global_
        buf.offwidth, buf.offheight = max(buf.offwidth, width), max(buf.offheight, height)
        self.data = mujoco.MjData(self.model)
        self._renderer: mujoco.Renderer | None = None
        if offscreen:
            self._renderer = mujoco.Renderer(self.model, height, width)
            # Free the GL context before interpreter shutdown tears down PyOpenGL: freeing an
            # OSMesa context from a late __del__ fails with a noisy traceback.
            self._finalizer = weakref.finalize(self, self._renderer.close)
        else:
            self._finalizer = weakref.finalize(self, lambda: None)
        self._camera_id = mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_CAMERA, camera)
        self._shuttle_mocap = int(self.model.body_mocapid[
            mujoco.mj_name2id(self.model, mujoco.mjtObj.mjOBJ_BODY, "shuttle")])
        self.rig: PlayerRig = rig(self.model, self.data, n_players)
        self.trail = ShuttleTrail(trail_length, SHUTTLE_RGBA[:3])
        self._font = HudFont(font_size_for(height))
        mujoco.mj_forward(self.model, self.data)

    @property
    def renderer(self) -> mujoco.Renderer:
        """The ``mujoco.Renderer`` underneath (for custom scene options or raw frames)."""
        if self._renderer is None:
            raise RuntimeError("this SceneRenderer was built with offscreen=False: it has no "
                               "renderer and draws no frames")
        return self._renderer

    # -- state -----------------------------------------------------------------------------
    def reset_trail(self) -> None:
        """Forget the shuttle's past positions (call at the start of each episode)."""
        self.trail.reset()

    def set_state(self, game: Game, env_index: int = 0, target_depth: TargetDepth = None, *,
                  target_velocity: TargetVelocity = None) -> None:
        """Copy environment ``env_index`` of ``game`` into this renderer's world and record the
        shuttle position in the trail. Targets as in ``render``."""
        if game.n_players != self.n_players:
            raise ValueError(f"renderer built for {self.n_players} player(s), game has "
                             f"{game.n_players}")
        rig = self.rig
        rig.check(game)
        e = int(env_index)
        rig.copy_state(game, e)
        shuttle = game.shuttle.pos[e]
        self.data.mocap_pos[self._shuttle_mocap] = shuttle
        rig.place_targets(self._target(target_depth, target_velocity))
        self.trail.push(shuttle)
        # Positions only: mocap bodies and joints need kinematics; the cameras and the light
        # (mj_camlight) are fixed but computed there too. No dynamics are needed to draw.
        mujoco.mj_kinematics(self.model, self.data)
        mujoco.mj_camlight(self.model, self.data)

    def _target(self, target_depth: TargetDepth, target_velocity: TargetVelocity) -> object:
        """The target argument this kind of player takes; the other one must be None."""
        given = {"target_depth": target_depth, "target_velocity": target_velocity}
        value = given.pop(self.rig.target_keyword)
        for name, other in given.items():
            if other is not None:
                raise ValueError(f"{self.player} players take {self.rig.target_keyword}, "
                                 f"not {name}")
        return value

    # -- drawing ---------------------------------------------------------------------------
    def render(self, game: Game, env_index: int = 0, target_depth: TargetDepth = None,
               hud_text: str | None = None, *, target_velocity: TargetVelocity = None,
               ) -> np.ndarray:
        """(H, W, 3) uint8 RGB frame of environment ``env_index`` of ``game``.

        SIMPLE: ``target_depth`` is None (no marker), one depth in metres beyond the net for
        player 0, or one per player (None or NaN hides that player's marker). HUMAN-LIKE:
        ``target_velocity`` is None (no arrow), one own-frame racket velocity (3,) in m/s for
        player 0, or one per player (None or NaN hides one). ``hud_text`` is written in the
        top-left corner (newlines allowed)."""
        self.set_state(game, env_index, target_depth, target_velocity=target_velocity)
        return self.render_current(hud_text)

    def render_current(self, hud_text: str | None = None) -> np.ndarray:
        """A frame of the state last set (``set_state`` or ``render``)."""
        r = self.renderer
        r.update_scene(self.data, self._camera_id)
        self.rig.draw(r.scene)
        self.trail.draw(r.scene)
        frame = r.render()
        if hud_text:
            draw_text(frame, hud_text, self._font)
        return frame

    def draw_markers(self, scene: mujoco.MjvScene) -> int:
        """Append the targets that are not bodies of the model (HUMAN-LIKE's arrows) to
        another ``scene``, e.g. a viewer's ``user_scn``; returns the geoms added."""
        return self.rig.draw(scene)

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

