"""The competitive game from one player's seat, turn by turn: the league's training env.

N batched games under badminton scoring (``RallyConfig(mode="competitive")``). The learner is
player ``g % 2`` in game ``g`` (both sides of the court, both first serves). Each ``step`` is
one of the learner's turns: its action (in [-1, 1], mapped onto a goal by the player's goal
mapping; SIMPLE: a landing depth of 4 + 2a m) is held while its frozen low level swings toward
it, and the opponent (an agent of ``rallysim.eval.agents``: a hierarchical or a Monolithic
player, frozen) plays its own turns inside the span, until the learner's next turn begins.

- Observation: the learner's rally observation (20 values for SIMPLE), in its own frame.
- Reward: the points of the span, +1 won and -1 lost.
- Episode: one game (21 points, won by 2, capped at 30), ``terminated`` at its end;
  ``truncated`` once it has run ``max_decisions`` decisions (lets between players who never
  miss would replay for ever).
- Opponents: each game draws its opponent when it starts, from ``opponents`` with
  probabilities ``weights`` (``set_opponents`` changes them for the games that start next).
- ``info``: ``points_won``, ``points_lost``, ``decisions`` of the span; at a game's end
  ``score`` (learner, opponent) and ``opponent`` (its index in the list it was drawn from).

``CompeteDecisionVectorEnv`` is the same game for a flat (Monolithic) learner, which acts
every decision: one step is one decision, the action the player's motor action. What both
share (the games, the opponents and their draws, the points counted) is ``CompeteSeat``.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any

import numpy as np
from gymnasium import spaces

from rallysim.core.tasks.rally import RallyConfig, RallyTask
from rallysim.core.validation import positive_int
from rallysim.envs.vector_base import SAME_STEP, NativeVectorEnv
from rallysim.players import SIMPLE, PlayerSpec
from rallysim.policies.registry import resolve
from rallysim.policies.types import Agent, LowLevel


class CompeteSeat(NativeVectorEnv):
    """The learner's seat in N competitive games against frozen opponents drawn per game: the
    games, the opponents, the points counted. Subclasses say how the learner acts."""

    metadata = {"render_modes": [], "autoreset_mode": SAME_STEP}
    player_spec: PlayerSpec = SIMPLE

    def _setup_seat(self, num_envs: int, opponents: Sequence[Agent],
                    weights: Sequence[float] | None, seed: int | None, autoreset_mode: str,
                    max_decisions: int, shuttle: str, action_size: int) -> None:
        self._setup(num_envs, autoreset_mode)
        self.max_decisions = positive_int(max_decisions, "max_decisions")
        spec = self.player_spec
        n = self.num_units
        self.task = RallyTask(n, RallyConfig(shuttle=shuttle, mode="competitive"), seed, spec)
        self.side = np.arange(n) % 2
        self.elapsed = np.zeros(n, np.int64)
        self.rng = np.random.default_rng(seed)
        self._resumed_rng: dict[str, Any] | None = None
        self.opponent_of = np.zeros(n, np.int64)  # each game's opponent: its index ...
        self._agent_of: list[Agent | None] = [None] * n  # ... and the agent itself
        self._started: dict[int, Agent] = {}  # agents started on this env, by id
        self.set_opponents(opponents, weights)
        self.decisions_simulated = 0
        self._tally = np.zeros(2, np.int64)  # points won, lost since take_tally()
        obs_size = spec.rally_obs.size
        self.single_observation_space = spaces.Box(-1.0, 1.0, (obs_size,), np.float32)
        self.single_action_space = spaces.Box(-1.0, 1.0, (action_size,), np.float32)
        self.observation_space = spaces.Box(-1.0, 1.0, (n, obs_size), np.float32)
        self.action_space = spaces.Box(-1.0, 1.0, (n, action_size), np.float32)

    # -- opponents ------------------------------------------------------------------------------
    def set_opponents(self, opponents: Sequence[Agent],
                      weights: Sequence[float] | None = None) -> None:
        """The agents that games starting from now are drawn from, with ``weights``
        (default: equal). Games under way keep the opponent they drew."""
        opponents = list(opponents)
        if not opponents:
            raise ValueError("need at least one opponent")
        w = np.ones(len(opponents)) if weights is None else np.asarray(weights, np.float64)
        if w.shape != (len(opponents),) or not np.all(np.isfinite(w)) or (w < 0).any() \
                or w.sum() <= 0:
            raise ValueError(f"weights must be {len(opponents)} non-negative finite numbers "
                             f"with a positive sum, got {weights!r}")
        # an agent keeps its per-game state (held goals) while games against it go on: only
        # agents new to this env start afresh; the dict pins them, so no id is reused
        in_use = {id(a) for a in self._agent_of}
        self._started = {k: a for k, a in self._started.items() if k in in_use}
        for agent in opponents:
            if id(agent) not in self._started:
                agent.start(self.num_units)
                self._started[id(agent)] = agent
        self.opponents, self.weights = opponents, w / w.sum()

    def take_tally(self) -> np.ndarray:
        """Points (won, lost) by the learner since the last call."""
        tally, self._tally = self._tally, np.zeros(2, np.int64)
        return tally

    def _draw_opponents(self, units: np.ndarray) -> None:
        picks = self.rng.choice(len(self.opponents), size=len(units), p=self.weights)
        for u, k in zip(units.tolist(), picks.tolist(), strict=True):
            self._agent_of[u] = self.opponents[k]
            self.opponent_of[u] = k

    # -- NativeVectorEnv ------------------------------------------------------------------------
    def _seed_units(self, seeds: list[int]) -> None:
        self.task.game.seed_each(seeds)
        self.rng = np.random.default_rng(seeds[0])
        if self._resumed_rng is not None:  # a resumed run's opponent stream goes on
            self.rng.bit_generator.state = self._resumed_rng
            self._resumed_rng = None

    def resume_opponent_stream(self, state: dict[str, Any]) -> None:
        """Continue the opponent draws from ``state`` (a saved ``rng.bit_generator.state``),
        now and after the next seeded reset (a resumed trainer's first reset reseeds)."""
        self.rng.bit_generator.state = state
        self._resumed_rng = state

    def _observe(self) -> np.ndarray:
        return self.task.observe()[np.arange(self.num_units), self.side]

    # -- one decision ---------------------------------------------------------------------------
    def _decide(self, running: np.ndarray, actions: np.ndarray,
                learner: Callable[[np.ndarray, np.ndarray], np.ndarray]
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """One decision of the games ``running``, their actions written into ``actions``
        (N, 2, action_size): the learner's ``learner(observations, rows)`` for the running
        rows, each opponent's by its agent. Returns the games that ended, and the points the
        learner won and lost."""
        task = self.task
        rows = np.flatnonzero(running)
        me, opponent = self.side, 1 - self.side
        obs = task.observe()
        actions[rows, me[rows]] = learner(obs[rows, me[rows]], rows)
        for agent, members in self._groups(rows):
            s = opponent[members]
            actions[members, s] = agent.act(obs[members, s], task.turn_started[members, s],
                                            members)
        _, over, _, info = task.step(np.clip(actions, -1.0, 1.0), active=running)
        self.elapsed += running
        winner = info["point_winner"]
        scored = running & (winner >= 0)
        return over, scored & (winner == me), scored & (winner != me)

    def _result(self, won: np.ndarray, lost: np.ndarray, decisions: np.ndarray,
                term: np.ndarray, trunc: np.ndarray
                ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """A step's reward (points won - lost), ends and info; counts the points and
        decisions."""
        n = self.num_units
        self.decisions_simulated += int(decisions.sum())
        self._tally += [int(won.sum()), int(lost.sum())]
        info = {"points_won": won, "points_lost": lost, "decisions": decisions,
                "score": np.stack([self.task.score[np.arange(n), self.side],
                                   self.task.score[np.arange(n), 1 - self.side]], axis=1),
                "opponent": self.opponent_of.copy()}
        return (won - lost).astype(np.float64), term, trunc, info

    def _groups(self, rows: np.ndarray) -> list[tuple[Agent, np.ndarray]]:
        """The games of ``rows`` grouped by the agent they play against, in a fixed order."""
        order: dict[int, list[int]] = {}
        for r in rows.tolist():
            order.setdefault(id(self._agent_of[r]), []).append(r)
        return [(self._agent_of[m[0]], np.array(m)) for m in order.values()]


class CompeteTurnVectorEnv(CompeteSeat):
    """The learner's turns of N competitive games against frozen opponents (see the module)."""

    def __init__(self, num_envs: int, opponents: Sequence[Agent],
                 weights: Sequence[float] | None = None, low_level: LowLevel | str = "pretrained",
                 seed: int | None = None, autoreset_mode: str = "same_step",
                 max_decisions: int = 20_000, shuttle: str = "paper",
                 player_spec: PlayerSpec = SIMPLE) -> None:
        self.player_spec = spec = player_spec
        self._setup_seat(num_envs, opponents, weights, seed, autoreset_mode, max_decisions,
                         shuttle, spec.goal.size)
        self.low = resolve(low_level, "rally_low", spec)
        self.goals = np.empty((self.num_units, *spec.goal.shape))
        self.goals[:] = spec.goal.default

    def _reset_units(self, units: np.ndarray, options: dict | None) -> None:
        self.task.reset(units)
        self.goals[units] = self.player_spec.goal.default
        self.elapsed[units] = 0
        self._draw_opponents(units)
        # play until the learner's first turn (the opponent may receive the first serve)
        self._advance(units, fresh=True)

    def _step_units(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        from rallysim.core.validation import validate_actions

        a = validate_actions(actions, (self.num_envs, self.player_spec.goal.size))
        units = np.setdiff1d(np.arange(self.num_units), self._pending)
        goals = self.player_spec.goal.from_action(a)
        self.goals[units] = goals[units].reshape(self.goals[units].shape)
        return self._advance(units)

    # -- the span -------------------------------------------------------------------------------
    def _advance(self, units: np.ndarray, fresh: bool = False,
                 ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """Play games ``units`` until the learner's turn begins, the game ends or its decision
        limit is reached; ``fresh`` games stop at once if the serve comes to the learner."""
        n, task = self.num_units, self.task
        running = np.zeros(n, bool)
        running[units] = True
        won = np.zeros(n, np.int64)
        lost = np.zeros(n, np.int64)
        decisions = np.zeros(n, np.int64)
        term = np.zeros(n, bool)
        trunc = np.zeros(n, bool)
        me = np.arange(n), self.side
        actions = np.zeros((n, 2, task.action_size))
        if fresh:
            running &= ~task.turn_started[me]
        while running.any():
            over, w, lo = self._decide(running, actions,
                                       lambda obs, rows: self.low(obs, self.goals[rows]))
            decisions += running
            won += w
            lost += lo
            term |= running & over
            trunc |= running & ~over & (self.elapsed >= self.max_decisions)
            running &= ~(over | task.turn_started[me] | trunc)
        return self._result(won, lost, decisions, term, trunc)


class CompeteDecisionVectorEnv(CompeteSeat):
    """N competitive games against frozen opponents for a flat learner that acts every
    decision: the action is the player's motor action (SIMPLE: 3 values in [-1, 1]), and one
    step is one decision of every game (see the module)."""

    def __init__(self, num_envs: int, opponents: Sequence[Agent],
                 weights: Sequence[float] | None = None, seed: int | None = None,
                 autoreset_mode: str = "same_step", max_decisions: int = 20_000,
                 shuttle: str = "paper") -> None:
        self._setup_seat(num_envs, opponents, weights, seed, autoreset_mode, max_decisions,
                         shuttle, self.player_spec.action.size)

    def _reset_units(self, units: np.ndarray, options: dict | None) -> None:
        self.task.reset(units)
        self.elapsed[units] = 0
        self._draw_opponents(units)

    def _step_units(self, actions: Any) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        from rallysim.core.validation import validate_actions

        n = self.num_units
        a = validate_actions(actions, (self.num_envs, self.player_spec.action.size))
        running = np.ones(n, bool)
        running[self._pending] = False
        over, won, lost = self._decide(running, np.zeros((n, 2, self.task.action_size)),
                                       lambda obs, rows: a[rows])
        trunc = running & ~over & (self.elapsed >= self.max_decisions)
        return self._result(won.astype(np.int64), lost.astype(np.int64),
                            running.astype(np.int64), running & over, trunc)
