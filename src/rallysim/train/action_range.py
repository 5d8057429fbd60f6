"""Keeping PPO's Gaussian inside a bounded action range (SB3 path; ``ppo.mean_bound`` and
``ppo.log_std_end``). Both are off by default, and then no trained bit changes.

A clipped Gaussian policy is judged by its clipped mean, and it trains on clipped samples.
Where the best actions lie in a narrow band near the end of the range and the spread is wide,
the stochastic policy does best with its mean beyond the end (the samples that fall outside the
band then clip onto the end instead of off a cliff on the band's other side), while the clipped
mean, the end itself, is a poor action. Beyond the end every sample clips to the same action, so
nothing pulls the mean back (docs/research-log/reproduce.md, "The high level's mean beyond the
range's end"). Two remedies, each a loss or a schedule, not a change of the policy's form (an
exported policy is still the MLP's mean, clipped):

- ``mean_bound``: a penalty ``mean_bound * mean((|mu| - 1)_+^2)`` on the mean's excess beyond
  the range (in units of its half-width), added as a gradient on the mean in the update, so the
  mean stays where the clipped samples still tell it which way is better;
- ``log_std_end``: an upper bound on the state-independent log-std, lowered linearly from
  ``log_std_init`` to this over the budget, so that by the end the policy PPO optimises is
  close to its mean, the action it is judged and used by.
"""

from __future__ import annotations

from typing import Any

import numpy as np


def pull_mean_into_range(policy: Any, weight: float) -> None:
    """Add the gradient of ``weight * mean((|mu| - 1)_+^2)`` to the mean's in every update of
    SB3 ``policy`` (its ``action_net``'s output; mu in units of the action range's half-width,
    averaged over the batch and summed over action dimensions). The forward value is unchanged."""
    import torch

    space = policy.action_space
    centre = torch.as_tensor((space.high + space.low) / 2.0, dtype=torch.float32)
    half = torch.as_tensor((space.high - space.low) / 2.0, dtype=torch.float32)

    class Pull(torch.autograd.Function):
        @staticmethod
        def forward(ctx: Any, mean: Any) -> Any:
            ctx.save_for_backward(mean)
            return mean.view_as(mean)

        @staticmethod
        def backward(ctx: Any, grad: Any) -> Any:
            (mean,) = ctx.saved_tensors
            unit = (mean - centre) / half
            excess = torch.clamp(unit.abs() - 1.0, min=0.0) * torch.sign(unit)
            return grad + weight * 2.0 * excess / half / mean.shape[0]

    def hook(module: Any, inputs: Any, output: Any) -> Any:
        return Pull.apply(output) if torch.is_grad_enabled() else output

    policy.action_net.register_forward_hook(hook)


def log_std_cap(start: float, end: float, progress: float) -> float:
    """The log-std's upper bound at ``progress`` (0 to 1) of the budget."""
    return start + (end - start) * float(np.clip(progress, 0.0, 1.0))


def cap_log_std(policy: Any, cap: float) -> None:
    """Lower SB3 ``policy``'s log-std to at most ``cap`` (a value below it is kept)."""
    import torch

    with torch.no_grad():
        policy.log_std.clamp_(max=cap)
