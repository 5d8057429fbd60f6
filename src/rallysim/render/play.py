"""``rallysim play``: watch a rally live in MuJoCo's viewer and take part by keyboard.

The rally is played by the turn loop (``rallysim.envs.turn_loop``), as the turn-based views and
recorded videos play it, for SIMPLE or HUMAN-LIKE players. A person can take over one player:
a SIMPLE player's actions come from the keys; a HUMAN-LIKE player's goals do (its 15 joints
are the learned low level's to move). Keys: ``rallysim.render.keyboard``. The other player (and
both, when nobody is taken over) is driven by the chosen low level with goals from the chosen
high level.

The window: ``rallysim.render.viewer`` (the scene only; the mouse moves the camera, Ctrl+A
returns to the starting view, ``[`` / ``]`` switch to the rendering model's fixed cameras).
"""

from __future__ import annotations

import contextlib
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from rallysim.envs.rally_task import RallyConfig
from rallysim.envs.turn_loop import HighLevel, LowLevel, TurnLoop, rally_core
from rallysim.render.keyboard import Keyboard, keyboard_for
from rallysim.render.markers import goal_markers
from rallysim.render.players import default_camera
from rallysim.render.viewer import launch_viewer

DECISION_SECONDS = 0.1  # one decision of game time: the pace of a real-time window


def play(low_level: LowLevel | str, high_level: HighLevel, human: int | None = None,
         config: RallyConfig | None = None, seed: int = 0, rallies: int = 0,
         viewer_factory: Callable[..., Any] | None = None, realtime: bool = True,
         max_decisions: int | None = None, seconds: float | None = None,
         player: str = "simple", camera: str | None = None) -> list[int]:
    """Run rallies of ``player``'s players (``"simple"`` or ``"humanlike"``) in a live viewer
    until it is closed (or ``rallies`` are played, if > 0, or ``seconds`` of wall-clock time
    have passed, if given).

    ``human`` is the player (0 or 1) the keyboard drives, or None to watch. ``low_level`` (a
    callable or a name the rally core resolves) plays both players, ``high_level`` chooses
    the goals of every player the keyboard does not. Returns the rally lengths (in
    competitive mode: at each game's end). ``viewer_factory(model, data, key_callback)`` opens
    the window (default: ``launch_viewer``, MuJoCo's passive viewer, starting on ``camera``,
    default the player kind's: ``"side"`` for SIMPLE, ``"three_quarter_close"`` for
    HUMAN-LIKE); tests pass a stand-in."""
    from rallysim.render.scene import SceneRenderer

    if seconds is not None and not seconds > 0:  # NaN included: it would never end
        raise ValueError(f"seconds must be > 0, got {seconds}")
    # the rally first: a bad low level's name fails before any window opens
    loop = TurnLoop.build(rally_core(player), 1, low_level, config, seed)
    loop.reset(np.array([0]))
    keyboard = keyboard_for(player)
    # the viewer draws the model itself: no offscreen OpenGL context next to its window's
    scene = SceneRenderer(2, offscreen=False, player=player)
    if viewer_factory is None:
        start_camera = camera or default_camera(player)

        def viewer_factory(model: Any, data: Any, key_callback: Callable[[int], None]) -> Any:
            return launch_viewer(model, data, start_camera, key_callback)

    viewer = viewer_factory(scene.model, scene.data, keyboard.press)
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
            _, term, trunc, _ = _decide(loop, high_level, keyboard, human)
            decisions += 1
            if term[0] or trunc[0]:
                lengths.append(int(loop.rally.game.hits[0]))
                loop.reset(np.array([0]))
                scene.reset_trail()
            _show(viewer, scene, loop)
            if realtime:
                time.sleep(max(0.0, DECISION_SECONDS - (time.perf_counter() - start)))
    finally:
        viewer.close()
        scene.close()
    return lengths


def _decide(loop: TurnLoop, high_level: HighLevel, keyboard: Keyboard, human: int | None,
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """One decision of the turn loop with the person's part in it: the goal its keys set
    (HUMAN-LIKE), or the action (SIMPLE)."""
    obs = loop.observe()
    steers_goals = human is not None and keyboard.steers_goals
    loop.choose_goals(high_level, obs, skip=human if steers_goals else None)
    if steers_goals:
        loop.set_goal(0, human, keyboard.goal())
    actions = loop.low_level_actions(obs)
    if human is not None and not keyboard.steers_goals:
        actions[0, human] = keyboard.action()
    return loop.step(actions)


def _show(viewer: Any, scene: Any, loop: TurnLoop) -> None:
    """Copy the rally into the world the viewer draws, hand the viewer the targets drawn per
    frame (HUMAN-LIKE's arrows) and the shuttle's trail (not bodies of the model: decor in the
    viewer's own scene), and draw."""
    # MuJoCo's viewer reads the data and its scene on its own thread; stand-ins for it in
    # tests may have neither a lock nor a scene.
    lock = getattr(viewer, "lock", None)
    task = loop.rally
    with lock() if lock is not None else contextlib.nullcontext():
        scene.set_state(task.game, 0, **goal_markers(task.player, loop.goals[0]))
        user_scn = getattr(viewer, "user_scn", None)
        if user_scn is not None:
            user_scn.ngeom = 0
            scene.draw_markers(user_scn)
            scene.trail.draw(user_scn)
    viewer.sync()
