"""``RallySim/HumanLikeReturn-v0``: the HUMAN-LIKE low-level task (docs/reference.md §10).

One HUMAN-LIKE player (a humanoid upper body on kinematic hips, racket in the right hand; see
``rallysim.core.humanlike`` and ``assets/humanlike_player.xml``) stands at x < 0. A serve comes
over the net; the player must hit it with the racket moving at ``target_velocity``. One hit per
episode; the episode ends when the shuttle lands.

## Action space: ``Box(-1, 1, (15,), float32)``
| index | name | effect |
|---|---|---|
| 0-1 | movement x, y | hips velocity = 5 * a m/s (own frame), hips centre kept in x in [-6.5, -0.5], y in [-2.8, 2.8] m |
| 2 | spine z | target angle, a in [-1, 1] spanning -15..15 deg |
| 3 | chest z | target angle, -15..15 deg |
| 4-6 | upper arm x, y, z | target angles, -90..90, -75..75, -85..85 deg |
| 7 | lower arm x | target angle, 0..100 deg |
| 8-9 | hand x, y | target angles, -90..90, -25..25 deg |
| 10-14 | strength of spine, chest, upper arm, lower arm, hand | torque limit = (a + 1) / 2 of 100, 100, 60, 40, 10 N m |

Target angle = lo + (a + 1) / 2 * (hi - lo). Actions outside [-1, 1] are clipped; NaN, inf or a
wrong shape raise ``ValueError``. The action is held for the 5 physics steps (0.02 s each) of one
decision (0.1 s).

## Observation space: ``Box(-1, 1, (85,), float32)``
Indices 0-81 are the player observation of ``rallysim.core.humanlike_obs`` (for each of spine,
chest, upper arm, lower arm and hand: velocity 3, angular velocity 3, position relative to the
hips 3, orientation quaternion 4, torque magnitude 1; then shuttle position 3 and velocity 3,
hips position 3, racket head position 3; all own-frame and scaled); indices 82-84 are the target
racket velocity / 5 m/s. Values are clipped into the bounds.

## Rewards
| term | value |
|---|---|
| hit | 0.5 * (R_hit + exp(-1.5 * d)), R_hit = 1, d = abs(v - v*) in m/s, v the racket face centre's velocity at the impact (own frame), v* the target |
| otherwise | 0 |

The maximum is 1.0 per episode. After the hit the shuttle leaves along v at min(60, 5 abs(v)) m/s.

## Starting state
Serve (docs/reference.md §10): from x0 ~ U[1, 6], y0 ~ U[-1, 1], z0 ~ U[1, 1.5] m on the far side, along
normalise(-3, U(-0.5, 0.5), U(2, 3)) at 15 m/s (with the ``paper`` flight it always clears
the net and lands at x in [-6.3, -0.5] m after 1.5-1.9 s; with ``aero`` 7 % meet the net). Hips at x ~ U[-4.5, -1.5], y ~ U[-1.5, 1.5] m, joints at
the zero pose (a T-pose: arm out to the right, racket continuing it), at rest. Target racket
velocity: speed ~ U[1.5, 4.5] m/s, elevation ~ U[40, 50] deg, azimuth ~ U[-30, 30] deg about
+x (toward the far court).

## Episode end
Terminates when the shuttle's centre drops below z = 0; truncates after 1000 decisions.

## Arguments
| argument | default | meaning |
|---|---|---|
| ``shuttle`` | ``"paper"`` | flight model: ``"paper"``, ``"paper-alg1"`` or ``"aero"`` |
| ``max_decisions`` | ``1000`` | truncation |
| ``render_mode`` | ``None`` | ``"rgb_array"``: ``render()`` returns a 640x360 frame (three-quarter view, the target velocity as a red arrow from the racket head); ``"human"`` (with a display): a viewer window |

``reset(options=...)`` accepts ``target_velocity`` (m/s, own frame, 3 values each in [-5, 5],
a speed of at least 0.5 m/s) and ``hips_position`` (m, own frame x, y within the hips range);
the vector env takes one value for all environments or one per environment.

## ``info``
``hit``, ``racket_velocity`` (m/s, own frame, at the hit), ``velocity_error`` (d, m/s),
``angle_error`` (degrees between v and v*; NaN if the racket was still), ``speed_error``
((abs(v) - abs(v*)) / abs(v*), signed), ``net_touch``, ``landed``, ``landing_point`` (world, m),
``target_velocity``, and the reward's two terms every step, which sum to it: ``reward_hit``
(0.5 on a hit) and ``reward_velocity`` (0.5 exp(-1.5 d) on a hit). The single env gives the hit
values only on a hit and ``landing_point``
only at the landing; the vector env gives arrays for all keys, with NaN where a value does not
apply and Gymnasium's ``_key`` masks marking where it does.

## Version history
- v0: first release. 2026-11-24: ``info`` gains the reward's terms (``reward_*``); observations,
  rewards and episode ends are unchanged.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from gymnasium import spaces

from rallysim.core.tasks.humanlike_return import (
    ACTION_SIZE,
    HIT_KEYS,
    MAX_DECISIONS,
    OBS_SIZE,
    HumanLikeReturnTask,
)
from rallysim.core.validation import check_keywords, keyword_names, positive_int
from rallysim.envs.rendering import RENDER_MODES, EnvView
from rallysim.envs.task_env import TaskEnv, box_spaces
from rallysim.envs.vector_base import NEXT_STEP, TaskVectorEnv


def _spaces() -> tuple[spaces.Box, spaces.Box]:
    return box_spaces(OBS_SIZE, ACTION_SIZE)


class HumanLikeReturnEnv(TaskEnv):
    """One environment of the HUMAN-LIKE low-level task. See the module docstring."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 10}
    goal_key = "target_velocity"
    reward_keys = ("reward_hit", "reward_velocity")
    hit_keys = HIT_KEYS
    landing_keys = ("landing_point",)

    def __init__(self, shuttle: str = "paper", max_decisions: int = MAX_DECISIONS,
                 render_mode: str | None = None, **unknown: Any) -> None:
        check_keywords(unknown, keyword_names(HumanLikeReturnEnv.__init__))
        task = HumanLikeReturnTask(1, shuttle, None, max_decisions)
        self._init_task(task, OBS_SIZE, ACTION_SIZE, render_mode, {"player": "humanlike"})

    def _frame(self, view: EnvView, env: int) -> np.ndarray | None:
        """The player's half court from behind its right with the target racket velocity as
        a red arrow from the racket head (``"rgb_array"``)."""
        return render_humanlike_return(view, self.task, env)


