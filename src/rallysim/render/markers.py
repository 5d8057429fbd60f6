"""What a player's goal looks like in the picture: the ``SceneRenderer`` target argument of each
player kind's goals.

SIMPLE goals are landing depths, drawn as they are (red discs on the floor). A HUMAN-LIKE goal
is the turn-based view's three values in [-1, 1], which the low level reads as a target racket
velocity: that velocity is drawn (a red arrow from the racket head).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rallysim.players.humanlike import targets_from_goals


def goal_markers(player: str, goals: np.ndarray) -> dict[str, Any]:
    """``SceneRenderer.render`` / ``set_state`` keyword arguments drawing one rally's goals
    (2, *goal shape), one per player, of a ``player`` kind (``"simple"`` or ``"humanlike"``)."""
    if player == "simple":
        return {"target_depth": list(goals)}
    if player == "humanlike":
        return {"target_velocity": targets_from_goals(np.asarray(goals))}
    raise ValueError(f"no goal markers for player kind {player!r}")


def target_markers(player: str, target: Any) -> dict[str, Any]:
    """The same for a low-level task's own target (a depth, or a velocity in m/s)."""
    return {"target_depth" if player == "simple" else "target_velocity": target}
