"""``rallysim play``: watch a rally live in MuJoCo's viewer and take over a player by keyboard.

Keys (the viewer passes key presses, not holds, so each key sets a state that persists):

| key | effect |
|---|---|
| right / left arrow | walk toward the net / away from it; press the other way to stop |
| up / down arrow | raise / lower the arm's target angle by 15 degrees |
| space | swing: full force to +85 degrees for 0.3 s, then back to the held angle |
| F / G | weaker / stronger arm (force action -0.5 / +1) |

The other player (and both, when nobody is taken over) is driven by the chosen low level with
goals from the chosen high level.

The window opens on the whole court from the side, MuJoCo's interface panels hidden (Tab and
Shift+Tab show them); the mouse moves the camera, Ctrl+A (the viewer's "align") returns to the
side view, and ``[`` / ``]`` switch to the rendering model's fixed cameras.
"""

from __future__ import annotations

import contextlib
import math
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from rallysim.envs.rally_task import RALLY_OBS_SIZE, RallyConfig, RallyTask
from rallysim.envs.turn_task import LowLevel
from rallysim.render.model import CAMERAS, fit_cameras

KEY_RIGHT, KEY_LEFT, KEY_DOWN, KEY_UP, KEY_SPACE, KEY_F, KEY_G = 262, 263, 264, 265, 32, 70, 71
STEP_DEGREES = 15.0
SWING_DECISIONS = 3
VIEWER_CAMERA = "side"
# The window shape the free camera's field of view is fitted to before the window exists
# (MuJoCo opens it at two thirds of the screen, so it has the screen's shape: mostly 16:10 or
# 16:9); other shapes are then fitted by the camera's distance.
DEFAULT_ASPECT = 16 / 10


@dataclass
class KeyboardPlayer:
    """Keyboard state of a taken-over SIMPLE player, turned into its action each decision."""

    move: float = 0.0
    angle_deg: float = -45.0
    force: float = 1.0
    swing_left: int = 0

    def press(self, key: int) -> None:
        if key == KEY_RIGHT:
            self.move = 0.0 if self.move < 0 else 1.0
        elif key == KEY_LEFT:
            self.move = 0.0 if self.move > 0 else -1.0
        elif key == KEY_UP:
            self.angle_deg = min(85.0, self.angle_deg + STEP_DEGREES)
        elif key == KEY_DOWN:
            self.angle_deg = max(-85.0, self.angle_deg - STEP_DEGREES)
        elif key == KEY_SPACE:
            self.swing_left = SWING_DECISIONS
        elif key == KEY_F:
            self.force = -0.5
        elif key == KEY_G:
            self.force = 1.0

    def action(self) -> np.ndarray:
        """(target orientation, force, movement) for this decision."""
        if self.swing_left > 0:
            self.swing_left -= 1
            return np.array([1.0, 1.0, self.move])
        return np.array([self.angle_deg / 85.0, self.force, self.move])


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


def play(low_level: LowLevel, high_level: Callable[[np.ndarray], np.ndarray],
         human: int | None = None, config: RallyConfig | None = None, seed: int = 0,
         rallies: int = 0, viewer_factory: Callable[..., Any] | None = None,
         realtime: bool = True, max_decisions: int | None = None,
         seconds: float | None = None) -> list[int]:
    """Run rallies in a live viewer until it is closed (or ``rallies`` are played, if > 0, or
    ``seconds`` of wall-clock time have passed, if given).

    ``human`` is the player (0 or 1) the keyboard drives, or None to watch. Returns the rally
    lengths. ``viewer_factory(model, data, key_callback)`` opens the window (default:
    ``launch_viewer``, MuJoCo's passive viewer); tests pass a stand-in."""
    from rallysim.render.scene import SceneRenderer

    if seconds is not None and not seconds > 0:  # NaN included: it would never end
        raise ValueError(f"seconds must be > 0, got {seconds}")
    keyboard = KeyboardPlayer()
    # the viewer draws the model itself: no offscreen OpenGL context next to its window's
    scene = SceneRenderer(2, offscreen=False)
    if viewer_factory is None:
        def viewer_factory(model: Any, data: Any, key_callback: Callable[[int], None]) -> Any:
            return launch_viewer(model, data, VIEWER_CAMERA, key_callback)

    viewer = viewer_factory(scene.model, scene.data, keyboard.press)
    task = RallyTask(1, config, seed=seed)
    task.reset(np.array([0]))
    goals = np.full(2, 4.0)
    lengths: list[int] = []
    decisions = 0
    began = time.perf_counter()
    try:
        while viewer.is_running() and (rallies <= 0 or len(lengths) < rallies):
            if max_decisions is not None and decisions >= max_decisions:
                break
            start = time.perf_counter()
            if seconds is not None and start - began >= seconds:
                break
            obs = task.observe()[0]
            starting = task.turn_started[0]
            if starting.any():
                goals[starting] = high_level(obs[starting])
            actions = np.clip(low_level(obs.reshape(2, RALLY_OBS_SIZE), goals), -1.0, 1.0)
            if human is not None:
                actions[human] = keyboard.action()
            _, term, trunc, _ = task.step(actions.reshape(1, 2, 3))
            decisions += 1
            if term[0] or trunc[0]:
                lengths.append(int(task.game.hits[0]))
                task.reset(np.array([0]))
                scene.reset_trail()
            _show(viewer, scene, task, goals)
            if realtime:
                time.sleep(max(0.0, 0.1 - (time.perf_counter() - start)))
    finally:
        viewer.close()
        scene.close()
    return lengths


def _show(viewer: Any, scene: Any, task: RallyTask, goals: np.ndarray) -> None:
    """Copy the rally into the world the viewer draws, hand the viewer the shuttle's trail (not
    a body of the model: per-frame decor in the viewer's own scene), and draw."""
    # MuJoCo's viewer reads the data and its scene on its own thread; stand-ins for it in
    # tests may have neither a lock nor a scene.
    lock = getattr(viewer, "lock", None)
    with lock() if lock is not None else contextlib.nullcontext():
        scene.set_state(task.game, 0, list(goals))
        user_scn = getattr(viewer, "user_scn", None)
        if user_scn is not None:
            user_scn.ngeom = 0
            scene.trail.draw(user_scn)
    viewer.sync()
