"""No rally passes its hit cap, through the rally core, every evaluator and every view.

Under the original net rule a touch re-arms both players, so several hits can fall within one
decision; the cap must stop the rally at the hit that reaches it, not at the decision's end."""

from __future__ import annotations

import copy
from collections.abc import Iterator
from dataclasses import replace
from typing import Any

import numpy as np
import pytest
from pettingzoo import AECEnv, ParallelEnv

from rallysim.core.tasks.rally import RallyConfig, RallyTask
from rallysim.envs import (
    humanlike_rally_turn_v0,
    humanlike_rally_v0,
    simple_rally_turn_v0,
    simple_rally_v0,
)
from rallysim.eval.rally_eval import (
    rally_lengths_direct,
    rally_lengths_turns,
    random_goals,
    rules_for_cap,
)

CAP = 3


def _hard_random(rng: np.random.Generator, shape: tuple[int, ...]) -> np.ndarray:
    """Random actions that drive the bases at full speed: players meet the net often."""
    a = rng.uniform(-1.0, 1.0, shape)
    a[..., 0] = np.sign(a[..., 0])
    return a


@pytest.mark.slow
@pytest.mark.parametrize("mode", ["cooperative", "competitive"])
def test_several_hits_in_one_decision_stop_at_the_cap(mode):
    task = RallyTask(256, RallyConfig(max_hits=CAP, mode=mode), seed=CAP)
    task.reset(np.arange(256))
    rng = np.random.default_rng(0)
    longest, capped = 0, 0
    for _ in range(300):
        _, term, trunc, info = task.step(_hard_random(rng, (256, 2, 3)))
        longest = max(longest, int(info["rally_length"].max()))
        capped += int((info["rally_over"] & ~info["landed"]).sum())
        assert (task.game.hits <= CAP).all()
        done = np.flatnonzero(term | trunc)
        if len(done):
            task.reset(done)
    assert longest == CAP and capped > 0  # rallies do reach the cap


@pytest.mark.slow
def test_a_decision_of_two_hits_stops_at_the_hit_that_reaches_the_cap():
    """With the net re-arming both players, some decisions of random play hold two hits or
    more; replayed with the cap one hit above where it began, such a decision ends the rally
    at the cap (a let), not one hit past it."""
    task = RallyTask(256, RallyConfig(max_hits=1000), seed=0)
    task.reset(np.arange(256))
    rng = np.random.default_rng(0)
    for _ in range(300):
        saved, actions = copy.deepcopy(task), _hard_random(rng, (256, 2, 3))
        before = task.game.hits.copy()
        _, term, trunc, _ = task.step(actions)
        several = np.flatnonzero(task.game.hits - before > 1)
        if len(several):
            break
        done = np.flatnonzero(term | trunc)
        if len(done):
            task.reset(done)
    else:
        pytest.fail("no decision held two hits")
    e = several[0]
    cap = int(before[e]) + 1
    saved.config = replace(saved.config, max_hits=cap)
    saved.game.max_hits = cap
    _, term, trunc, info = saved.step(actions)
    assert (info["rally_length"][e], bool(trunc[e]), bool(term[e])) == (cap, True, False)
    assert info["hit"][e].sum() == 1 and not info["landed"][e]


@pytest.mark.parametrize("player", ["simple", "humanlike"])
@pytest.mark.parametrize("cap", [1, 2, 5])
def test_random_goal_rallies_stay_within_the_cap(player, cap):
    rallies = 64 if player == "simple" else 16
    for seed in range(2):
        goals = random_goals(seed) if player == "simple" else _humanlike_random_goals(seed)
        lengths = rally_lengths_turns(goals, "scripted", rallies, seed, rules_for_cap(cap),
                                      player=player)
        assert lengths.min() >= 0 and lengths.max() <= cap


def _humanlike_random_goals(seed: int):
    from rallysim.policies.registry import resolve

    return resolve("random", "high", "humanlike", seed)


@pytest.mark.slow
def test_a_random_monolithic_policy_stays_within_the_cap():
    rng = np.random.default_rng(1)

    def policy(obs: np.ndarray) -> np.ndarray:
        return _hard_random(rng, (len(obs), 3))

    for cap in (1, 2, CAP):
        lengths = rally_lengths_direct(policy, 256, cap, rules_for_cap(cap))
        assert lengths.max() <= cap and (lengths == cap).any()


def _views(cap: int) -> Iterator[tuple[str, Any]]:
    for name, mod, turn in (("simple", simple_rally_v0, simple_rally_turn_v0),
                            ("humanlike", humanlike_rally_v0, humanlike_rally_turn_v0)):
        for mode in ("cooperative", "competitive"):
            yield f"{name}/parallel/{mode}", mod.parallel_env(max_hits=cap, mode=mode)
            yield f"{name}/turn_aec/{mode}", turn.raw_env(max_hits=cap, mode=mode)
    yield "simple/vector", simple_rally_v0.SimpleRallyVectorEnv(8, max_hits=cap)
    yield "simple/turn_vector", simple_rally_turn_v0.SimpleRallyTurnVectorEnv(8, max_hits=cap)
    yield "simple/turn_single", simple_rally_turn_v0.SimpleRallyTurnEnv(max_hits=cap)
    yield "humanlike/vector", humanlike_rally_v0.HumanLikeRallyVectorEnv(4, max_hits=cap)


def _lengths(info: Any) -> list[int]:
    """Every ``rally_length`` in an info dict, a dict of them, or an array."""
    if isinstance(info, dict):
        if "rally_length" in info:
            return np.ravel(info["rally_length"]).astype(int).tolist()
        return [x for v in info.values() for x in _lengths(v)]
    return []


# the fast tier (``pytest -m "not slow"``) caps the views that take under 2 s here
FAST_VIEWS = {"simple/vector", "simple/parallel/cooperative", "simple/parallel/competitive",
              "simple/turn_aec/cooperative", "humanlike/parallel/cooperative"}


@pytest.mark.parametrize("name", [
    name if name in FAST_VIEWS else pytest.param(name, marks=pytest.mark.slow)
    for name, _ in _views(CAP)])
def test_every_view_stops_at_the_cap(name):
    env = dict(_views(CAP))[name]
    rng = np.random.default_rng(2)
    seen: list[int] = []
    steps = 150 if "turn" in name else 600
    if isinstance(env, AECEnv):
        env.reset(seed=0)
        for _ in range(steps):
            if not env.agents:
                env.reset()
            agent = env.agent_selection
            done = env.terminations[agent] or env.truncations[agent]
            space = env.action_space(agent)
            env.step(None if done else rng.uniform(space.low, space.high).astype(np.float32))
            seen += _lengths(env.infos)
    elif isinstance(env, ParallelEnv):
        env.reset(seed=0)
        for _ in range(steps):
            if not env.agents:
                env.reset()
            actions = {a: _hard_random(rng, env.action_space(a).shape).astype(np.float32)
                       for a in env.agents}
            seen += _lengths(env.step(actions)[4])
    else:  # Gymnasium, one env or a vector
        env.reset(seed=0)
        space = env.action_space
        for _ in range(steps):
            out = env.step(rng.uniform(space.low, space.high).astype(space.dtype))
            seen += _lengths(out[4])
            if not hasattr(env, "num_envs") and (out[2] or out[3]):
                env.reset()
    env.close()
    assert seen and max(seen) <= CAP
