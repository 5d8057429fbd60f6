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


def _play(view: View, env, seed: int) -> str:
    h = Hasher()
    view.play(env, STEPS, np.random.default_rng(seed), h)
    return h.hexdigest()


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
@pytest.mark.parametrize("name", sorted(VIEWS))
def test_a_copy_mid_episode_steps_like_its_original(name, how):
    view = VIEWS[name]
    env = view.make()
    view.reset(env, Hasher(), seed=3)
    view.play(env, 7 if view.api in ("aec",) or "turn" in name else 30,
              np.random.default_rng(0), Hasher())
    twin = copy.deepcopy(env) if how == "deepcopy" else pickle.loads(pickle.dumps(env))
    original, copied = _play(view, env, 1), _play(view, twin, 1)
    assert copied == original
    # the original was not disturbed by the copy, and the players really move
    assert _play(view, env, 2) != _play(view, twin, 5)


@pytest.mark.parametrize("name", sorted(VIEWS))
def test_a_copy_before_reset_replays_the_seeded_episode(name):
    view = VIEWS[name]
    fresh = view.make()
    twin = copy.deepcopy(view.make())
    for env in (fresh, twin):
        view.reset(env, Hasher(), seed=11)
    assert _play(view, twin, 4) == _play(view, fresh, 4)
