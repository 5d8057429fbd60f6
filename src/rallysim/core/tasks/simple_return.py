"""The SIMPLE low-level task over N batched games (docs/reference.md §5-6): goals, rewards, episode
ends, observations. Its Gymnasium views, and the task's full description, are in
``rallysim.envs.simple_return_v0``."""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rallysim.core import native
from rallysim.core.game import Game
from rallysim.core.reach import ShotPlanner
from rallysim.core.serve import FedShots, MachineServe, Serve
from rallysim.core.simple_obs import (
    PLAYER_OBS_CENTRE,
    PLAYER_OBS_SCALE,
    PLAYER_OBS_SIZE,
    TARGET_DEPTH_RANGE,
    observations,
)
from rallysim.core.validation import positive_int, read_options, real_array

OBS_SIZE = PLAYER_OBS_SIZE + 1
# the observation's affine maps: the player's, then normalise_depth's for the goal
OBS_CENTRE = np.append(PLAYER_OBS_CENTRE, 0.5 * sum(TARGET_DEPTH_RANGE))
OBS_SCALE = np.append(PLAYER_OBS_SCALE, 0.5 * (TARGET_DEPTH_RANGE[1] - TARGET_DEPTH_RANGE[0]))
OBS_CENTRE.flags.writeable = OBS_SCALE.flags.writeable = False
ACTION_SIZE = 3
MAX_DECISIONS = 1000
R_HIT = 1.0
SHAPING_GOOD = 0.001
SHAPING_BAD = -0.005
R_DIST_RATE = 0.5
INCOMING = ("serve", "mixed", "rally")
RALLY_SHOT_SHARE = {"mixed": 0.5, "rally": 1.0}  # games served a recorded rally shot
LANDING_KEYS = ("landing_point", "landing_depth", "landing_error", "landed_in")
GOALS = ("uniform", "reachable")
REWARD_OPTIONS = ("returnable", "ready")  # optional reward terms (info: "reward_" + name)


