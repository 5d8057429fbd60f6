"""The two-player rally over N batched games (docs/reference.md §7): observations, turns, rewards,
ends.

Shared by every rally view (PettingZoo parallel, the slot vector env, the turn-based views).

Cooperative mode (the paper): +0.2 to both players on every hit; one episode is one rally, ending
when the shuttle lands (terminated) or at the 50-hit cap (truncated).

Competitive mode: badminton scoring. A rally ends in a point for the player whose opponent failed
to return the shuttle in: a shuttle landing in a player's half (in bounds) is that player's
fault; one landing out is the last hitter's. The point's winner gets +1, the loser -1, and serves
the next rally (the machine serve of docs/reference.md §4.3, from the winner's side). A game goes
to 21 points, won by 2, capped at 30; one episode is one game. A rally reaching the hit cap is
replayed (a let).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from rallysim.core import rules
from rallysim.core.game import Game
from rallysim.core.simple_obs import POSITION_CENTRE, POSITION_SCALE
from rallysim.players import SIMPLE, PlayerSpec

MODES = ("cooperative", "competitive")
# the maps of what the rally adds to a player's observation: the opponent's position (as
# every position is observed), then "my turn" (armed: 1 or 0)
EXTRA_CENTRE = np.append(POSITION_CENTRE, 0.0)
EXTRA_SCALE = np.append(POSITION_SCALE, 1.0)


@dataclass(frozen=True)
class RallyConfig:
    """Rules of a rally game; defaults are the paper's (docs/reference.md §7)."""

    shuttle: str = "paper"
    mode: str = "cooperative"
    max_hits: int = 50
    hit_reward: float = 0.2
    max_decisions: int = 5000  # a stall guard per rally; rallies end long before
    points_to_win: int = 21
    win_by: int = 2
    max_points: int = 30

    def __post_init__(self) -> None:
        from rallysim.core.shuttle import check_shuttle_name
        from rallysim.core.validation import positive_int

        for name in ("max_hits", "max_decisions", "points_to_win", "win_by", "max_points"):
            positive_int(getattr(self, name), name)
        if (isinstance(self.hit_reward, bool) or not isinstance(self.hit_reward, int | float)
                or not np.isfinite(self.hit_reward)):
            raise ValueError(f"hit_reward must be a finite number, got {self.hit_reward!r}")
        check_shuttle_name(self.shuttle)
        if self.mode not in MODES:
            valid = ", ".join(map(repr, MODES))
            raise ValueError(f"unknown mode {self.mode!r}; valid modes: {valid}")
        if not 1 <= self.points_to_win <= self.max_points or self.win_by < 1:
            raise ValueError("need 1 <= points_to_win <= max_points and win_by >= 1")

    @classmethod
    def from_kwargs(cls, kwargs: dict[str, Any], view_args: Iterable[str] = ()) -> RallyConfig:
        """The rules from a view's keyword arguments. An unknown name raises ``TypeError`` in
        Python's own wording (clients such as TorchRL's ``GymEnv`` retry without an optional
        argument on exactly that error) and lists every valid name: the view's own
        ``view_args`` and the rules' fields."""
        from rallysim.core.validation import check_keywords

        valid = [f.name for f in fields(cls)]
        check_keywords(kwargs, valid, [*view_args, *valid])
        return cls(**kwargs)


