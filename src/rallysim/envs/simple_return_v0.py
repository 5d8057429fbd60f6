"""``RallySim/SimpleReturn-v0``: the SIMPLE low-level task (SPEC §5-6).

One SIMPLE player stands at x < 0. A machine serve comes over the net; the player must hit it so
that it lands ``target_depth`` metres beyond the net. One hit per episode; the episode ends when
the shuttle lands.

## Action space: ``Box(-1, 1, (3,), float32)``
| index | name | effect |
|---|---|---|
| 0 | target orientation | arm target angle = 85 deg * a0 (0 = upright, + leans toward the net) |
| 1 | force | torque limit of the arm's servo = 15 * (a1 + 1) / 2 N m |
| 2 | movement | base velocity = 5 * a2 m/s along x, base centre kept in [-6.5, -1.0] m |

Actions outside [-1, 1] are clipped; NaN, inf or a wrong shape raise ``ValueError``.
The action is held for the 5 physics steps (0.02 s each) of one decision (0.1 s).

## Observation space: ``Box(-1, 1, (17,), float32)``
Indices 0-15 are the player observation of ``rallysim.envs.simple_obs`` (base position, arm
quaternion, racket face velocity, shuttle position and velocity, all own-frame and scaled);
index 16 is the target depth, (d* - 4) / 2. Values are clipped into the bounds.

## Rewards (summed over the decision's physics steps)
| term | value |
|---|---|
| shaping, each physics step before the hit | +0.001 if the base moved and its x-distance to the shuttle shrank, else -0.005 |
| hit | +1 |
| landing, if hit, no net touch since the hit, and in the opponent court | exp(-0.5 * abs(depth - d*)) |

## Starting state
The serve of SPEC §4.3 (toward this player). The base starts at x ~ U[-6.5, -1.0] and the arm
at an angle ~ U[-85, 85] deg (the original never reset its robots, so they started wherever the
previous episode left them; ours draws that from the seed). The goal d* ~ U[2, 6] m.

## Episode end
Terminates when the shuttle's centre drops below z = 0; truncates after 1000 decisions.

## Arguments
| argument | default | meaning |
|---|---|---|
| ``shuttle`` | ``"paper"`` | flight model: ``"paper"``, ``"paper-alg1"`` or ``"aero"`` |
| ``target_depth_range`` | ``(2.0, 6.0)`` | goals are drawn uniformly from this range |
| ``max_decisions`` | ``1000`` | truncation |
| ``keep_bodies`` | ``False`` | ``True``: like the original builds, a new episode starts with the player where the last one left it (the first from a random start); reset options still place it |
| ``goals`` | ``"uniform"`` | ``"uniform"``: d* ~ U[range]; ``"reachable"`` (the default of ``-v1``): d* uniform over the depths a full-speed shot from a meeting the player can make reaches (``rallysim.core.reach.ShotPlanner``, the paper flight model), within the range: the nearest end of the range when the serve reaches none of it, the whole range when it reaches no depth |
| ``incoming`` | ``"serve"`` | what comes over: the machine serve (the paper); ``"rally"``: a shot drawn from 4,096 recorded rally shots (scripted players aiming at 2-6 m); ``"mixed"``: either, half the time each |

``reset(options=...)`` accepts ``target_depth`` (metres, in [2, 6]), ``base_x`` (metres, in
[-6.5, -1]) and ``arm_angle`` (radians, in [-85, 85] deg); the vector env takes a scalar or one
value per environment.

## ``info``
``hit``, ``racket_speed`` (m/s at the hit, else 0), ``net_touch``, ``landed``,
``landing_point`` (world, m), ``landing_depth`` (m beyond the net), ``landing_error``
(abs(depth - d*)), ``landed_in``, ``target_depth``. The single env gives ``racket_speed`` only on
a hit and the landing keys only at the landing; the vector env gives arrays for all keys, with
NaN where a value does not apply and Gymnasium's ``_key`` masks marking where it does.

## Version history
- v1: ``goals="reachable"``. Over 1,000 fresh serves only 39 % of v0's U[2, 6] m goals can be
  reached at all (the deepest full-speed return lands 3.8 m deep in the median); see
  docs/rl-alone.md for what the change does to learning from scratch.
- v0: first release. Fix (2026-11-23): reset options no longer shift the random stream
  (episodes reset without options are unchanged).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from rallysim.core.game import Game
from rallysim.core.lanes import column
from rallysim.core.reach import ShotPlanner
from rallysim.core.serve import FedShots, MachineServe, Serve
from rallysim.envs.rendering import RENDER_MODES, EnvView
from rallysim.envs.simple_obs import (
    PLAYER_OBS_CENTRE,
    PLAYER_OBS_SCALE,
    PLAYER_OBS_SIZE,
    TARGET_DEPTH_RANGE,
    raw_observation_lanes,
)
from rallysim.envs.task_env import TaskEnv, box_spaces
from rallysim.envs.validation import positive_int, read_options, real_array
from rallysim.envs.vector_base import NEXT_STEP, TaskVectorEnv

OBS_SIZE = PLAYER_OBS_SIZE + 1
# the observation's affine maps: the player's, then normalise_depth's for the goal
OBS_CENTRE = (*PLAYER_OBS_CENTRE, 0.5 * sum(TARGET_DEPTH_RANGE))
OBS_SCALE = (*PLAYER_OBS_SCALE, 0.5 * (TARGET_DEPTH_RANGE[1] - TARGET_DEPTH_RANGE[0]))
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


class ReturnTask:
    """The low-level task over N batched games: goals, rewards, ends, observations."""

    def __init__(self, num_envs: int, shuttle: str = "paper", seed: int | None = None,
                 target_depth_range: tuple[float, float] = TARGET_DEPTH_RANGE,
                 max_decisions: int = MAX_DECISIONS, incoming: str = "serve",
                 keep_bodies: bool = False, goals: str = "uniform") -> None:
        if goals not in GOALS:
            raise ValueError(f"unknown goals {goals!r}; valid: {', '.join(map(repr, GOALS))}")
        self.goals = goals
        self._planner = ShotPlanner() if goals == "reachable" else None
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
        self.game = Game(num_envs, 1, shuttle=shuttle, seed=seed, shaping=True,
                         serve=incoming_serve(incoming))
        self.depth_range = (lo, hi)
        self.max_decisions = max_decisions
        self.goal = np.zeros(num_envs)
        self.elapsed = np.zeros(num_envs, np.int64)

    def reset(self, envs: np.ndarray, options: dict[str, Any] | None = None) -> None:
        envs = np.asarray(envs, np.int64)
        b, limit = self.game.bodies, self.game.bodies.limit
        given = self.reset_options(options, len(envs))
        # The same draws whatever the options say, so an option changes only what it sets:
        # the start here, the serve's (the game's serve strategy), then the goal.
        rngs = [self.game.rngs[e] for e in envs]
        base_x = given.get("base_x", np.array([r.uniform(*b.base_range) for r in rngs]))
        theta = given.get("arm_angle", np.array([r.uniform(-limit, limit) for r in rngs]))
        # the original builds: robots stay where the last episode left them
        keep = self._started[envs] & (self.keep_bodies and not given)
        carry = envs[keep]
        base_x[keep], theta[keep] = b.base_x[carry, 0], b.theta[carry, 0]
        omega = b.omega[carry, 0].copy()
        self.game.reset(envs, receiver=0, base_x=base_x[:, None], theta=theta[:, None])
        b.omega[carry, 0] = omega
        self._started[envs] = True
        # (drawn even when the option gives the goal, so that the stream does not shift)
        if self._planner is None:
            drawn = np.array([r.uniform(*self.depth_range) for r in rngs])
        else:
            u = np.array([r.uniform() for r in rngs])
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
        b = self.game.bodies
        return read_options(options, {"target_depth": ((k,), TARGET_DEPTH_RANGE),
                                      "base_x": ((k,), b.base_range),
                                      "arm_angle": ((k,), (-b.limit, b.limit))})

    def observe(self) -> np.ndarray:
        game = self.game
        lanes = [*raw_observation_lanes(game), game.ops.read(self.goal[:, None])]
        return game.ops.observations(lanes, (self.n, 1), OBS_CENTRE, OBS_SCALE)[:, 0]

    def step(self, actions: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict]:
        """Advance all N games by one decision with validated, clipped ``actions`` (N, 3):
        rewards, terminated, truncated and info, as (N,) arrays."""
        reward, terminated, truncated, values = self.outcome(actions)
        info = {key: column(value, self.n) for key, value in values.items()}
        # Gymnasium's vector convention: "_key" marks the environments where "key" applies.
        info["_racket_speed"] = info["hit"].copy()
        for key in LANDING_KEYS:
            info["_" + key] = info["landed"].copy()
        return (column(reward, self.n), column(terminated, self.n), column(truncated, self.n),
                info)

    def outcome(self, actions: np.ndarray) -> tuple[Any, Any, Any, dict[str, Any]]:
        """``step``'s values as lanes of ``game.ops`` (rallysim.core.lanes: Python values for
        one environment), not yet copied into arrays."""
        game, ops = self.game, self.game.ops
        read, read0 = ops.read, ops.read0
        ev = game.step(actions[:, None, :])
        self.elapsed += 1
        hit, landed, goal = read0(ev.hit), read(ev.landed), read(self.goal)
        reward = SHAPING_GOOD * read0(ev.approach_good) + SHAPING_BAD * read0(ev.approach_bad)
        reward = reward + R_HIT * hit
        depth = error = np.nan
        landed_in = False
        if ops.any(landed):
            land_x = read(ev.land_point[:, 0])  # player 0's own frame is the world frame
            depth = ops.where(landed, land_x, np.nan)
            error = ops.where(landed, abs(land_x - goal), np.nan)
            landed_in = landed & (read(ev.land_side) == 1) & read(ev.land_in)
            scored = landed_in & read0(game.has_hit) & ops.logical_not(read(game.net_touched))
            closeness = ops.exp(-R_DIST_RATE * ops.where(landed, error, 0.0))
            reward = reward + ops.where(scored, closeness, 0.0)
        # (without a landing there is nothing to score: adding 0.0 would not change the
        # reward, which never is -0.0)
        truncated = ops.logical_not(landed) & (read(self.elapsed) >= self.max_decisions)
        info = {"hit": hit, "racket_speed": read0(ev.hit_speed), "net_touch": read(ev.net_touch),
                "landed": landed, "landing_point": ev.land_point, "landing_depth": depth,
                "landing_error": error, "landed_in": landed_in, "target_depth": goal}
        return reward, landed, truncated, info


def incoming_serve(incoming: str) -> Serve:
    """What comes over (``incoming``): the machine serve (``"serve"``), or a recorded rally
    shot in its place always (``"rally"``) or half the time (``"mixed"``)."""
    if incoming == "serve":
        return MachineServe()
    return FedShots(RALLY_SHOT_SHARE[incoming])


def _spaces() -> tuple[spaces.Box, spaces.Box]:
    return box_spaces(OBS_SIZE, ACTION_SIZE)


class SimpleReturnEnv(TaskEnv):
    """One environment of the SIMPLE low-level task. See the module docstring."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 10}
    goal_key = "target_depth"
    hit_keys = ("racket_speed",)
    landing_keys = LANDING_KEYS

    def __init__(self, shuttle: str = "paper",
                 target_depth_range: tuple[float, float] = TARGET_DEPTH_RANGE,
                 max_decisions: int = MAX_DECISIONS, render_mode: str | None = None,
                 incoming: str = "serve", keep_bodies: bool = False,
                 goals: str = "uniform") -> None:
        task = ReturnTask(1, shuttle, None, target_depth_range, max_decisions, incoming,
                          keep_bodies, goals)
        self._init_task(task, OBS_SIZE, ACTION_SIZE, render_mode, {})

    def _frame(self, view: EnvView, env: int) -> np.ndarray | None:
        """The court from the side with the target landing spot in red (``"rgb_array"``)."""
        return render_return(view, self.task, env)


