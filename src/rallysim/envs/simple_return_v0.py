"""``RallySim/SimpleReturn-v0``: the SIMPLE low-level task (docs/reference.md §5-6).

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
Indices 0-15 are the player observation of ``rallysim.core.simple_obs`` (base position, arm
quaternion, racket face velocity, shuttle position and velocity, all own-frame and scaled);
index 16 is the target depth, (d* - 4) / 2. Values are clipped into the bounds.

## Rewards (summed over the decision's physics steps)
| term | value |
|---|---|
| shaping, each physics step before the hit | +0.001 if the base moved and its x-distance to the shuttle shrank, else -0.005 |
| hit | +1 |
| landing, if hit, no net touch since the hit, and in the opponent court | exp(-0.5 * abs(depth - d*)) |

## Starting state
The serve of docs/reference.md §4.3 (toward this player). The base starts at x ~ U[-6.5, -1.0] and the arm
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
| ``returnable`` | ``0.0`` | not the paper's: this much more reward for a hit whose shot the opponent could meet at full speed from some base position (``rallysim.core.reach.ShotPlanner.returnable``, the paper flight model); ``info`` then also gives ``reward_returnable`` |
| ``ready`` | ``0.0`` | not the paper's: in the decision in which the player's shot lands, this much times exp(-0.5 d) more reward, d the base's distance at the end of that decision from the middle of its range (-3.75 m), where it can reach either end soonest; ``info`` then also gives ``reward_ready`` |
| ``incoming`` | ``"serve"`` | what comes over: the machine serve (the paper); ``"rally"``: a shot drawn from 4,096 recorded rally shots (scripted players aiming at 2-6 m); ``"mixed"``: either, half the time each |

``reset(options=...)`` accepts ``target_depth`` (metres, in [2, 6]), ``base_x`` (metres, in
[-6.5, -1]) and ``arm_angle`` (radians, in [-85, 85] deg); the vector env takes a scalar or one
value per environment.

## ``info``
``hit``, ``racket_speed`` (m/s at the hit, else 0), ``net_touch``, ``landed``,
``landing_point`` (world, m), ``landing_depth`` (m beyond the net), ``landing_error``
(abs(depth - d*)), ``landed_in``, ``target_depth``, and the reward's terms every step, which
sum to it: ``reward_shaping``, ``reward_hit``, ``reward_landing`` (and ``reward_returnable``,
``reward_ready`` when those options are on). The single env gives ``racket_speed`` only on a
hit and the landing keys only at the landing; the vector env gives arrays for all keys, with NaN
where a value does not apply and Gymnasium's ``_key`` masks marking where it does.

## Version history
- v1: ``goals="reachable"``. Over 1,000 fresh serves only 39 % of v0's U[2, 6] m goals can be
  reached at all (the deepest full-speed return lands 3.8 m deep in the median); see
  docs/rl-alone.md for what the change does to learning from scratch.
- v0: first release. Fix (2026-11-23): reset options no longer shift the random stream
  (episodes reset without options are unchanged). 2026-11-24: ``info`` gains the reward's
  terms (``reward_*``); observations, rewards and episode ends are unchanged.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from rallysim.core.tasks.simple_return import (
    ACTION_SIZE,
    LANDING_KEYS,
    MAX_DECISIONS,
    OBS_SIZE,
    TARGET_DEPTH_RANGE,
    ReturnTask,
)
from rallysim.core.validation import check_keywords, keyword_names, positive_int
from rallysim.envs.rendering import RENDER_MODES, EnvView
from rallysim.envs.task_env import TaskEnv, box_spaces
from rallysim.envs.vector_base import NEXT_STEP, TaskVectorEnv


def _spaces() -> tuple[spaces.Box, spaces.Box]:
    return box_spaces(OBS_SIZE, ACTION_SIZE)


class SimpleReturnEnv(TaskEnv):
    """One environment of the SIMPLE low-level task. See the module docstring."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 10}
    goal_key = "target_depth"
    reward_keys = ("reward_shaping", "reward_hit", "reward_landing")
    hit_keys = ("racket_speed",)
    landing_keys = LANDING_KEYS

    def __init__(self, shuttle: str = "paper",
                 target_depth_range: tuple[float, float] = TARGET_DEPTH_RANGE,
                 max_decisions: int = MAX_DECISIONS, render_mode: str | None = None,
                 incoming: str = "serve", keep_bodies: bool = False,
                 goals: str = "uniform", returnable: float = 0.0, ready: float = 0.0,
                 **unknown: Any) -> None:
        check_keywords(unknown, keyword_names(SimpleReturnEnv.__init__))
        task = ReturnTask(1, shuttle, None, target_depth_range, max_decisions, incoming,
                          keep_bodies, goals, returnable, ready)
        # the reward's terms, with those of the options that are on
        self.reward_keys = (*type(self).reward_keys, *task.extra_reward_keys)
        self._info_keys = (*self._info_keys, *task.extra_reward_keys)
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

    The fast path: one MuJoCo model holds all N players and the rules run as one compiled
    loop over the games, so there are no per-environment Python objects. ``autoreset_mode``
    is ``"next_step"`` (the Gymnasium default) or ``"same_step"``; see
    ``rallysim.envs.vector_base.NativeVectorEnv``.
    """

    metadata = {"render_modes": RENDER_MODES, "render_fps": 10, "autoreset_mode": NEXT_STEP}
    goal_key = "target_depth"
    action_size = ACTION_SIZE

    def __init__(self, num_envs: int = 1, shuttle: str = "paper",
                 target_depth_range: tuple[float, float] = TARGET_DEPTH_RANGE,
                 max_decisions: int = MAX_DECISIONS, autoreset_mode: str = "next_step",
                 render_mode: str | None = None, seed: int | None = None,
                 render_envs: int = 1, incoming: str = "serve",
                 keep_bodies: bool = False, goals: str = "uniform", returnable: float = 0.0,
                 ready: float = 0.0, **unknown: Any) -> None:
        check_keywords(unknown, keyword_names(SimpleReturnVectorEnv.__init__))
        num_envs = positive_int(num_envs, "num_envs")
        task = ReturnTask(num_envs, shuttle, seed, target_depth_range, max_decisions,
                          incoming, keep_bodies, goals, returnable, ready)
        self._init_task(num_envs, autoreset_mode, task, _spaces(), render_mode, render_envs, {})

    def _frame(self, view: EnvView, env: int) -> np.ndarray | None:
        return render_return(view, self.task, env)

    def _blank_info(self, info: dict, units: np.ndarray) -> None:
        super()._blank_info(info, units)
        info["target_depth"][units] = self.task.goal[units]
