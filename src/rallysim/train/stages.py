"""The three training stages of the paper's method (SPEC §8): what each trains on and how it is
judged. ``rallysim.train.runner`` runs any of them the same way.

- low: ``SimpleReturnVectorEnv``; one SB3 step is one decision; judged by the mean episode
  reward, hit rate and landing error.
- high: ``SimpleRallyTurnVectorEnv`` with the frozen low level, the action a in [-1, 1] setting
  the goal 4 + 2a m; one SB3 step is one turn; judged by the mean rally length.
- mono: ``SimpleRallyVectorEnv``, one slot per rally-player pair; one SB3 step is one decision
  of one player; judged by the mean rally length.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import TYPE_CHECKING, Any

import numpy as np
from gymnasium.wrappers.vector import RescaleAction

from rallysim.envs.rally_task import RallyConfig
from rallysim.envs.registration import HUMANLIKE_RETURN_ID, SIMPLE_RETURN_ID
from rallysim.envs.simple_rally_v0 import SimpleRallyTurnVectorEnv, SimpleRallyVectorEnv
from rallysim.eval.low_eval import evaluate_return
from rallysim.eval.rally_eval import rally_lengths_direct, rally_lengths_turns
from rallysim.train.config import TrainConfig

if TYPE_CHECKING:  # SB3 is imported where its env is built: the RLlib backend runs without it
    from rallysim.train.sb3_vec import NativeVecEnv

Act = Callable[[np.ndarray], np.ndarray]

# Which env an exported policy drives, and how many observations it takes.
EXPORT_ENV = {"low": "RallySim/SimpleReturn-v0", "high": "RallySim/SimpleRallyTurn-v0",
              "mono": "rallysim.envs.simple_rally_v0:SimpleRallyVectorEnv",
              "humanlike": "RallySim/HumanLikeReturn-v0",
              "humanlike_high": "rallysim.envs.humanlike_rally_v0:HumanLikeRallyTurnVectorEnv"}


def goal_mapping(config: TrainConfig) -> str | None:
    """How a high-level policy's action becomes its goal (written into its export)."""
    if config.stage != "high":
        return None
    if config.env == "humanlike":
        return ("target racket velocity: speed 1.5 + 1.5 (a0 + 1) m/s, elevation "
                "40 + 5 (a1 + 1) deg, azimuth 30 a2 deg (own frame)")
    return "goal_m = 4 + 2 * clip(action, -1, 1)"


def export_env(config: TrainConfig) -> str:
    """The env id an exported policy of ``config``'s stage drives."""
    if config.env == "humanlike":
        return EXPORT_ENV["humanlike_high" if config.stage == "high" else "humanlike"]
    return EXPORT_ENV[config.stage]


def frozen_low_level(spec: str) -> Callable[[np.ndarray, np.ndarray], np.ndarray]:
    """The high stage's low level: a stored low-level policy (or ``scripted``)."""
    from rallysim.policies.resolve import rally_low_level

    return rally_low_level(spec)


