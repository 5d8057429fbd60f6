"""The HUMAN-LIKE low-level task over N batched games (docs/reference.md §10): goals, rewards,
episode ends, observations. Its Gymnasium views, and the task's full description, are in
``rallysim.envs.humanlike_return_v0``."""

from __future__ import annotations

from typing import Any

import numpy as np

from rallysim.core.game import Game
from rallysim.core.humanlike import N_ACTIONS, HumanLikeBodies
from rallysim.core.humanlike_obs import PLAYER_OBS_SIZE, TARGET_SCALE, player_observations
from rallysim.core.rules import SERVE_DRAWS
from rallysim.core.serve import HumanLikeServe
from rallysim.core.validation import positive_int, read_options
from rallysim.players.humanlike import sample_targets

OBS_SIZE = PLAYER_OBS_SIZE + 3  # 85
ACTION_SIZE = N_ACTIONS  # 15
MAX_DECISIONS = 1000
R_HIT = 1.0
R_VELOCITY_RATE = 1.5
HIPS_START = np.array([[-4.5, -1.5], [-1.5, 1.5]])  # x and y ranges
MIN_TARGET_SPEED = 0.5  # m/s: a target needs a direction, and the speed error divides by it
HIT_KEYS = ("racket_velocity", "velocity_error", "angle_error", "speed_error")
N_DRAWS = 5  # uniforms one reset draws per environment before its serve's (SERVE below)
# The HUMAN-LIKE serve of docs/reference.md §10 (rallysim.core.serve), drawn after the start's
# uniforms and followed by the machine serve's draws, unused, which keeps v0's seeded episodes.
SERVE = HumanLikeServe(unused_after=SERVE_DRAWS)


class HumanLikeReturnTask:
    """The HUMAN-LIKE low-level task over N batched games: goals, rewards, ends, observations."""

    def __init__(self, num_envs: int, shuttle: str = "paper", seed: int | None = None,
                 max_decisions: int = MAX_DECISIONS) -> None:
        positive_int(max_decisions, "max_decisions")
        self.n = num_envs
        self.bodies = HumanLikeBodies(num_envs, 1)
        self.game = Game(num_envs, 1, shuttle=shuttle, seed=seed, bodies=self.bodies,
                         serve=SERVE)
        self.max_decisions = max_decisions
        self.goal = np.zeros((num_envs, 3))
        self.elapsed = np.zeros(num_envs, np.int64)

    def reset(self, envs: np.ndarray, options: dict[str, Any] | None = None) -> None:
        envs = np.asarray(envs, np.int64)
        k, game = len(envs), self.game
        given = self.reset_options(options, k)
        # One draw per environment from its own stream, whatever the options say, so that
        # an option changes only the value it sets; then the serve's (``SERVE``).
        u = game.streams.random(envs, N_DRAWS)
        lo, hi = HIPS_START[:, 0], HIPS_START[:, 1]
        hips = given.get("hips_position", lo + u[:, 0:2] * (hi - lo))
        self.goal[envs] = given.get("target_velocity", sample_targets(u[:, 2:5]))
        game.reset(envs, receiver=0, base_x=hips[:, :1], theta=0.0, base_y=hips[:, 1:])
        self.elapsed[envs] = 0

    def reset_options(self, options: dict[str, Any] | None, k: int) -> dict[str, np.ndarray]:
        """The given reset options for ``k`` environments, checked (``ValueError``)."""
        if options is None:  # (every autoreset: no specs to build)
            return {}
        given = read_options(options, {
            "target_velocity": ((k, 3), np.array([[-TARGET_SCALE, TARGET_SCALE]] * 3)),
            "hips_position": ((k, 2), self.bodies.hips_range)})
        if "target_velocity" in given:
            slow = np.linalg.norm(given["target_velocity"], axis=1) < MIN_TARGET_SPEED
            if slow.any():
                raise ValueError(f"option 'target_velocity' needs a speed of at least "
                                 f"{MIN_TARGET_SPEED} m/s (its direction is the goal), got "
                                 f"{given['target_velocity'][slow][0].tolist()}")
        return given

    def observe(self, rows: np.ndarray | None = None, out: np.ndarray | None = None
                ) -> np.ndarray:
        """(N, 85) float32 observations, all made anew (``rows`` and ``out``, which the SIMPLE
        task uses to observe only some games again, are not needed here)."""
        obs = np.empty((self.n, OBS_SIZE))
        obs[:, :PLAYER_OBS_SIZE] = player_observations(self.game)[:, 0]
        obs[:, PLAYER_OBS_SIZE:] = self.goal / TARGET_SCALE
        return np.clip(obs, -1.0, 1.0).astype(np.float32)

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """Advance all N games by one decision with validated, clipped ``actions`` (N, 15):
        rewards, terminated, truncated and info, as (N,) (or (N, 3)) arrays."""
        reward, terminated, truncated, info = self.outcome(actions)
        # Gymnasium's vector convention: "_key" marks the environments where "key" applies.
        for key in HIT_KEYS:
            info["_" + key] = info["hit"].copy()
        info["_landing_point"] = info["landed"].copy()
        return reward, terminated.copy(), truncated, info

    def outcome(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """``step``'s values before the vector's info keys, each a new array."""
        ev = self.game.step(actions[:, None, :])
        self.elapsed += 1
        hit, landed = ev.hit[:, 0].copy(), ev.landed.copy()
        if np.count_nonzero(hit):
            reward, values = self._hit_values(hit, ev.hit_velocity[:, 0])
        else:  # rewards and hit values only come with a hit
            n = self.n
            reward = np.zeros(n)
            values = {"racket_velocity": np.full((n, 3), np.nan),
                      "velocity_error": np.full(n, np.nan), "angle_error": np.full(n, np.nan),
                      "speed_error": np.full(n, np.nan), "reward_hit": np.zeros(n),
                      "reward_velocity": np.zeros(n)}
        landing = (np.where(ev.landed[:, None], ev.land_point, np.nan)
                   if np.count_nonzero(landed) else np.full((self.n, 3), np.nan))
        truncated = ~landed & (self.elapsed >= self.max_decisions)
        return reward, landed, truncated, {
            "hit": hit, **values, "net_touch": ev.net_touch.copy(), "landed": landed,
            "landing_point": landing, "target_velocity": self.goal.copy()}

    def _hit_values(self, hit: np.ndarray, velocity: np.ndarray
                    ) -> tuple[np.ndarray, dict[str, np.ndarray]]:
        """Rewards and hit values (NaN without a hit) of (N,) ``hit`` at racket ``velocity``
        (N, 3)."""
        v = np.where(hit[:, None], velocity, np.nan)
        error = np.linalg.norm(v - self.goal, axis=1)
        closeness = np.exp(-R_VELOCITY_RATE * np.nan_to_num(error))
        reward = np.where(hit, 0.5 * (R_HIT + closeness), 0.0)
        speed, goal_speed = np.linalg.norm(v, axis=1), np.linalg.norm(self.goal, axis=1)
        with np.errstate(invalid="ignore", divide="ignore"):
            cos = np.einsum("ij,ij->i", v, self.goal) / (speed * goal_speed)
            angle = np.degrees(np.arccos(np.clip(cos, -1.0, 1.0)))
            speed_error = (speed - goal_speed) / goal_speed
        # the reward's terms, which sum to it (halving is exact)
        terms = {"reward_hit": np.where(hit, 0.5 * R_HIT, 0.0),
                 "reward_velocity": np.where(hit, 0.5 * closeness, 0.0)}
        return reward, {"racket_velocity": v, "velocity_error": error, "angle_error": angle,
                        "speed_error": speed_error, **terms}
