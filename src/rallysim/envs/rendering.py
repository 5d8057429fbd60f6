"""Rendering for the env views: ``render_mode="rgb_array"`` frames and ``"human"`` windows.

An ``EnvView`` gets its renderer and its window from factories, called on the first
``render()``, so envs without rendering never touch OpenGL, and no env module imports
``rallysim.render`` (an optional extra) when it is imported. The default factories load the
drawing modules (``rallysim.render.scene``, ``rallysim.render.viewer``), which import nothing
of ``rallysim.envs``: the envs-to-render dependency runs one way only.
"""

from __future__ import annotations

import os
from collections.abc import Callable
from typing import Any

import numpy as np

# (n_players, width, height, camera, player, offscreen) -> a renderer with SceneRenderer's API
RendererFactory = Callable[[int, int, int, str | None, str, bool], Any]
# (model, data, camera) -> a window with the API of MuJoCo's passive viewer handle
ViewerFactory = Callable[[Any, Any, str], Any]


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


def scene_renderer(n_players: int, width: int, height: int, camera: str | None, player: str,
                   offscreen: bool) -> Any:
    """The default ``RendererFactory``: ``rallysim.render.scene.SceneRenderer``."""
    try:
        from rallysim.render.scene import SceneRenderer
    except ImportError as err:
        raise ImportError("rendering needs the render extra: "
                          "pip install 'rallysim[render]'") from err
    return SceneRenderer(n_players, width, height, camera=camera, player=player,
                         offscreen=offscreen)


def passive_viewer(model: Any, data: Any, camera: str) -> Any:
    """The default ``ViewerFactory``: MuJoCo's passive viewer
    (``rallysim.render.viewer.launch_viewer``)."""
    from rallysim.render.viewer import launch_viewer

    return launch_viewer(model, data, camera)


class EnvView:
    """Draws environment ``env_index`` of a ``Game`` for one env view.

    ``player`` is the kind of player the env's games have (``"simple"`` or ``"humanlike"``,
    see ``rallysim.render.SceneRenderer``); ``camera`` None picks that kind's default.
    ``renderer_factory`` makes the renderer (for ``"human"``, one without an offscreen
    context: the window draws its world), ``viewer_factory`` the ``"human"`` window; both
    must pickle (module-level functions do) for the view to be copied."""

    def __init__(self, render_mode: str | None, n_players: int, width: int = 640,
                 height: int = 360, camera: str | None = None, player: str = "simple",
                 renderer_factory: RendererFactory = scene_renderer,
                 viewer_factory: ViewerFactory = passive_viewer) -> None:
        self.mode = check_render_mode(render_mode)
        self.n_players, self.size, self.camera = n_players, (width, height), camera
        self.player = player
        self.renderer_factory, self.viewer_factory = renderer_factory, viewer_factory
        self._scene: Any = None
        self._viewer: Any = None

    def __getstate__(self) -> dict[str, Any]:
        """A copy draws with its own renderer (a GL context and a window belong to one
        process and one object), made when it first renders."""
        return {**self.__dict__, "_scene": None, "_viewer": None}

    def _scene_renderer(self) -> Any:
        if self._scene is None:
            # "human": MuJoCo's viewer draws the model itself, no offscreen context needed
            self._scene = self.renderer_factory(self.n_players, *self.size, self.camera,
                                                self.player, self.mode == "rgb_array")
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
            self._viewer = self.viewer_factory(scene.model, scene.data, scene.camera)
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