def render_humanlike_return(view: EnvView, task: HumanLikeReturnTask, env: int,
                            ) -> np.ndarray | None:
    goal = task.goal[env]
    hud = (f"target ({goal[0]:+.1f}, {goal[1]:+.1f}, {goal[2]:+.1f}) m/s   "
           f"t {0.1 * task.elapsed[env]:.1f} s   shuttle {task.game.flight.name}")
    return view.render(task.game, env, hud_text=hud, target_velocity=goal)


class HumanLikeReturnVectorEnv(TaskVectorEnv):
    """N environments of the HUMAN-LIKE low-level task stepped together in one call.

    One MuJoCo model holds all N players and the rules run as one compiled loop over the
    games. ``autoreset_mode`` is ``"next_step"`` (the Gymnasium default) or ``"same_step"``;
    see ``rallysim.envs.vector_base.NativeVectorEnv``."""

    metadata = {"render_modes": RENDER_MODES, "render_fps": 10, "autoreset_mode": NEXT_STEP}

    goal_key = "target_velocity"
    action_size = ACTION_SIZE

    def __init__(self, num_envs: int = 1, shuttle: str = "paper",
                 max_decisions: int = MAX_DECISIONS, autoreset_mode: str = "next_step",
                 render_mode: str | None = None, seed: int | None = None,
                 render_envs: int = 1, **unknown: Any) -> None:
        check_keywords(unknown, keyword_names(HumanLikeReturnVectorEnv.__init__))
        num_envs = positive_int(num_envs, "num_envs")
        task = HumanLikeReturnTask(num_envs, shuttle, seed, max_decisions)
        self._init_task(num_envs, autoreset_mode, task, _spaces(), render_mode, render_envs,
                        {"player": "humanlike"})

    def _frame(self, view: EnvView, env: int) -> np.ndarray | None:
        return render_humanlike_return(view, self.task, env)

    def _blank_info(self, info: dict, units: np.ndarray) -> None:
        super()._blank_info(info, units)
        for key in (*HIT_KEYS, "landing_point"):
            info[key][units] = np.nan
        info["target_velocity"][units] = self.task.goal[units]