class RallyTask:
    """N rallies (or competitive games) of two players of the kind ``spec``
    (``rallysim.players``: SIMPLE by default).

    What differs between player kinds comes from the spec: sizes, the goal, the bodies, the
    start pose, the serve, the observation and the opponent's position; the rules are the same
    for every kind."""

    def __init__(self, num_rallies: int, config: RallyConfig | None = None,
                 seed: int | None = None, spec: PlayerSpec = SIMPLE) -> None:
        self.config = config = config or RallyConfig()
        self.spec = spec
        self.n = num_rallies
        # The net rule (re-arm both players, or block for the aero shuttle) is the game's
        # rules.Rules, derived from the shuttle model.
        self.game = Game(num_rallies, 2, shuttle=config.shuttle, seed=seed,
                         bodies=spec.make_bodies(num_rallies, 2), serve=spec.serve,
                         max_hits=config.max_hits)
        self.competitive = config.mode == "competitive"
        n = num_rallies
        self.elapsed = np.zeros(n, np.int64)  # decisions in the current rally
        self.score = np.zeros((n, 2), np.int64)
        # the machine serve of docs/reference.md §4.3 goes to player 0
        self.server = np.ones(n, np.int64)
        self.turn_started = np.zeros((n, 2), bool)

    @property
    def player(self) -> str:
        return self.spec.name

    @property
    def obs_size(self) -> int:
        return self.spec.rally_obs.size

    @property
    def action_size(self) -> int:
        return self.spec.action.size

    @property
    def default_goal(self) -> float | tuple[float, ...]:
        """One goal, in its own shape."""
        return self.spec.goal.default

    # -- episodes -------------------------------------------------------------------------------
    def reset(self, envs: np.ndarray) -> None:
        """New episodes: a fresh rally (cooperative) or a fresh game at 0-0 (competitive)."""
        envs = np.asarray(envs, np.int64)
        self.score[envs] = 0
        self.server[envs] = 1
        self._start_rally(envs)

    def _start_rally(self, envs: np.ndarray) -> None:
        """Place both players at the spec's start pose and serve toward the receiver
        (docs/reference.md §7, §4.3; the serve is the spec's strategy)."""
        receiver = 1 - self.server[envs]
        k, start = len(envs), self.spec.start
        # base_y only for bodies that have that freedom
        body = {} if start.base_y is None else {"base_y": np.broadcast_to(start.base_y, (k, 2))}
        self.game.reset(envs, receiver=receiver, theta=0.0,
                        base_x=np.broadcast_to(start.base_x, (k, 2)), **body)
        self.elapsed[envs] = 0
        self.turn_started[envs] = False
        self.turn_started[envs, receiver] = True

    def clip_goals(self, goals: np.ndarray) -> np.ndarray:
        """The turn-based view's goals as finite values clipped into the goal range (SIMPLE:
        depths in [2, 6] m); NaN or inf raise ``ValueError``."""
        return self.spec.goal.clip(goals)

    # -- views ----------------------------------------------------------------------------------
    def observe(self) -> np.ndarray:
        """(N, 2, obs_size) float32 observations, each in its player's own frame, in [-1, 1]:
        the player's own, the opponent's base position, and "my turn" (armed)."""
        g = self.game
        extra = np.empty((self.n, 2, 4))
        extra[..., :3] = self.spec.opponent(g)
        extra[..., 3] = g.armed
        return self.spec.observe_with(g, extra, EXTRA_CENTRE, EXTRA_SCALE)

    # -- one decision ---------------------------------------------------------------------------
    def step(self, actions: np.ndarray, active: np.ndarray | None = None):
        """Advance the rallies by one decision with clipped ``actions`` (N, 2, action_size).

        Returns ``(rewards (N, 2), terminated (N,), truncated (N,), info)``. In competitive mode a
        finished point that does not end the game starts the next rally at once; ``info`` tells
        what happened, ``self.turn_started`` whose turn began during this decision."""
        g, cfg = self.game, self.config
        live = np.ones(self.n, bool) if active is None else active
        ev = g.step(actions, active)
        self.elapsed += live
        self.turn_started[:] = False
        hit_any = ev.hit.any(axis=1)
        # a player's turn begins when the opponent hits (net re-arming is no new turn)
        self.turn_started[:, 0] = ev.hit[:, 1]
        self.turn_started[:, 1] = ev.hit[:, 0]
        landed = ev.landed
        capped = live & ~landed & ((g.hits >= cfg.max_hits) | (self.elapsed >= cfg.max_decisions))
        rally_length = g.hits.copy()  # (the state: the next rally resets it)
        info = {
            "hit": ev.hit,
            "racket_speed": ev.hit_speed,
            "hit_point": ev.hit_point,
            "net_touch": ev.net_touch,
            "landed": landed,
            "landing_point": ev.land_point,
            "landing_side": np.where(landed, ev.land_side, -1),
            "landed_in": landed & ev.land_in,
            "rally_length": rally_length,
            "rally_over": landed | capped,
            "point_winner": np.full(self.n, -1),
            "score": self.score.copy(),
        }
        if not self.competitive:
            rewards = np.repeat((cfg.hit_reward * hit_any)[:, None], 2, axis=1)
            return rewards, landed, capped, info

        rewards = np.zeros((self.n, 2))
        game_over = np.zeros(self.n, bool)
        if landed.any():
            e = np.flatnonzero(landed)
            winner = rules.point_winner(ev.land_side[e], ev.land_in[e], g.last_hitter[e],
                                        self.server[e])
            loser = 1 - winner
            self.score[e, winner] += 1
            rewards[e, winner] = 1.0
            rewards[e, loser] = -1.0
            info["point_winner"][e] = winner
            info["score"] = self.score.copy()
            game_over[e] = self._game_over(e)
            self.server[e] = winner
        # next rallies: after a point that did not end the game, and after a let (the cap)
        again = np.flatnonzero((landed & ~game_over) | capped)
        if len(again):
            self._start_rally(again)
        return rewards, game_over, np.zeros(self.n, bool), info

    def _game_over(self, envs: np.ndarray) -> np.ndarray:
        cfg = self.config
        return rules.game_over(self.score[envs], cfg.points_to_win, cfg.win_by, cfg.max_points)

