"""Keeping PPO's Gaussian inside the action range (rallysim.train.action_range)."""

from __future__ import annotations

import gymnasium as gym
import numpy as np
import pytest
import torch

from rallysim.train.action_range import cap_log_std, log_std_cap, pull_mean_into_range
from rallysim.train.config import TrainConfig


def _policy(low: float, high: float) -> torch.nn.Module:
    from stable_baselines3.common.policies import ActorCriticPolicy

    obs = gym.spaces.Box(-1.0, 1.0, (3,), np.float32)
    act = gym.spaces.Box(np.array([low, -1.0], np.float32), np.array([high, 1.0], np.float32))
    torch.manual_seed(0)
    return ActorCriticPolicy(obs, act, lambda _: 3e-4)


def _mean_grad(policy: torch.nn.Module, obs: torch.Tensor
               ) -> tuple[torch.Tensor, torch.Tensor]:
    """The actor's mean and the gradient of the sum of means w.r.t. the action net's bias."""
    policy.zero_grad()
    latent = policy.mlp_extractor.forward_actor(obs)
    mean = policy.action_net(latent)
    mean.sum().backward()
    return mean.detach(), policy.action_net.bias.grad.clone()


def test_the_pull_adds_the_penalty_gradient_and_leaves_the_mean() -> None:
    obs = torch.linspace(-1, 1, 24).reshape(8, 3)
    plain, hooked = _policy(2.0, 6.0), _policy(2.0, 6.0)
    pull_mean_into_range(hooked, 10.0)
    # move the means beyond both ends of the first axis (range [2, 6]: centre 4, half 2)
    bias = torch.tensor([-3.0, 0.0])
    for p in (plain, hooked):
        with torch.no_grad():
            p.action_net.bias.copy_(bias)
    with torch.no_grad():
        plain.action_net.weight[0].mul_(40.0)
        hooked.action_net.weight[0].mul_(40.0)
    mean_plain, grad_plain = _mean_grad(plain, obs)
    mean_hooked, grad_hooked = _mean_grad(hooked, obs)
    assert torch.equal(mean_plain, mean_hooked)  # the forward value is unchanged
    unit = (mean_plain - torch.tensor([4.0, 0.0])) / torch.tensor([2.0, 1.0])
    beyond = (unit.abs() - 1).clamp(min=0) * unit.sign()
    assert (beyond[:, 0] != 0).sum() >= 2  # the case exercises the penalty
    expected = 10.0 * 2 * beyond / torch.tensor([2.0, 1.0]) / len(obs)
    assert torch.allclose(grad_hooked - grad_plain, expected.sum(0), atol=1e-5)
    # with no gradient taken (rollouts, predictions) nothing is wrapped
    with torch.no_grad():
        assert torch.equal(hooked.action_net(torch.zeros(1, 64)), plain.action_net(
            torch.zeros(1, 64)))


def test_the_log_std_cap_falls_linearly_and_keeps_lower_values() -> None:
    assert log_std_cap(-0.5, -2.0, 0.0) == -0.5
    assert log_std_cap(-0.5, -2.0, 0.5) == pytest.approx(-1.25)
    assert log_std_cap(-0.5, -2.0, 1.7) == -2.0
    policy = _policy(-1.0, 1.0)
    with torch.no_grad():
        policy.log_std.copy_(torch.tensor([-0.5, -3.0]))
    cap_log_std(policy, -1.25)
    assert policy.log_std.tolist() == [-1.25, -3.0]


def test_the_settings_are_checked_and_refused_by_rllib() -> None:
    with pytest.raises(ValueError, match=r"ppo\.log_std_end .* must be <= -0\.5, got 0\.0"):
        TrainConfig.from_dict({"stage": "high", "ppo": {"log_std_end": 0.0}})
    with pytest.raises(ValueError, match=r"ppo\.mean_bound"):
        TrainConfig.from_dict({"stage": "high", "ppo": {"mean_bound": -1.0}})
    config = TrainConfig.from_dict({"stage": "high", "ppo": {"log_std_end": -2.0}})
    assert config.ppo.log_std_end == -2.0 and config.ppo.mean_bound == 0.0
    pytest.importorskip("ray")
    from rallysim.rllib.ppo_config import build_ppo_config

    with pytest.raises(ValueError, match="SB3-only"):
        build_ppo_config(config, env_runners=0)
