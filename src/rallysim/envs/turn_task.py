"""Turn-based rallies over N batched games (SPEC §8): the high level's semi-Markov steps.

A turn begins for a player when the opponent hits (or when a rally starts with the serve coming
to it). The player then picks a goal, a landing depth in [2, 6] m, held until its next turn; the
low-level controllers of both players act on their goals every decision until the next turn
begins. One ``step`` covers that whole span and reports its summed reward and its length in
decisions (for gamma^k discounting). Rallies of a batch that reach their next turn early wait
(held still) while the others finish their span.
"""

from __future__ import annotations

import numpy as np

from rallysim.envs.rally_task import RallyConfig, RallyTask
from rallysim.policies.registry import resolve
from rallysim.policies.types import LowLevel


class TurnTask:
    """N rallies advanced turn by turn. ``rally`` is the rally core's class (``RallyTask`` for
    SIMPLE players); its ``goal_size`` says what one goal holds. ``low_level`` is a callable
    or a name of ``rallysim.policies.registry`` (role ``rally_low``)."""

    def __init__(self, num_rallies: int, low_level: LowLevel | str = "scripted",
                 config: RallyConfig | None = None, seed: int | None = None,
                 rally: type[RallyTask] = RallyTask) -> None:
        self.rally = rally(num_rallies, config, seed)
        self.low_level = resolve(low_level, "rally_low", rally.spec, seed)
        self.n = num_rallies
        # (N, 2) depths for SIMPLE players; (N, 2, goal_size) where a goal holds more
        self.goals = np.empty((num_rallies, 2, *np.shape(rally.default_goal)))
        self.goals[:] = rally.default_goal
        self.turn_player = np.zeros(num_rallies, np.int64)

    def seed(self, seeds: list[int]) -> None:
        """Restart rally e's random stream at ``seeds[e]``, and a seedable low level's (such as
        ``"random"``) at ``seeds[0]``, so that ``reset(seed=s)`` replays an episode exactly."""
        self.rally.game.seed_each(seeds)
        if hasattr(self.low_level, "seed") and seeds:
            self.low_level.seed(seeds[0])

    def reset(self, envs: np.ndarray) -> None:
        envs = np.asarray(envs, np.int64)
        self.rally.reset(envs)
        self.goals[envs] = self.rally.default_goal
        self.turn_player[envs] = self.rally.turn_started[envs].argmax(axis=1)

    def observe(self) -> np.ndarray:
        """(N, obs_size) observation of each rally's turn player, in its own frame."""
        return self.rally.observe()[np.arange(self.n), self.turn_player]

    def step(self, goals: np.ndarray, envs: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """Give each turn player of ``envs`` (default: all) its goal and run to the next turn.

        Returns per rally: ``reward`` (N, 2) summed over the span, ``decisions`` (N,),
        ``terminated``, ``truncated``, ``rally_length``, ``score`` (N, 2), ``hits`` (N, 2) in the
        span, and ``acted`` (N,), the player whose goal was set."""
        n = self.n
        running = np.zeros(n, bool)
        running[np.arange(n) if envs is None else np.asarray(envs)] = True
        rows = np.flatnonzero(running)
        acted = self.turn_player.copy()
        shape = (n, *self.goals.shape[2:])
        goals = self.rally.clip_goals(np.broadcast_to(np.asarray(goals, np.float64), shape))
        previous = self.goals.copy()
        self.goals[rows, acted[rows]] = goals[rows]
        return self._run_span(running, acted, previous)

    def _run_span(self, running: np.ndarray, acted: np.ndarray,
                  previous_goals: np.ndarray) -> dict[str, np.ndarray]:
        """Both players' low levels act on their goals until a turn begins, for the rallies
        marked ``running``."""
        n, rally = self.n, self.rally
        out = {
            "reward": np.zeros((n, 2)), "decisions": np.zeros(n, np.int64),
            "terminated": np.zeros(n, bool), "truncated": np.zeros(n, bool),
            "rally_length": rally.game.hits.copy(), "score": rally.score.copy(),
            "hits": np.zeros((n, 2), np.int64), "acted": acted,
        }
        flat_goals = self.goals.reshape((2 * n, *self.goals.shape[2:]))
        while running.any():
            obs = rally.observe().reshape(2 * n, rally.obs_size)
            try:
                actions = self._low_level_actions(obs, flat_goals)
            except ValueError:
                if not out["decisions"].any():  # refused before anything moved: undo the goals
                    self.goals[:] = previous_goals
                raise
            reward, term, trunc, info = rally.step(actions, active=running)
            out["reward"] += reward * running[:, None]
            out["decisions"] += running
            out["hits"] += info["hit"] & running[:, None]
            new_turn = rally.turn_started.any(axis=1)
            stop = running & (term | trunc | new_turn)
            if stop.any():
                s = np.flatnonzero(stop)
                out["terminated"][s], out["truncated"][s] = term[s], trunc[s]
                out["rally_length"][s] = info["rally_length"][s]
                out["score"][s] = info["score"][s]
                turn = s[new_turn[s]]
                self.turn_player[turn] = rally.turn_started[turn].argmax(axis=1)
                running[s] = False
        return out

    def _low_level_actions(self, obs: np.ndarray, goals: np.ndarray) -> np.ndarray:
        """The low level's actions (N, 2, action_size), clipped; a wrong shape or a non-finite
        value raises ``ValueError`` naming the low level (a damaged policy must not play on)."""
        n, size = self.n, self.rally.action_size
        actions = np.asarray(self.low_level(obs, goals))
        if actions.shape != (2 * n, size):
            raise ValueError(f"the low level {self.low_level!r} returned actions of shape "
                             f"{actions.shape}, expected {(2 * n, size)}")
        # not validate_actions: that casts to float64, and the bodies' arithmetic keeps a
        # policy's float32 (the seeded episodes would change)
        if actions.dtype.kind not in "fiu" or not np.isfinite(actions).all():
            raise ValueError(f"the low level {self.low_level!r} returned non-finite or "
                             "non-real actions")
        return np.clip(actions, -1.0, 1.0).reshape(n, 2, size)
