"""Turn-based rallies over N batched games (docs/reference.md §8): the high level's semi-Markov
steps.

A turn begins for a player when the opponent hits (or when a rally starts with the serve coming
to it). The player then picks a goal, a landing depth in [2, 6] m, held until its next turn; the
low-level controllers of both players act on their goals every decision until the next turn
begins. One ``step`` covers that whole span and reports its summed reward and its length in
decisions (for gamma^k discounting). Rallies of a batch that reach their next turn early wait
(held still) while the others finish their span.
"""

from __future__ import annotations

import numpy as np

from rallysim.core.tasks.rally import RallyConfig
from rallysim.core.tasks.turn_loop import TurnLoop
from rallysim.players import SIMPLE, PlayerSpec
from rallysim.policies.types import LowLevel


class TurnTask:
    """N rallies of ``player`` (a kind's name or spec; SIMPLE by default) advanced turn by turn;
    the spec's goal says what one goal holds. ``low_level`` is a callable or a name of
    ``rallysim.policies.registry`` (role ``rally_low``). The decisions themselves are
    ``TurnLoop``'s (``self.loop``), shared with recorded videos and the live viewer."""

    def __init__(self, num_rallies: int, low_level: LowLevel | str = "scripted",
                 config: RallyConfig | None = None, seed: int | None = None,
                 player: str | PlayerSpec = SIMPLE) -> None:
        self.loop = TurnLoop.build(player, num_rallies, low_level, config, seed)
        self.rally, self.low_level, self.n = self.loop.rally, self.loop.low_level, num_rallies
        # the loop's own arrays: (N, 2) depths for SIMPLE players, (N, 2, goal_size) where a
        # goal holds more; (N,) the player whose turn it is
        self.goals, self.turn_player = self.loop.goals, self.loop.turn_player

    def seed(self, seeds: list[int]) -> None:
        """Restart rally e's random stream at ``seeds[e]``, and a seedable low level's (such as
        ``"random"``) at ``seeds[0]``, so that ``reset(seed=s)`` replays an episode exactly."""
        self.rally.game.seed_each(seeds)
        if hasattr(self.low_level, "seed") and seeds:
            self.low_level.seed(seeds[0])

    def reset(self, envs: np.ndarray) -> None:
        self.loop.reset(envs)

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
        acted = self.turn_player.copy()
        previous = self.loop.give_goals(goals, np.flatnonzero(running))
        return self._run_span(running, acted, previous)

    def _run_span(self, running: np.ndarray, acted: np.ndarray,
                  previous_goals: np.ndarray) -> dict[str, np.ndarray]:
        """Both players' low levels act on their goals until a turn begins, for the rallies
        marked ``running``."""
        n, loop, rally = self.n, self.loop, self.rally
        out = {
            "reward": np.zeros((n, 2)), "decisions": np.zeros(n, np.int64),
            "terminated": np.zeros(n, bool), "truncated": np.zeros(n, bool),
            "rally_length": rally.game.hits.copy(), "score": rally.score.copy(),
            "hits": np.zeros((n, 2), np.int64), "acted": acted,
        }
        while running.any():
            try:
                actions = loop.low_level_actions(loop.observe())
            except ValueError:
                if not out["decisions"].any():  # refused before anything moved: undo the goals
                    loop.restore_goals(previous_goals)
                raise
            reward, term, trunc, info = loop.step(actions, active=running)
            out["reward"] += reward * running[:, None]
            out["decisions"] += running
            out["hits"] += info["hit"] & running[:, None]
            stop = running & (term | trunc | rally.turn_started.any(axis=1))
            if stop.any():
                s = np.flatnonzero(stop)
                out["terminated"][s], out["truncated"][s] = term[s], trunc[s]
                out["rally_length"][s] = info["rally_length"][s]
                out["score"][s] = info["score"][s]
                running[s] = False
        return out