def make_env(config: TrainConfig) -> NativeVecEnv:
    """The stage's training env behind SB3's ``VecEnv`` API (same-step autoreset)."""
    from rallysim.sb3 import make_vec_env
    from rallysim.train.sb3_vec import NativeVecEnv

    n, seed = config.n_envs, config.seed
    if config.env == "humanlike" and config.stage == "high":
        from rallysim.envs.humanlike_rally_task import HumanLikeRallyTask
        from rallysim.envs.humanlike_rally_v0 import HumanLikeRallyTurnVectorEnv

        low = HumanLikeRallyTask.resolve_low_level(config.low_policy)
        return NativeVecEnv(HumanLikeRallyTurnVectorEnv(n, low_level=low, seed=seed,
                                                        autoreset_mode="same_step",
                                                        shuttle=config.shuttle))
    # The low levels are registered ids with a batched vector entry point: built through the
    # public adapter (rallysim.sb3.make_vec_env), so what users get is what training uses.
    if config.env == "humanlike":
        return make_vec_env(HUMANLIKE_RETURN_ID, n, seed=seed,
                            env_kwargs={"shuttle": config.shuttle})
    if config.stage == "low":
        return make_vec_env(SIMPLE_RETURN_ID, n, seed=seed,
                            env_kwargs={"shuttle": config.shuttle, "incoming": config.incoming,
                                        "keep_bodies": config.keep_bodies})
    if config.stage == "high":
        turns = SimpleRallyTurnVectorEnv(n, low_level=frozen_low_level(config.low_policy),
                                         autoreset_mode="same_step", seed=seed,
                                         shuttle=config.shuttle)
        # the original mapping: goal = 4 + 2 clip(a, -1, 1) metres
        unit = np.ones(1, np.float32)
        venv = RescaleAction(turns, min_action=-unit, max_action=unit)
    else:
        venv = SimpleRallyVectorEnv(n // 2, autoreset_mode="same_step", seed=seed,
                                    shuttle=config.shuttle)
    return NativeVecEnv(venv)


def goals_from_actions(act: Act) -> Act:
    """A high-level network's (M, 1) actions in [-1, 1] -> (M,) goals in metres."""
    return lambda obs: 4.0 + 2.0 * np.clip(np.asarray(act(obs)).reshape(len(obs)), -1.0, 1.0)


def evaluate(config: TrainConfig, act: Act, rallies: int | None = None) -> dict[str, Any]:
    """The stage's numbers for deterministic policy ``act`` (observations -> actions)."""
    n = rallies or config.eval_episodes
    if config.env == "humanlike" and config.stage == "high":
        from rallysim.envs.humanlike_rally_task import HumanLikeRallyTask

        lengths = rally_lengths_turns(act, HumanLikeRallyTask.resolve_low_level(config.low_policy),
                                      n, config.eval_seed, RallyConfig(shuttle=config.shuttle),
                                      rally=HumanLikeRallyTask)
        return _rally_result(lengths)
    if config.env == "humanlike":
        from rallysim.eval.humanlike_eval import evaluate_humanlike

        return evaluate_humanlike(act, episodes=n, seed=config.eval_seed,
                                  shuttle=config.shuttle)
    if config.stage == "low":
        return evaluate_return(act, episodes=n, seed=config.eval_seed,
                               shuttle=config.shuttle).as_dict()
    rules = RallyConfig(shuttle=config.shuttle)
    if config.stage == "high":
        lengths = rally_lengths_turns(goals_from_actions(act), frozen_low_level(config.low_policy),
                                      n, config.eval_seed, rules)
    else:
        lengths = rally_lengths_direct(act, n, config.eval_seed, rules)
    return _rally_result(lengths)


def _rally_result(lengths: np.ndarray) -> dict[str, Any]:
    return {"rallies": len(lengths), "mean_rally": float(lengths.mean()),
            "median_rally": float(np.median(lengths)), "capped": int((lengths >= 50).sum())}


def headline(config: TrainConfig, result: dict[str, Any]) -> str:
    if config.env == "humanlike" and config.stage == "low":
        return (f"reward {result['mean_reward']:.3f} hit {result['hit_rate']:.3f} angle "
                f"{result['mean_angle_error']:.1f} deg speed {result['mean_abs_speed_error']:.2f}")
    if config.stage == "low":
        return (f"reward {result['mean_reward']:.3f} hit {result['hit_rate']:.3f} "
                f"err {result['median_error']:.2f} m")
    return f"mean rally {result['mean_rally']:.2f} capped {result['capped']}/{result['rallies']}"


def score(config: TrainConfig, result: dict[str, Any]) -> float:
    """The number a learning curve plots for this stage."""
    return result["mean_reward"] if config.stage == "low" else result["mean_rally"]


def decisions_simulated(vec_env: NativeVecEnv) -> int:
    """Decisions simulated so far by a training env (the high stage's turns span many)."""
    inner = vec_env.venv.unwrapped
    return int(getattr(inner, "decisions_simulated", 0))
