"""The turn loop of a hierarchical rally (docs/reference.md §8), written once for every player kind
and every driver: the turn-based views (``TurnTask``), recorded videos and the live viewer
(``rallysim.render.record``, ``rallysim.render.play``).

Each decision: a player whose turn has just begun (the opponent hit, or the serve is coming to
it) gets a goal from its high level and holds it until its next turn; both players' low levels
act toward their current goals; the rally advances one decision. ``TurnLoop`` keeps the goals
and runs that decision over N batched rallies. It knows a player kind only through the rally's
player spec (``default_goal``, ``clip_goals``, ``obs_size``, ``action_size``), so the same loop
plays SIMPLE and HUMAN-LIKE rallies.

Who picks a goal is the driver's business: a turn-based view takes it as its agent's action
(``give_goals``), a recording or a viewer asks a high-level callable (``choose_goals``).
"""

from __future__ import annotations

from typing import Any

import numpy as np

from rallysim.core.tasks.rally import RallyConfig, RallyTask
from rallysim.players import PlayerSpec, get_player
from rallysim.policies.registry import resolve
from rallysim.policies.types import HighLevel, LowLevel


class TurnLoop:
    """N rallies of ``rally`` (a ``RallyTask``) whose players' low level ``low_level`` (a
    batched callable) acts toward each player's held goal.

    ``goals`` is (N, 2) for one-value goals (SIMPLE's landing depths), (N, 2, goal size)
    otherwise; ``turn_player`` (N,) is the player whose turn began last in each rally."""

    def __init__(self, rally: RallyTask, low_level: LowLevel) -> None:
        self.rally, self.low_level, self.n = rally, low_level, rally.n
        self.goals = np.empty((rally.n, 2, *np.shape(rally.default_goal)))
        self.goals[:] = rally.default_goal
        self.turn_player = np.zeros(rally.n, np.int64)

    @classmethod
    def build(cls, player: str | PlayerSpec, n: int, low_level: LowLevel | str,
              config: RallyConfig | None = None, seed: int | None = None) -> TurnLoop:
        """A loop over ``n`` new rallies of ``player`` (a kind's name or spec); ``low_level`` is
        a callable or a name of ``rallysim.policies.registry`` (role ``rally_low``, seeded with
        ``seed``). An unknown kind raises ``ValueError``."""
        spec = get_player(player)
        return cls(RallyTask(n, config, seed, spec), resolve(low_level, "rally_low", spec, seed))

    @property
    def goal_shape(self) -> tuple[int, ...]:
        """The shape of one goal: () for a depth, (goal size,) otherwise."""
        return self.goals.shape[2:]

    # -- episodes -------------------------------------------------------------------------------
    def reset(self, envs: np.ndarray) -> None:
        """New episodes for ``envs``: the rally core's reset, every goal back to the default."""
        envs = np.asarray(envs, np.int64)
        self.rally.reset(envs)
        self.goals[envs] = self.rally.default_goal
        self.turn_player[envs] = self.rally.turn_started[envs].argmax(axis=1)

    # -- goals ----------------------------------------------------------------------------------
    def give_goals(self, goals: Any, envs: np.ndarray) -> np.ndarray:
        """The turn players of rallies ``envs`` take ``goals`` (one per rally, N rows or one
        goal broadcast; clipped by the rally core, NaN raises ``ValueError`` before anything
        changes). Returns the goals as they were, for ``restore_goals``."""
        shape = (self.n, *self.goal_shape)
        clipped = self.rally.clip_goals(np.broadcast_to(np.asarray(goals, np.float64), shape))
        previous = self.goals.copy()
        rows = np.asarray(envs, np.int64)
        self.goals[rows, self.turn_player[rows]] = clipped[rows]
        return previous

    def restore_goals(self, previous: np.ndarray) -> None:
        self.goals[:] = previous

    def set_goal(self, env: int, player: int, goal: Any) -> None:
        """Player ``player`` of rally ``env`` takes ``goal`` (clipped) now, whether or not its
        turn has begun: a goal steered live, as a person at the keyboard does."""
        self.goals[env, player] = self.rally.clip_goals(np.asarray(goal, np.float64))

    def choose_goals(self, high_level: HighLevel, obs: np.ndarray,
                     skip: int | None = None) -> np.ndarray:
        """Each player whose turn has just begun takes a goal from ``high_level``, which gets
        those players' observations (M, obs_size) in rally order and returns M goals. ``skip``
        names a player whose goals come from elsewhere (a person at the keyboard). Returns the
        (N, 2) mask of players who chose."""
        starting = self.rally.turn_started.copy()
        if skip is not None:
            starting[:, skip] = False
        if starting.any():
            chosen = np.asarray(high_level(obs[starting]))
            target = self.goals[starting]
            self.goals[starting] = self.rally.clip_goals(chosen.reshape(target.shape))
        return starting

    # -- one decision ---------------------------------------------------------------------------
    def observe(self) -> np.ndarray:
        """(N, 2, obs_size) both players' observations, each in its own frame."""
        return self.rally.observe()

    def low_level_actions(self, obs: np.ndarray) -> np.ndarray:
        """The low level's actions (N, 2, action_size) for observations ``obs`` (N, 2,
        obs_size) and the held goals, clipped to [-1, 1]; a wrong shape or a non-finite value
        raises ``ValueError`` naming the low level (a damaged policy must not play on)."""
        n, size = self.n, self.rally.action_size
        flat_obs = obs.reshape(2 * n, self.rally.obs_size)
        flat_goals = self.goals.reshape((2 * n, *self.goal_shape))
        actions = np.asarray(self.low_level(flat_obs, flat_goals))
        if actions.shape != (2 * n, size):
            raise ValueError(f"the low level {self.low_level!r} returned actions of shape "
                             f"{actions.shape}, expected {(2 * n, size)}")
        # not validate_actions: that casts to float64, and the bodies' arithmetic keeps a
        # policy's float32 (the seeded episodes would change)
        if actions.dtype.kind not in "fiu" or not np.isfinite(actions).all():
            raise ValueError(f"the low level {self.low_level!r} returned non-finite or "
                             "non-real actions")
        return np.clip(actions, -1.0, 1.0).reshape(n, 2, size)

    def step(self, actions: np.ndarray, active: np.ndarray | None = None,
             ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
        """Advance the rallies (those ``active``, default all) one decision with ``actions``
        (N, 2, action_size); ``turn_player`` follows the turns that began. Returns the rally
        core's ``(rewards, terminated, truncated, info)``."""
        out = self.rally.step(actions, active=active)
        began = self.rally.turn_started.any(axis=1)
        if active is not None:
            began &= active
        if began.any():
            rows = np.flatnonzero(began)
            self.turn_player[rows] = self.rally.turn_started[rows].argmax(axis=1)
        return out
