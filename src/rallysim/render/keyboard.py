"""Keyboard players of ``rallysim play``: key presses turned into a player's actions (SIMPLE) or
into its goals (HUMAN-LIKE).

MuJoCo's viewer passes key presses, not holds, so each key sets a state that persists.

SIMPLE (``KeyboardPlayer``): the keys are the player's three actions.

| key | effect |
|---|---|
| right / left arrow | walk toward the net / away from it; press the other way to stop |
| up / down arrow | raise / lower the arm's target angle by 15 degrees |
| space | swing: full force to +85 degrees for 0.3 s, then back to the held angle |
| F / G | weaker / stronger arm (force action -0.5 / +1) |

HUMAN-LIKE (``KeyboardGoals``): nobody steers 15 joints by hand, so the keys choose the
player's goal, the racket velocity its high level would choose, and the learned low level
moves the body and swings toward it. The goal is the turn-based view's (``Box(-1, 1, (3,))``:
speed 1.5-4.5 m/s, elevation 40-50 degrees, azimuth -30-30 degrees), changed in steps of
``GOAL_STEP`` and in force at once, not only from the next turn.

| key | effect |
|---|---|
| up / down arrow | faster / slower racket (0.375 m/s a press) |
| left / right arrow | aim to the player's left / right (7.5 degrees a press) |
| G / F | steeper / flatter (2.5 degrees a press) |
| space | back to the centre goal: 3 m/s at 45 degrees, straight over the net |
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import ClassVar, Protocol

import numpy as np

from rallysim.players import SIMPLE

KEY_RIGHT, KEY_LEFT, KEY_DOWN, KEY_UP, KEY_SPACE, KEY_F, KEY_G = 262, 263, 264, 265, 32, 70, 71
STEP_DEGREES = 15.0
SWING_DECISIONS = 3
GOAL_STEP = 0.25  # goal units a key press moves: 8 presses span a component's [-1, 1]


@dataclass
class KeyboardPlayer:
    """Keyboard state of a taken-over SIMPLE player, turned into its action each decision."""

    steers_goals: ClassVar[bool] = False  # the keys replace the low level's action

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


@dataclass
class KeyboardGoals:
    """Keyboard state of a HUMAN-LIKE player whose goal a person chooses: ``goal()`` is the
    (speed, elevation, azimuth) goal in [-1, 1] the keys have set."""

    steers_goals: ClassVar[bool] = True  # the keys replace the high level's goal

    value: np.ndarray = field(default_factory=lambda: np.zeros(3))

    _KEYS: ClassVar[dict[int, tuple[int, float]]] = {
        KEY_UP: (0, GOAL_STEP), KEY_DOWN: (0, -GOAL_STEP),
        KEY_G: (1, GOAL_STEP), KEY_F: (1, -GOAL_STEP),
        # azimuth turns toward the player's own +y, its left as it faces the net
        KEY_LEFT: (2, GOAL_STEP), KEY_RIGHT: (2, -GOAL_STEP),
    }

    def press(self, key: int) -> None:
        if key == KEY_SPACE:
            self.value = np.zeros(3)
        elif key in self._KEYS:
            index, step = self._KEYS[key]
            self.value = self.value.copy()
            self.value[index] = np.clip(self.value[index] + step, -1.0, 1.0)

    def goal(self) -> np.ndarray:
        return self.value.copy()


class Keyboard(Protocol):
    """What ``rallysim play`` asks of a player kind's keyboard player (its rig's ``keyboard``):
    key presses, then each decision ``goal()`` if it ``steers_goals`` (the keys set the goal the
    low level swings for), else ``action()`` (the keys replace the low level's action)."""

    steers_goals: ClassVar[bool]

    def press(self, key: int) -> None: ...


class KeyboardAgent:
    """A person at the keyboard as a competitive agent (the ``Agent`` protocol of
    ``rallysim.eval.agents``): a SIMPLE player whose action every decision is the keys'
    (``KeyboardPlayer.action``), so ``rallysim.eval.competitive.Match`` plays a person against
    any agent as it plays two agents. One person plays one game."""

    def __init__(self, keyboard: KeyboardPlayer | None = None, name: str = "you") -> None:
        self.keyboard = KeyboardPlayer() if keyboard is None else keyboard
        self.name, self.player = name, SIMPLE

    def start(self, n: int) -> None:
        if n != 1:
            raise ValueError(f"a person at the keyboard plays one game, not {n}")

    def act(self, obs: np.ndarray, started: np.ndarray, rows: np.ndarray) -> np.ndarray:
        if not len(rows):  # no live game: no decision, a swing keeps its decisions
            return np.zeros((0, 3))
        # one action per decision: a swing counts its decisions down in action()
        return self.keyboard.action()[None, :].repeat(len(rows), axis=0)
