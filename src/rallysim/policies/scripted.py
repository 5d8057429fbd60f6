"""A scripted SIMPLE player: returns the shuttle toward a goal depth from observations alone.

It predicts the shuttle with the paper flight model in closed form, picks the hit elevation
whose full-speed shot lands at the goal from where the shuttle will be met, walks the base under
that point, winds the arm up and swings through it at full speed. Batched: one call acts for N
players. It reads only the 16-value player observation, so it drives the low-level task and
either side of a rally.
"""

from __future__ import annotations

import numpy as np

from rallysim.core.bodies import SimpleBodies
from rallysim.core.game import PHYSICS_DT, PHYSICS_STEPS_PER_DECISION
from rallysim.core.reach import PlayerState, ShotPlanner
from rallysim.core.simple_obs import PLAYER_OBS

DECISION = PHYSICS_DT * PHYSICS_STEPS_PER_DECISION


class ScriptedController(ShotPlanner):
    """``controller(observations (N, >=16), goals (N,)) -> actions (N, 3)``; its geometry and
    flight prediction are ``ShotPlanner``'s."""

    def __init__(self, elevations_deg: tuple[float, float] = (8.0, 60.0), n_elevations: int = 27,
                 contact_lead: float = 0.1) -> None:
        super().__init__(elevations_deg, n_elevations, contact_lead)
        self.max_target = SimpleBodies.max_target_angle

    def __call__(self, observations: np.ndarray, goals: np.ndarray) -> np.ndarray:
        state = PlayerState.from_observations(observations)
        base_x, theta, vel = state.base_x, state.theta, state.vel
        n = len(base_x)
        m = self.meetings(state)
        t_hit, base_needed, depth = m.t_hit, m.base_needed, m.depth
        cost = np.abs(depth - np.asarray(goals)[:, None])
        # Prefer meetings the base can make, then the goal; a meeting on the far side is void.
        cost = cost + 100.0 * ~m.makeable + np.where(m.usable, 0.0, np.inf)
        best = cost.argmin(axis=1)
        rows = np.arange(n)
        tau = t_hit[rows, best]  # seconds until the face centre should pass the shuttle
        target_base = np.clip(base_needed[rows, best], *self.base_range)
        align = self.align[best]

        actions = np.zeros((n, 3))
        actions[:, 2] = np.clip((target_base - base_x) / (self.base_speed * DECISION), -1, 1)
        # Wind up so that a full-speed swing begun at a decision boundary reaches ``align`` at
        # the meeting. The swing is given at least half a decision (0.35 rad) of run-up, so the
        # waiting face sits clear of the shuttle's path instead of catching it at rest.
        remainder = tau - DECISION * np.floor((tau - 1e-9) / DECISION)
        run_up = np.where(remainder < 0.5 * DECISION, remainder + DECISION, remainder)
        windup = np.clip(align - self.rate * run_up, -self.limit, self.limit)
        swing_now = tau <= run_up + 1e-9
        coming = np.isfinite(cost[rows, best]) & (vel[:, 0] < 0.0)  # heading for this player
        target = np.where(swing_now, self.max_target, windup)
        target = np.where(coming, target, theta)
        actions[:, 0] = target / self.max_target
        actions[:, 1] = np.where(coming, 1.0, -0.5)
        actions[:, 2] = np.where(coming, actions[:, 2], 0.0)
        return np.clip(actions, -1.0, 1.0)

    def act_return(self, observations: np.ndarray) -> np.ndarray:
        """Act in ``RallySim/SimpleReturn-v0`` (N, 17) observations: the scaled goal depth
        follows the player's observation."""
        obs = np.asarray(observations)
        goals = obs[:, PLAYER_OBS.size] * 2.0 + 4.0
        return self(obs, goals)

