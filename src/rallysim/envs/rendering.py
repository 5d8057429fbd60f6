"""Rendering for the env views: ``render_mode="rgb_array"`` frames and ``"human"`` windows.

The renderer (``rallysim.render``, an optional extra) is created on the first ``render()``
call, so envs without rendering never touch OpenGL.
"""

from __future__ import annotations

import os
from typing import Any

import numpy as np


def has_display() -> bool:
    return bool(os.environ.get("DISPLAY") or os.environ.get("WAYLAND_DISPLAY"))


# "human" is listed whether or not a display exists: for a mode missing from this list,
# gymnasium.make swaps in its own pygame window (HumanRendering over "rgb_array"), which fails
# only at reset, far from the cause. Listed, the env itself refuses "human" without a display
# (check_render_mode). Gymnasium's env_checker, which tries every listed mode, then needs a
# display or skip_render_check=True, as for Gymnasium's own MuJoCo envs.
RENDER_MODES = ["rgb_array", "human"]


def check_render_mode(render_mode: str | None) -> str | None:
    if render_mode is not None and render_mode not in ("rgb_array", "human"):
        raise ValueError(f"unknown render_mode {render_mode!r}; valid: None, 'rgb_array', "
                         "'human' (with a display)")
    if render_mode == "human" and not has_display():
        raise ValueError("render_mode='human' needs a display (DISPLAY is unset); use "
                         "render_mode='rgb_array' and rallysim.render.write_video instead")
    return render_mode


class EnvView:
    """Draws environment ``env_index`` of a ``Game`` for one env view.

    ``player`` is the kind of player the env's games have (``"simple"`` or ``"humanlike"``,
    see ``rallysim.render.SceneRenderer``); ``camera`` None picks that kind's default."""

    def __init__(self, render_mode: str | None, n_players: int, width: int = 640,
                 height: int = 360, camera: str | None = None, player: str = "simple") -> None:
        self.mode = check_render_mode(render_mode)
        self.n_players, self.size, self.camera = n_players, (width, height), camera
        self.player = player
        self._scene: Any = None
        self._viewer: Any = None

    def __getstate__(self) -> dict[str, Any]:
        """A copy draws with its own renderer (a GL context and a window belong to one
        process and one object), made when it first renders."""
        return {**self.__dict__, "_scene": None, "_viewer": None}

    def _scene_renderer(self) -> Any:
        if self._scene is None:
            try:
                from rallysim.render import SceneRenderer
            except ImportError as err:
                raise ImportError("rendering needs the render extra: "
                                  "pip install 'rallysim[render]'") from err
            # "human": MuJoCo's viewer draws the model itself, no offscreen context needed
            self._scene = SceneRenderer(self.n_players, *self.size, camera=self.camera,
                                        player=self.player, offscreen=self.mode == "rgb_array")
        return self._scene

    def new_episode(self) -> None:
        if self._scene is not None:
            self._scene.reset_trail()

    def render(self, game: Any, env_index: int = 0, target_depth: Any = None,
               hud_text: str | None = None, *, target_velocity: Any = None,
               ) -> np.ndarray | None:
        """A frame (``"rgb_array"``) or a viewer update (``"human"``); targets as in
        ``SceneRenderer.render``."""
        if self.mode is None:
            return None
        scene = self._scene_renderer()
        if self.mode == "rgb_array":
            return scene.render(game, env_index, target_depth, hud_text,
                                target_velocity=target_velocity)
        if self._viewer is None:
            from rallysim.render.play import launch_viewer

            self._viewer = launch_viewer(scene.model, scene.data, scene.camera)
        # the viewer draws from its own thread: change its world only under its lock.
        # Targets drawn per frame, not bodies of the model (HUMAN-LIKE's arrows; SIMPLE has
        # none), go to the viewer's own scene.
        with self._viewer.lock():
            scene.set_state(game, env_index, target_depth, target_velocity=target_velocity)
            self._viewer.user_scn.ngeom = 0
            scene.draw_markers(self._viewer.user_scn)
        self._viewer.sync()
        return None

    def close(self) -> None:
        if self._viewer is not None:
            self._viewer.close()
            self._viewer = None
        if self._scene is not None:
            self._scene.close()
            self._scene = None
