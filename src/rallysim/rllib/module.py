"""The PPO RLModule RallySim trains with RLlib: RLlib's default one, with the log-std started
at the config's ``log_std_init`` as in the SB3 path (docs/reference.md §8: -0.5).

With ``free_log_std=True`` the policy head is one linear layer to the action means and a
state-independent log-std vector, the same parameterisation as SB3's and as RallySim's policy
files (``rallysim.policies.mlp``); ``vf_share_layers=False`` keeps the actor a plain MLP.
"""

from __future__ import annotations

import torch
from ray.rllib.algorithms.ppo.torch.default_ppo_torch_rl_module import DefaultPPOTorchRLModule

LOG_STD_INIT_KEY = "log_std_init"


class RallyPPOTorchRLModule(DefaultPPOTorchRLModule):
    """``DefaultPPOTorchRLModule`` whose free log-std starts at ``model_config["log_std_init"]``."""

    def setup(self) -> None:
        super().setup()
        init = (self.model_config or {}).get(LOG_STD_INIT_KEY)
        log_std = getattr(self.pi, "log_std", None)
        if init is not None and log_std is not None:
            with torch.no_grad():
                log_std.fill_(float(init))
