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
"""

from __future__ import annotations

import time
from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from rallysim.envs.rally_task import RALLY_OBS_SIZE, RallyConfig, RallyTask
from rallysim.envs.turn_task import LowLevel

KEY_RIGHT, KEY_LEFT, KEY_DOWN, KEY_UP, KEY_SPACE, KEY_F, KEY_G = 262, 263, 264, 265, 32, 70, 71
STEP_DEGREES = 15.0
SWING_DECISIONS = 3


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


def play(low_level: LowLevel, high_level: Callable[[np.ndarray], np.ndarray],
         human: int | None = None, config: RallyConfig | None = None, seed: int = 0,
         rallies: int = 0, viewer_factory: Callable[..., Any] | None = None,
         realtime: bool = True, max_decisions: int | None = None) -> list[int]:
    """Run rallies in a live viewer until it is closed (or ``rallies`` are played, if > 0).

    ``human`` is the player (0 or 1) the keyboard drives, or None to watch. Returns the rally
    lengths. ``viewer_factory(model, data, key_callback)`` opens the window (default: MuJoCo's
    passive viewer); tests pass a stand-in."""
    from rallysim.render.scene import SceneRenderer

    keyboard = KeyboardPlayer()
    scene = SceneRenderer(2, 64, 64)
    if viewer_factory is None:
        import mujoco.viewer

        def viewer_factory(model: Any, data: Any, key_callback: Callable[[int], None]) -> Any:
            return mujoco.viewer.launch_passive(model, data, key_callback=key_callback)

    viewer = viewer_factory(scene.model, scene.data, keyboard.press)
    task = RallyTask(1, config, seed=seed)
    task.reset(np.array([0]))
    goals = np.full(2, 4.0)
    lengths: list[int] = []
    decisions = 0
    try:
        while viewer.is_running() and (rallies <= 0 or len(lengths) < rallies):
            if max_decisions is not None and decisions >= max_decisions:
                break
            start = time.perf_counter()
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
            lock = getattr(viewer, "lock", None)  # MuJoCo's viewer reads data on its own thread
            if lock is None:
                scene.set_state(task.game, 0, list(goals))
            else:
                with lock():
                    scene.set_state(task.game, 0, list(goals))
            viewer.sync()
            if realtime:
                time.sleep(max(0.0, 0.1 - (time.perf_counter() - start)))
    finally:
        viewer.close()
        scene.close()
    return lengths
