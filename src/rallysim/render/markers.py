"""What a player's goal looks like in the picture: the ``SceneRenderer`` target argument of each
player kind's goals, from the kind's render rig (``rallysim.render.players``).

SIMPLE goals are landing depths, drawn as they are (red discs on the floor). A HUMAN-LIKE goal
is the turn-based view's three values in [-1, 1], which the low level reads as a target racket
velocity: that velocity is drawn (a red arrow from the racket head).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rallysim.render.players import rig_class


def goal_markers(player: str, goals: np.ndarray) -> dict[str, Any]:
    """``SceneRenderer.render`` / ``set_state`` keyword arguments drawing one rally's goals
    (2, *goal shape), one per player, of a ``player`` kind."""
    return rig_class(player).goal_markers(goals)


def target_markers(player: str, target: Any) -> dict[str, Any]:
    """The same for a low-level task's own target (a depth, or a velocity in m/s)."""
    return rig_class(player).target_markers(target)
