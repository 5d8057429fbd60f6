"""Evaluation rallies: each slot plays exactly one rally; baselines order as expected."""

import numpy as np
import pytest

from rallysim.eval.rally_eval import rally_lengths_direct, rally_lengths_turns, random_goals
from rallysim.policies import ScriptedController
from rallysim.policies.registry import goal_conditioned


@pytest.mark.slow
def test_scripted_hierarchy_rallies_long_and_random_motor_control_does_not():
    lengths = rally_lengths_turns(random_goals(0), "scripted", 32, seed=0)
    assert lengths.shape == (32,) and lengths.min() >= 0 and lengths.max() <= 50
    assert lengths.mean() > 25
    rng = np.random.default_rng(0)
    flails = rally_lengths_direct(lambda o: rng.uniform(-1, 1, (len(o), 3)), 32, seed=0)
    assert flails.mean() < 2


def test_goal_conditioned_low_level_reads_the_goal():
    c = ScriptedController()
    seen = {}

    def low(x):
        seen["x"] = x
        return c.act_return(x)

    act = goal_conditioned(low)
    obs = np.zeros((2, 20), np.float32)
    act(obs, np.array([2.0, 6.0]))
    assert seen["x"].shape == (2, 17) and seen["x"][:, 16].tolist() == [-1.0, 1.0]