class ReturnTask:
    """The low-level task over N batched games: goals, rewards, ends, observations."""

    def __init__(self, num_envs: int, shuttle: str = "paper", seed: int | None = None,
                 target_depth_range: tuple[float, float] = TARGET_DEPTH_RANGE,
                 max_decisions: int = MAX_DECISIONS, incoming: str = "serve",
                 keep_bodies: bool = False, goals: str = "uniform",
                 returnable: float = 0.0, ready: float = 0.0) -> None:
        if goals not in GOALS:
            raise ValueError(f"unknown goals {goals!r}; valid: {', '.join(map(repr, GOALS))}")
        self.goals = goals
        self.returnable = _weight(returnable, "returnable")
        self.ready = _weight(ready, "ready")
        self._planner = (ShotPlanner() if goals == "reachable" or self.returnable > 0.0
                         else None)
        if incoming not in INCOMING:
            raise ValueError(f"unknown incoming {incoming!r}; valid: "
                             f"{', '.join(map(repr, INCOMING))}")
        self.incoming = incoming
        if not isinstance(keep_bodies, bool | np.bool_):
            raise ValueError(f"keep_bodies must be True or False, got {keep_bodies!r}")
        self.keep_bodies = bool(keep_bodies)
        self._started = np.zeros(num_envs, bool)
        # anything but two real numbers fails the range check below
        lo, hi = (real_array(target_depth_range, "target_depth_range", (2,))
                  if np.shape(target_depth_range) == (2,) else (np.nan, np.nan))
        if not TARGET_DEPTH_RANGE[0] <= lo <= hi <= TARGET_DEPTH_RANGE[1]:
            raise ValueError(f"target_depth_range must lie within {TARGET_DEPTH_RANGE}, got "
                             f"{target_depth_range}")
        positive_int(max_decisions, "max_decisions")
        self.n = num_envs
        self.game = Game(num_envs, 1, shuttle=shuttle, seed=seed,
                         serve=incoming_serve(incoming))
        self.depth_range = (lo, hi)
        self.max_decisions = max_decisions
        self.goal = np.zeros(num_envs)
        self.elapsed = np.zeros(num_envs, np.int64)
        # the ready term's best place: the middle of the base's range
        self._ready_centre = 0.5 * sum(self.game.bodies.base_range)

    @property
    def extra_reward_keys(self) -> tuple[str, ...]:
        """The info keys of the optional reward terms this task gives."""
        return tuple(f"reward_{name}" for name in REWARD_OPTIONS if getattr(self, name) > 0.0)

    def reset(self, envs: np.ndarray, options: dict[str, Any] | None = None) -> None:
        envs = np.asarray(envs, np.int64)
        b, limit = self.game.bodies, self.game.bodies.limit
        given = self.reset_options(options, len(envs))
        # The same draws whatever the options say, so an option changes only what it sets:
        # the start here, the serve's (the game's serve strategy), then the goal.
        streams = self.game.streams
        # (lo + (hi - lo) * u: the bits of NumPy's Generator.uniform(lo, hi) wherever NumPy's C
        # does not fuse it into one FMA, as on x86-64; the goldens were recorded this way)
        u = streams.random(envs, 2)
        (b_lo, b_hi), t_lo = b.base_range, -limit
        base_x = given.get("base_x", b_lo + (b_hi - b_lo) * u[:, 0])
        theta = given.get("arm_angle", t_lo + (limit - t_lo) * u[:, 1])
        # the original builds: robots stay where the last episode left them
        carry = None
        if self.keep_bodies and not given:
            keep = self._started[envs]
            carry = envs[keep]
            base_x[keep], theta[keep] = b.base_x[carry, 0], b.theta[carry, 0]
            omega = b.omega[carry, 0].copy()
        self.game.reset(envs, receiver=0, base_x=base_x[:, None], theta=theta[:, None])
        if carry is not None:
            b.omega[carry, 0] = omega
        self._started[envs] = True
        # (drawn even when the option gives the goal, so that the stream does not shift)
        u = streams.random(envs, 1)[:, 0]
        if self.goals == "uniform":
            d_lo, d_hi = self.depth_range
            drawn = d_lo + (d_hi - d_lo) * u
        else:
            drawn = None if "target_depth" in given else self._reachable_goals(envs, u)
        self.goal[envs] = given.get("target_depth", drawn)
        self.elapsed[envs] = 0

    def _reachable_goals(self, envs: np.ndarray, u: np.ndarray) -> np.ndarray:
        """Goals at the quantiles ``u`` of the depths these serves make reachable
        (``ShotPlanner.reachable_depths``) within the goal range; a serve that reaches none
        of them gets the nearest end of the range, one that reaches no depth at all the
        whole range."""
        lo, hi = self._planner.reachable_depths(self.observe()[envs, :PLAYER_OBS_SIZE])
        none = np.isnan(lo)
        lo = np.clip(np.where(none, self.depth_range[0], lo), *self.depth_range)
        hi = np.clip(np.where(none, self.depth_range[1], hi), *self.depth_range)
        return lo + u * (hi - lo)

    def reset_options(self, options: dict[str, Any] | None, k: int) -> dict[str, np.ndarray]:
        """The given reset options for ``k`` environments, checked (``ValueError``)."""
        if options is None:  # (every autoreset: no specs to build)
            return {}
        b = self.game.bodies
        return read_options(options, {"target_depth": ((k,), TARGET_DEPTH_RANGE),
                                      "base_x": ((k,), b.base_range),
                                      "arm_angle": ((k,), (-b.limit, b.limit))})

    def observe(self, rows: np.ndarray | None = None, out: np.ndarray | None = None
                ) -> np.ndarray:
        """(N, 17) float32 observations; with ``rows`` and ``out`` (an earlier (N, 17)
        observation), only those games' rows, written into ``out``."""
        extra = self.goal.reshape(self.n, 1, 1)
        full = None if out is None else out[:, None]
        return observations(self.game, extra, OBS_CENTRE, OBS_SCALE, rows, full)[:, 0]

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """Advance all N games by one decision with validated, clipped ``actions`` (N, 3):
        rewards, terminated, truncated and info, as (N,) arrays."""
        reward, terminated, truncated, info = self.outcome(actions)
        # Gymnasium's vector convention: "_key" marks the environments where "key" applies.
        info["_racket_speed"] = info["hit"].copy()
        for key in LANDING_KEYS:
            info["_" + key] = info["landed"].copy()
        return reward, terminated.copy(), truncated, info

    def outcome(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """``step``'s values before the vector's info keys: reward, terminated, truncated and
        the info values, as arrays. The event values are the decision's ``Events``' own
        arrays, which the game never writes again."""
        game = self.game
        ev = game.step(actions[:, None, :])
        hit = ev.hit[:, 0]
        returnable = self._returnable_reward(hit) if self.returnable > 0.0 else _NONE
        state, trace = game.state, game.trace
        values = np.empty((7, self.n))
        flags = np.empty((2, self.n), bool)
        _OUTCOME.get()(ev.hit, ev.landed, ev.land_point, ev.land_side, ev.land_in,
                       state.has_hit, state.net_touched, game.bodies.base_x, trace.gap,
                       trace.moved, trace.live, trace.has_hit, self.goal, self.elapsed,
                       self.max_decisions, returnable, self.ready, self._ready_centre, values,
                       flags)
        reward, shaping, hit_reward, landing, depth, error, ready = values
        truncated, landed_in = flags
        info = {"hit": hit, "racket_speed": ev.hit_speed[:, 0], "net_touch": ev.net_touch,
                "landed": ev.landed, "landing_point": ev.land_point, "landing_depth": depth,
                "landing_error": error, "landed_in": landed_in, "target_depth": self.goal.copy(),
                # the reward's terms, which sum to it (Gymnasium's MuJoCo v5 habit)
                "reward_shaping": shaping, "reward_hit": hit_reward, "reward_landing": landing}
        if self.returnable > 0.0:
            info["reward_returnable"] = returnable
        if self.ready > 0.0:
            info["reward_ready"] = ready
        return reward, ev.landed, truncated, info

    def _returnable_reward(self, hit: np.ndarray) -> np.ndarray:
        """``returnable`` for each game whose player has just hit a shot the opponent can meet
        (``ShotPlanner.returnable``), else 0."""
        ok = np.zeros(hit.shape, bool)
        if hit.any():
            idx = np.flatnonzero(hit)
            ok[idx] = self._planner.returnable(self.observe()[idx, :PLAYER_OBS_SIZE])
        return self.returnable * ok


def _weight(value: Any, name: str) -> float:
    if (isinstance(value, bool) or not isinstance(value, int | float | np.number)
            or not 0.0 <= value < np.inf):
        raise ValueError(f"{name} must be a finite reward >= 0, got {value!r}")
    return float(value)


_NONE = np.zeros(0)  # no returnable term


def _outcome(hit, landed, land_point, land_side, land_in, has_hit, net_touched, base_x, gap,
             moved, live, trace_hit, goal, elapsed, max_decisions, returnable, ready,
             ready_centre, values, flags):
    """One decision's outcome in each of N games, after its physics steps (compiled:
    ``_OUTCOME``), into ``values`` (7 x N: reward, its terms shaping, hit and landing, the
    landing's depth and its error, the ready term) and ``flags`` (truncated, landed in);
    counts the decision in ``elapsed``.

    The approach shaping counts, from the game's trace, the physics steps in which player 0's
    base closed in on the shuttle (it moved, and its x-distance to the shuttle shrank) while
    the rally was live and before the player's first hit (``SHAPING_GOOD`` each), and the live
    steps before that hit in which it did not (``SHAPING_BAD`` each). A landing scores
    exp(-``R_DIST_RATE`` x its distance to the goal depth) when it is in the opponent's half,
    after the player's hit, with no net touch since. The terms are added in the order the
    reward lists them; ``returnable`` (empty: no such term) and ``ready`` (0: none) are the
    optional ones."""
    for e in range(goal.shape[0]):
        good = bad = 0
        for s in range(live.shape[0]):
            if live[s, e] and not trace_hit[s, e, 0]:
                if moved[s, e, 0] and gap[s + 1, e, 0] < gap[s, e, 0]:
                    good += 1
                else:
                    bad += 1
        shaping = SHAPING_GOOD * good + SHAPING_BAD * bad
        hit_reward = R_HIT if hit[e, 0] else 0.0
        reward = shaping + hit_reward
        depth = error = np.nan
        landing = 0.0
        landed_in = False
        if landed[e]:
            depth = land_point[e, 0]  # player 0's own frame is the world frame
            error = abs(depth - goal[e])
            landed_in = land_side[e] == 1 and land_in[e]
            if landed_in and has_hit[e, 0] and not net_touched[e]:
                landing = math.exp(-R_DIST_RATE * error)
            reward = reward + landing
        if returnable.size:
            reward = reward + returnable[e]
        near = 0.0
        if ready > 0.0:
            # after its hit, where the player stands at the end of the decision in which the
            # shot lands: the middle of the base's range reaches either end soonest
            if landed[e] and has_hit[e, 0]:
                near = ready * math.exp(-R_DIST_RATE * abs(base_x[e, 0] - ready_centre))
            reward = reward + near
        elapsed[e] += 1
        flags[0, e] = not landed[e] and elapsed[e] >= max_decisions
        flags[1, e] = landed_in
        values[0, e], values[1, e], values[2, e] = reward, shaping, hit_reward
        values[3, e], values[4, e], values[5, e], values[6, e] = landing, depth, error, near


_OUTCOME = native.Kernel(lambda: native.jit(_outcome))


def incoming_serve(incoming: str) -> Serve:
    """What comes over (``incoming``): the machine serve (``"serve"``), or a recorded rally
    shot in its place always (``"rally"``) or half the time (``"mixed"``)."""
    if incoming == "serve":
        return MachineServe()
    return FedShots(RALLY_SHOT_SHARE[incoming])
