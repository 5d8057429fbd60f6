"""The two-player rally of HUMAN-LIKE players: ``RallyTask``'s rules with 3-D bodies.

Everything about the rally (turns, arming, landing, cooperative and competitive scoring) is
``RallyTask``'s; this class supplies the HUMAN-LIKE parts: the bodies, the start and serve, the
observation, and the goal a turn-based high level gives the low level.

- Start: both players' hips at own-frame (-2.7, 0), joints at the zero pose, at rest.
- Serve: the low-level task's HUMAN-LIKE serve (SPEC §10) toward the receiver, from its far side.
- Observation (86): the low-level task's 82 player values, the opponent's hips position in
  the player's own frame (3), "my turn" (1: this player's racket is armed).
- Goal (turn-based view): three values in [-1, 1] mapped onto the low level's target range,
  (speed, elevation, azimuth) = (1.5 + 1.5 (g0 + 1), 40 + 5 (g1 + 1) deg, 30 g2 deg).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np

from rallysim.core.humanlike import N_ACTIONS, HumanLikeBodies
from rallysim.envs.humanlike_obs import PLAYER_OBS_SIZE, player_observations
from rallysim.envs.humanlike_return_v0 import TARGET_SCALE, sample_targets
from rallysim.envs.rally_task import RallyTask, _finite_goals

START_HIPS = (-2.7, 0.0)  # own frame, both players
LowLevel = Callable[[np.ndarray, np.ndarray], np.ndarray]


def targets_from_goals(goals: np.ndarray) -> np.ndarray:
    """Goals (M, 3) in [-1, 1] -> target racket velocities (M, 3), m/s, own frame."""
    return sample_targets(0.5 * (np.clip(goals, -1.0, 1.0) + 1.0))


def low_level_observations(obs: np.ndarray, goals: np.ndarray) -> np.ndarray:
    """Rally observations (M, 86) and goals (M, 3) -> the low-level task's (M, 85)."""
    out = np.empty((len(obs), PLAYER_OBS_SIZE + 3), np.float32)
    out[:, :PLAYER_OBS_SIZE] = obs[:, :PLAYER_OBS_SIZE]
    out[:, PLAYER_OBS_SIZE:] = np.clip(targets_from_goals(goals) / TARGET_SCALE, -1.0, 1.0)
    return out


def goal_conditioned(policy: Callable[[np.ndarray], np.ndarray]) -> LowLevel:
    """A low-level policy of ``HumanLikeReturn-v0`` (85 observations) as a rally low level."""
    from rallysim.policies.callables import GoalConditioned

    return GoalConditioned(policy, low_level_observations)


class HumanLikeRallyTask(RallyTask):
    """N rallies (or competitive games) of two HUMAN-LIKE players."""

    player = "humanlike"
    obs_size = PLAYER_OBS_SIZE + 4  # 86
    action_size = N_ACTIONS  # 15
    goal_size = 3
    default_goal = (0.0, 0.0, 0.0)  # 3 m/s at 45 degrees, straight over the net

    def _bodies(self, n: int) -> Any:
        return HumanLikeBodies(n, 2)

    def _serve(self, envs: np.ndarray, receiver: np.ndarray) -> None:
        """Place both players at the start; the game's serve (``core.serve.rally_serve``: the
        HUMAN-LIKE serve) goes toward ``receiver``."""
        k = len(envs)
        self.game.reset(envs, receiver=receiver, base_x=np.full((k, 2), START_HIPS[0]),
                        theta=0.0, base_y=np.full((k, 2), START_HIPS[1]))

    def _player_observations(self) -> np.ndarray:
        return player_observations(self.game)

    def _opponent_position(self) -> np.ndarray:
        hips = self.game.bodies.hips_position()  # (N, 2, 3), each in its own frame
        opp = hips[:, ::-1].copy()
        opp[..., :2] *= -1.0  # the opponent's own frame turned 180 degrees about z
        return opp

    @staticmethod
    def clip_goals(goals: np.ndarray) -> np.ndarray:
        """Goals as finite values clipped to [-1, 1]."""
        return np.clip(_finite_goals(goals), -1.0, 1.0)

    @staticmethod
    def resolve_low_level(low_level: LowLevel | str, seed: int | None = None) -> LowLevel:
        """A batched ``(observations (M, 86), goals (M, 3)) -> actions (M, 15)`` callable.

        Strings: ``"scripted"`` (``AimedSwing``), ``"random"``, ``"pretrained"`` or the path
        prefix of an exported ``HumanLikeReturn-v0`` policy."""
        if callable(low_level):
            return low_level
        if low_level == "scripted":
            from rallysim.policies.aimed_swing import AimedSwing

            return goal_conditioned(AimedSwing())
        if low_level == "random":
            from rallysim.policies.callables import UniformRandom

            return UniformRandom(N_ACTIONS, seed)
        if isinstance(low_level, str):
            from rallysim.policies.resolve import humanlike_low_level

            return goal_conditioned(humanlike_low_level(low_level))
        raise ValueError(f"unknown low_level {low_level!r}; pass a callable "
                         "(observations, goals) -> actions, 'scripted', 'random', "
                         "'pretrained' or a policy path prefix")
