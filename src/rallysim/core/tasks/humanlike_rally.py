"""The two-player rally of HUMAN-LIKE players: ``RallyTask``'s rules with 3-D bodies.

Everything about the rally (turns, arming, landing, cooperative and competitive scoring) is
``RallyTask``'s; the HUMAN-LIKE parts (sizes, goal, observation) come from its player spec
(``rallysim.players.HUMANLIKE``), and this class supplies the bodies and the serve:

- Start: both players' hips at own-frame (-2.7, 0), joints at the zero pose, at rest.
- Serve: the low-level task's HUMAN-LIKE serve (SPEC §10) toward the receiver, from its far side.
- Observation (86): the low-level task's 82 player values, the opponent's hips position in
  the player's own frame (3), "my turn" (1: this player's racket is armed).
- Goal (turn-based view): three values in [-1, 1] mapped onto the low level's target range,
  (speed, elevation, azimuth) = (1.5 + 1.5 (g0 + 1), 40 + 5 (g1 + 1) deg, 30 g2 deg).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rallysim.core.tasks.rally import RallyTask
from rallysim.players import HUMANLIKE, PlayerSpec

START_HIPS = (HUMANLIKE.start.base_x[0], HUMANLIKE.start.base_y[0])  # own frame, both players


class HumanLikeRallyTask(RallyTask):
    """N rallies (or competitive games) of two HUMAN-LIKE players."""

    spec: PlayerSpec = HUMANLIKE
    player = spec.name
    obs_size = spec.rally_obs.size  # 86
    action_size = spec.action.size  # 15
    goal_size = spec.goal.size
    default_goal = spec.goal.default  # 3 m/s at 45 degrees, straight over the net

    def _bodies(self, n: int) -> Any:
        return self.spec.make_bodies(n, 2)

    def _serve(self, envs: np.ndarray, receiver: np.ndarray) -> None:
        """Place both players at the start; the game's serve (``spec.serve``: the
        HUMAN-LIKE serve) goes toward ``receiver``."""
        k = len(envs)
        self.game.reset(envs, receiver=receiver, base_x=np.full((k, 2), START_HIPS[0]),
                        theta=0.0, base_y=np.full((k, 2), START_HIPS[1]))

    def _opponent_position(self) -> np.ndarray:
        hips = self.game.bodies.hips_position()  # (N, 2, 3), each in its own frame
        opp = hips[:, ::-1].copy()
        opp[..., :2] *= -1.0  # the opponent's own frame turned 180 degrees about z
        return opp
