"""Turn a policy name on the command line into a callable.

| spec | low level (17 -> 3) | high level (20 -> goal, m) | monolithic (20 -> 3) |
|---|---|---|---|
| ``scripted`` | ``ScriptedController`` | — | — |
| ``random`` | uniform actions | goals ~ U[2, 6] m | uniform actions |
| ``fixed:D`` | — | always D metres | — |
| ``pretrained`` | the shipped policy | the shipped policy | the shipped policy |
| a path prefix | ``PREFIX.safetensors`` + ``PREFIX.json`` | same | same |

High-level networks output a in [-1, 1]; the goal is 4 + 2a metres (the original's mapping).
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path

import numpy as np

from rallysim.envs.simple_obs import TARGET_DEPTH_RANGE, depth_from_action
from rallysim.envs.turn_task import LowLevel
from rallysim.policies.callables import Composed, FixedGoal, UniformRandom

Policy = Callable[[np.ndarray], np.ndarray]
PRETRAINED = Path(__file__).parent / "pretrained"
ROLES = ("low", "high", "mono")


def pretrained_prefix(role: str, player: str = "simple") -> Path:
    """Path prefix of the shipped ``role`` policy (low, high or mono) for ``player``."""
    if role not in ROLES:
        raise ValueError(f"unknown role {role!r}; valid: {', '.join(ROLES)}")
    prefix = PRETRAINED / f"{player}_{role}"
    if not prefix.with_suffix(".json").is_file():
        raise FileNotFoundError(f"no pretrained {player} {role}-level policy is shipped "
                                f"(looked for {prefix}.json)")
    return prefix


def load_network(spec: str, role: str, player: str = "simple") -> Policy:
    """A stored network (``pretrained`` or a path prefix) for ``role``."""
    from rallysim.policies.mlp import load_policy

    prefix = pretrained_prefix(role, player) if spec == "pretrained" else Path(spec)
    return load_policy(prefix)


def humanlike_low_level(spec: str) -> Policy:
    """``(N, 85) observations -> (N, 15) actions`` for ``RallySim/HumanLikeReturn-v0``:
    ``scripted`` (``AimedSwing``), ``pretrained`` or a path prefix."""
    if spec == "scripted":
        from rallysim.policies.aimed_swing import AimedSwing

        return AimedSwing()
    return load_network(spec, "low", "humanlike")


def low_level_policy(spec: str, seed: int = 0) -> Policy:
    """``(N, 17) observations -> (N, 3) actions`` for ``RallySim/SimpleReturn-v0``."""
    if spec == "scripted":
        from rallysim.policies import ScriptedController

        return ScriptedController().act_return
    if spec == "random":
        return UniformRandom(3, seed)
    return load_network(spec, "low")


def rally_low_level(spec: str, seed: int = 0) -> LowLevel:
    """``(observations (M, 20), goals (M,)) -> actions`` for the rally's low level."""
    if spec in ("scripted", "random"):
        from rallysim.envs.turn_task import resolve_low_level

        return resolve_low_level(spec, seed)
    from rallysim.eval.rally_eval import goal_conditioned

    return goal_conditioned(load_network(spec, "low"))


def high_level_policy(spec: str, seed: int = 0) -> Policy:
    """``(M, 20) observations -> (M,) goals in metres``."""
    lo, hi = TARGET_DEPTH_RANGE
    if spec == "random":
        return UniformRandom(None, seed, lo, hi)
    if spec.startswith("fixed:"):
        try:
            goal = float(spec.split(":", 1)[1])
        except ValueError:
            goal = np.nan
        if not np.isfinite(goal):
            raise ValueError(f"a fixed goal is fixed:D with D a finite depth in metres, got "
                             f"{spec!r}")
        return FixedGoal(float(np.clip(goal, lo, hi)))
    return Composed(depth_from_action, load_network(spec, "high"))


def mono_policy(spec: str, seed: int = 0) -> Policy:
    """``(M, 20) observations -> (M, 3) actions`` acting for a rally player every decision."""
    if spec == "random":
        return UniformRandom(3, seed)
    return load_network(spec, "mono")
