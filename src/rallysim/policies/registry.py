"""One registry from a policy's name to its callable: ``resolve(spec, role, player)``.

| spec | ``low`` (task policy) | ``rally_low`` (rally low level) | ``high`` (goals) | ``mono`` |
|---|---|---|---|---|
| ``scripted`` | the player's scripted policy | the same, goal-conditioned | — | — |
| ``random`` | uniform actions | uniform actions | uniform goals | uniform actions |
| ``fixed:G`` | — | — | always the goal G (comma-separated values) | — |
| ``pretrained`` | the shipped one | the shipped low level | the shipped one | the shipped one |
| a shipped name | ``pretrained/NAME.*`` (e.g. ``simple_low_rl``) | same | same | same |
| a path prefix | ``PREFIX.safetensors`` + ``PREFIX.json`` | same | same | same |

A callable is returned as it is. A high-level network's action becomes its goal by the player's
goal mapping (``PlayerSpec.goal.from_action``; SIMPLE: 4 + 2a metres).
"""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path
from typing import Any, NoReturn

import numpy as np

from rallysim.players import PlayerSpec, get_player
from rallysim.policies.callables import Composed, FixedGoal, GoalConditioned, UniformRandom

PRETRAINED = Path(__file__).parent / "pretrained"
ROLES = ("low", "rally_low", "high", "mono")
NETWORK_ROLE = {"low": "low", "rally_low": "low", "high": "high", "mono": "mono"}


def pretrained_prefix(role: str, player: str = "simple") -> Path:
    """Path prefix of the shipped ``role`` network (low, high or mono) for ``player``."""
    if role not in ("low", "high", "mono"):
        raise ValueError(f"unknown role {role!r}; valid: low, high, mono")
    prefix = PRETRAINED / f"{get_player(player).name}_{role}"
    if not prefix.with_suffix(".json").is_file():
        raise FileNotFoundError(f"no pretrained {player} {role}-level policy is shipped "
                                f"(looked for {prefix}.json)")
    return prefix


def load_network(spec: str, role: str, player: str = "simple") -> Callable:
    """A stored network (``pretrained`` or a path prefix) of ``role`` (low, high, mono)."""
    from rallysim.policies.mlp import load_policy

    prefix = (pretrained_prefix(role, player) if spec == "pretrained"
              else shipped_prefix(spec, role) or Path(spec))
    return load_policy(prefix)


def shipped_prefix(name: str, role: str | None = None) -> Path | None:
    """The prefix of a policy shipped under ``name`` (``pretrained/NAME.json``), else None;
    given ``role`` (low, high, mono), one trained for another role is refused."""
    prefix = PRETRAINED / name
    simple_name = name.replace("_", "").isalnum()
    if not (simple_name and prefix.with_suffix(".json").is_file()):
        return None
    if role is None:
        return prefix
    stage = json.loads(prefix.with_suffix(".json").read_text())["metadata"].get("stage")
    if stage != role:
        raise ValueError(f"the shipped policy {name!r} is a {stage}-level policy, not a "
                         f"{role}-level one")
    return prefix


def resolve(spec: Any, role: str, player: str | PlayerSpec = "simple",
            seed: int | None = 0) -> Callable:
    """The callable that ``spec`` names for ``role`` (see the module's table) of ``player``;
    ``seed`` seeds ``random``."""
    if callable(spec):
        return spec
    if role not in ROLES:
        raise ValueError(f"unknown policy role {role!r}; valid: {', '.join(ROLES)}")
    p = get_player(player)
    if not isinstance(spec, str):
        raise ValueError(f"a {role} policy is a callable or a name, got {spec!r}")
    if spec == "random":
        if role == "high":  # goals drawn over the goal's own range
            g = p.goal
            if g.size == 1:
                return UniformRandom(None, seed, g.low[0], g.high[0])
            return UniformRandom(g.size, seed, np.asarray(g.low), np.asarray(g.high))
        return UniformRandom(p.action.size, seed)
    if spec == "scripted" and role in ("low", "rally_low"):
        return p.scripted_task_low() if role == "low" else p.scripted_low()
    if spec.startswith("fixed:") and role == "high":
        return FixedGoal(_fixed_goal(spec, p))
    if spec != "pretrained" and shipped_prefix(spec) is None and not _looks_like_path(spec):
        _refuse(spec, role, p)
    network = load_network(spec, NETWORK_ROLE[role], p.name)
    if role == "rally_low":
        return goal_conditioned(network, p)
    if role == "high":
        return Composed(p.goal.from_action, network)
    return network


def goal_conditioned(policy: Callable, player: str | PlayerSpec = "simple") -> Callable:
    """A low-level task's policy as a rally's ``(observations, goals) -> actions`` low level:
    the rally's observations and goals become the task's (``PlayerSpec.low_observations``)."""
    return GoalConditioned(policy, get_player(player).low_observations)


def _fixed_goal(spec: str, p: PlayerSpec) -> float | np.ndarray:
    try:
        goal = np.array([float(v) for v in spec.split(":", 1)[1].split(",")])
    except ValueError:
        goal = np.array([np.nan])
    if len(goal) != p.goal.size or not np.all(np.isfinite(goal)):
        unit = f" in {p.goal.unit}" if p.goal.unit else ""
        raise ValueError(f"a fixed {p.name} goal is fixed:G with G {p.goal.size} finite "
                         f"value(s){unit}, got {spec!r}")
    clipped = p.goal.clip(goal)
    return float(clipped[0]) if p.goal.size == 1 else clipped


def _looks_like_path(spec: str) -> bool:
    """A path prefix names a file or a folder part: a PREFIX.json that is there (of any kind:
    the loader then says what it is), or a path with a separator (whose missing file is then
    reported by the loader)."""
    from rallysim.jsondoc import MISSING, not_a_file

    return (not_a_file(Path(spec).with_suffix(".json")) != MISSING or "/" in spec
            or "\\" in spec)


def _refuse(spec: str, role: str, p: PlayerSpec) -> NoReturn:
    valid = {"low": "'scripted', 'random'", "rally_low": "'scripted', 'random'",
             "high": "'random', 'fixed:G'", "mono": "'random'"}[role]
    name = "low_level" if role == "rally_low" else f"{role} policy"
    raise ValueError(f"unknown {p.name} {name} {spec!r}; pass a callable, {valid}, "
                     "'pretrained' or the path prefix of an exported policy (PREFIX.json)")
