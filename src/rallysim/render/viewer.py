"""MuJoCo's passive viewer opened on a rendering model: the window of ``rallysim play`` and of
the env views' ``render_mode="human"``.

The window shows the scene only (MuJoCo's interface panels hidden: Tab and Shift+Tab show them)
through the viewer's free camera, placed on one of ``CAMERAS``' views; the mouse moves it,
Ctrl+A (the viewer's "align") returns to that view, and ``[`` / ``]`` switch to the rendering
model's fixed cameras.
"""

from __future__ import annotations

import math
import threading
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from rallysim.render.model import CAMERAS, fit_cameras

VIEWER_CAMERA = "side"
# The window shape the free camera's field of view is fitted to before the window exists
# (MuJoCo opens it at two thirds of the screen, so it has the screen's shape: mostly 16:10 or
# 16:9); other shapes are then fitted by the camera's distance.
DEFAULT_ASPECT = 16 / 10


def frame_free_camera(model: Any, camera: str = VIEWER_CAMERA) -> None:
    """Make ``model``'s default free camera the view of ``CAMERAS[camera]`` (fitted to a
    ``DEFAULT_ASPECT`` window), for a viewer about to open on ``model``.

    MuJoCo's viewer draws through a free camera, which a passive viewer leaves at MuJoCo's
    generic default (2 m from the world origin, looking down at 45 degrees: at the net, where
    that shows nothing but the floor). ``mujoco.mjv_defaultFreeCamera``, also the viewer's
    "align", derives the camera from ``vis.global_`` and ``stat``, set here. The viewer takes
    these from the model as it opens and writes its own copy back on its first sync, so they
    must be set before it opens. The clipping planes scale with ``stat.extent`` too: the
    court's size suits them better than the hall's. Only for a model a viewer draws: an
    offscreen renderer's fixed cameras would clip differently."""
    pose = CAMERAS[camera]
    offset = np.subtract(pose.target, pose.eye)
    distance = float(np.linalg.norm(offset))
    forward = offset / distance
    model.vis.global_.fovy = pose.fovy(DEFAULT_ASPECT)
    model.vis.global_.azimuth = math.degrees(math.atan2(forward[1], forward[0]))
    model.vis.global_.elevation = math.degrees(math.asin(forward[2]))
    model.stat.center[:] = pose.target
    model.stat.extent = distance / 1.5  # mjv_defaultFreeCamera stands 1.5 extents away


class ViewerWindow:
    """MuJoCo's passive viewer handle (every attribute of ``mujoco.viewer.Handle`` is passed
    through), whose ``close`` also waits for the window to be gone.

    The viewer runs on threads of its own; ``Handle.close`` only asks them to stop. A process
    that exits right after it runs GLFW's clean-up (``glfw.terminate``, registered at exit) while
    the viewer's thread still tears its window down, and crashes (a segmentation fault)."""

    JOIN_SECONDS = 5.0  # a window closes in well under a second; never hang on a stuck one

    def __init__(self, handle: Any, threads: list[threading.Thread]) -> None:
        self._handle, self._threads = handle, threads

    def __getattr__(self, name: str) -> Any:
        return getattr(self._handle, name)

    def close(self) -> None:
        self._handle.close()
        deadline = time.monotonic() + self.JOIN_SECONDS
        for thread in self._threads:
            thread.join(max(0.0, deadline - time.monotonic()))


def launch_viewer(model: Any, data: Any, camera: str = VIEWER_CAMERA,
                  key_callback: Callable[[int], None] | None = None) -> Any:
    """Open MuJoCo's passive viewer on ``model`` / ``data`` with the scene filling the window
    (interface panels hidden) and the free camera on ``CAMERAS[camera]``'s view, fitted to the
    window. Returns the viewer's handle."""
    import mujoco
    import mujoco.viewer

    frame_free_camera(model, camera)
    before = set(threading.enumerate())
    handle = mujoco.viewer.launch_passive(model, data, key_callback=key_callback,
                                          show_left_ui=False, show_right_ui=False)
    viewer = ViewerWindow(handle, [t for t in threading.enumerate() if t not in before])
    rect = viewer.viewport
    aspect = rect.width / rect.height if rect is not None and rect.height > 0 else DEFAULT_ASPECT
    pose = CAMERAS[camera]
    with viewer.lock():
        fit_cameras(model, aspect)
        mujoco.mjv_defaultFreeCamera(model, viewer.cam)
        # the field of view is fixed by now: move closer or back until the span fits
        fovy = math.radians(model.vis.global_.fovy)
        viewer.cam.distance *= (math.tan(math.radians(pose.fovy(aspect)) / 2.0)
                                / math.tan(fovy / 2.0))
    # no sync here: the viewer draws through this camera itself, and the caller's first sync
    # brings the state it sets
    return viewer