def render_return(view: EnvView, task: ReturnTask, env: int) -> np.ndarray | None:
    hud = (f"target {task.goal[env]:.2f} m   t {0.1 * task.elapsed[env]:.1f} s   "
           f"shuttle {task.game.flight.name}")
    return view.render(task.game, env, float(task.goal[env]), hud)


class SimpleReturnVectorEnv(TaskVectorEnv):
    """N environments of the SIMPLE low-level task stepped together in one call.

    The fast path: one MuJoCo model holds all N players and the rules run as array code, so
    there are no per-environment Python objects. ``autoreset_mode`` is ``"next_step"`` (the
    Gymnasium default) or ``"same_step"``; see ``rallysim.envs.vector_base.NativeVectorEnv``.
    """

    metadata = {"render_modes": RENDER_MODES, "render_fps": 10, "autoreset_mode": NEXT_STEP}
    goal_key = "target_depth"
    action_size = ACTION_SIZE

    def __init__(self, num_envs: int = 1, shuttle: str = "paper",
                 target_depth_range: tuple[float, float] = TARGET_DEPTH_RANGE,
                 max_decisions: int = MAX_DECISIONS, autoreset_mode: str = "next_step",
                 render_mode: str | None = None, seed: int | None = None,
                 render_envs: int = 1, incoming: str = "serve",
                 keep_bodies: bool = False, goals: str = "uniform") -> None:
        num_envs = positive_int(num_envs, "num_envs")
        task = ReturnTask(num_envs, shuttle, seed, target_depth_range, max_decisions,
                          incoming, keep_bodies, goals)
        self._init_task(num_envs, autoreset_mode, task, _spaces(), render_mode, render_envs, {})

    def _frame(self, view: EnvView, env: int) -> np.ndarray | None:
        return render_return(view, self.task, env)

    def _blank_info(self, info: dict, units: np.ndarray) -> None:
        super()._blank_info(info, units)
        info["target_depth"][units] = self.task.goal[units]
