"""``copy.deepcopy`` and ``pickle`` of every env view give an env that steps bit-identically
to its original (wrappers such as SuperSuit's copy envs this way)."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest
from golden import Hasher, View, views

# One shuttle model is enough: the copy mechanism does not depend on the flight model.
VIEWS = {v.name: v for v in views() if "/paper" in v.name and "alg1" not in v.name}
STEPS = 40
# The fast tier (``pytest -m "not slow"``) copies every view but the turn views that play whole
# turns per step (SIMPLE's turn_vector stays): HUMAN-LIKE's take 7-30 s each.
SLOW = {name for name in VIEWS
        if "turn" in name.lower() and name != "simple_rally_v0/turn_vector/paper"}


def _names() -> list:
    return [pytest.param(name, marks=pytest.mark.slow) if name in SLOW else name
            for name in sorted(VIEWS)]


def _play(view: View, env, seed: int) -> str:
    h = Hasher()
    view.play(env, STEPS, np.random.default_rng(seed), h)
    return h.hexdigest()


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
@pytest.mark.parametrize("name", _names())
def test_a_copy_mid_episode_steps_like_its_original(name, how):
    view = VIEWS[name]
    env = view.make()
    view.reset(env, Hasher(), seed=3)
    view.play(env, 7 if view.api in ("aec",) or "turn" in name else 30,
              np.random.default_rng(0), Hasher())
    twin = copy.deepcopy(env) if how == "deepcopy" else pickle.loads(pickle.dumps(env))
    original_state = pickle.dumps(env)
    copied = _play(view, twin, 1)
    assert pickle.dumps(env) == original_state  # the copy shares nothing with its original
    assert _play(view, env, 1) == copied


@pytest.mark.parametrize("name", _names())
def test_a_copy_before_reset_replays_the_seeded_episode(name):
    view = VIEWS[name]
    fresh = view.make()
    twin = copy.deepcopy(view.make())
    for env in (fresh, twin):
        view.reset(env, Hasher(), seed=11)
    assert _play(view, twin, 4) == _play(view, fresh, 4)


@pytest.mark.parametrize("env_id", ["RallySim/SimpleReturn-v0", "RallySim/HumanLikeReturn-v0"])
def test_a_rendered_env_copies_and_renders_with_its_own_renderer(env_id):
    import gymnasium as gym
    from conftest import gl_problem

    if gl_problem():
        pytest.skip(gl_problem())
    env = gym.make(env_id, render_mode="rgb_array").unwrapped
    env.reset(seed=2)
    frame = env.render()
    for twin in (copy.deepcopy(env), pickle.loads(pickle.dumps(env))):
        np.testing.assert_array_equal(twin.render(), frame)
        action = np.zeros(env.action_space.shape, np.float32)
        np.testing.assert_array_equal(twin.step(action)[0], copy.deepcopy(env).step(action)[0])
