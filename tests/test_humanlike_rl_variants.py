"""benchmarks/humanlike_rl_variants.py: the reshaped hit rewards it trains on."""

from __future__ import annotations

import importlib.util
from pathlib import Path

import numpy as np
import pytest

from rallysim.envs.humanlike_return_v0 import HumanLikeReturnVectorEnv
from rallysim.policies.aimed_swing import AimedSwing

SCRIPT = Path(__file__).resolve().parents[1] / "benchmarks" / "humanlike_rl_variants.py"


def _module():
    spec = importlib.util.spec_from_file_location("humanlike_rl_variants", SCRIPT)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)
    return module


@pytest.mark.parametrize("kind, k", [("exp", 0.3), ("only", 0.3), ("cos", 2.0)])
def test_a_variant_changes_only_the_hits_reward(kind, k):
    """AimedSwing hits every serve: on those steps the reward is the variant's, on every other
    step it is the env's (zero)."""
    variants = _module()
    env = variants.VelocityReward(HumanLikeReturnVectorEnv(16, autoreset_mode="same_step",
                                                           seed=4), kind, k)
    swing = AimedSwing("paper")
    obs, _ = env.reset(seed=4)
    hits = 0
    for _ in range(40):
        obs, reward, _, _, info = env.step(swing(obs))
        hit = info["hit"]
        d = info["velocity_error"][hit]
        if kind == "exp":
            expected = 0.5 + 0.5 * np.exp(-k * d)
        elif kind == "only":
            expected = np.exp(-k * d)
        else:
            angle = np.deg2rad(info["angle_error"][hit])
            expected = 0.5 + 0.25 * np.cos(angle) + 0.25 * np.exp(
                -k * np.abs(info["speed_error"][hit]))
        np.testing.assert_allclose(reward[hit], expected, rtol=1e-12)
        assert (reward[~hit] == 0.0).all()
        hits += int(hit.sum())
    assert hits >= 15
    assert variants.parse_variant("cos:2") == ("cos", 2.0)
    with pytest.raises(Exception, match="variant"):
        variants.parse_variant("exp")
