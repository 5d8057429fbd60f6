"""``TrainConfig`` -> RLlib ``PPOConfig`` (new API stack), the mapping written once.

The table in ``docs/rllib.md`` lists every field of the ``ppo`` section. Where the two libraries
differ by default, RLlib is set to behave as SB3 does: no KL penalty unless ``ppo.target_kl`` is
set (RLlib adapts a penalty toward it; SB3 stops the update early), no clipping of the value
loss, a separate critic network and a state-independent log-std started at
``ppo.log_std_init``. The rollout batch counts the stage's budget unit: env steps for the low
level (decisions), agent steps for the multi-agent stages (turns, players' decisions), whose two
players share one RLModule. The stage object (``rallysim.train.stages``) says which it is and
what its env needs.
"""

from __future__ import annotations

from typing import Any

from ray.rllib.algorithms.ppo import PPOConfig
from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
from ray.rllib.core.rl_module.rl_module import RLModuleSpec

from rallysim.rllib.envs import ENV_NAMES, SHARED_MODULE, shared_module
from rallysim.rllib.module import LOG_STD_INIT_KEY, RallyPPOTorchRLModule
from rallysim.train import stages
from rallysim.train.config import TrainConfig


def env_config(config: TrainConfig) -> dict[str, Any]:
    """What an env runner needs to rebuild the stage's env (plain values only)."""
    return stages.of(config).env_options(config)


def model_config(config: TrainConfig) -> dict[str, Any]:
    ppo = config.ppo
    return {"fcnet_hiddens": list(ppo.net_arch), "fcnet_activation": ppo.activation,
            "vf_share_layers": False, "free_log_std": True,
            LOG_STD_INIT_KEY: ppo.log_std_init}


def envs_per_runner(config: TrainConfig, env_runners: int) -> int:
    """Envs each env runner steps: the config's ``ppo.n_envs`` slots as envs (a rally env
    holds one slot per player), shared out (at least one)."""
    envs = config.ppo.n_envs // stages.of(config).slots_per_env
    return max(1, envs // max(1, env_runners))


def build_ppo_config(config: TrainConfig, env_runners: int = 2,
                     sample_timeout_s: float = 600.0) -> PPOConfig:
    """RLlib PPO settings equivalent to ``config`` (see the module docstring's table).

    ``env_runners``: remote env runners (Ray actors of one CPU each, placed by Ray across the
    cluster); 0 samples in the driver."""
    if env_runners < 0:
        raise ValueError(f"env_runners must be >= 0, got {env_runners}")
    ppo_settings = config.ppo
    if ppo_settings.mean_bound or ppo_settings.log_std_end is not None:
        raise ValueError("ppo.mean_bound and ppo.log_std_end are SB3-only settings "
                         "(rallysim.train.action_range); train with --backend sb3 or unset them")
    lr: Any = ppo_settings.learning_rate
    if ppo_settings.anneal_lr:
        lr = [[0, ppo_settings.learning_rate], [config.budget, 0.0]]
    multi = stages.of(config).multi_agent
    spec = RLModuleSpec(module_class=RallyPPOTorchRLModule, model_config=model_config(config))
    ppo = (
        PPOConfig()
        .environment(ENV_NAMES[config.stage], env_config=env_config(config))
        .env_runners(
            num_env_runners=env_runners,
            num_envs_per_env_runner=envs_per_runner(config, env_runners),
            num_cpus_per_env_runner=1,
            rollout_fragment_length="auto",
            sample_timeout_s=sample_timeout_s,
            # the low-level task is natively batched: one env object steps all of a runner's
            # games; the multi-agent envs are stepped one by one (RLlib's only mode for them)
            gym_env_vectorize_mode="vector_entry_point" if not multi else "sync",
        )
        .training(
            lr=lr, gamma=ppo_settings.gamma, lambda_=ppo_settings.gae_lambda,
            clip_param=ppo_settings.clip_range, entropy_coeff=ppo_settings.ent_coef,
            vf_loss_coeff=ppo_settings.vf_coef, vf_clip_param=float("inf"),
            grad_clip=ppo_settings.max_grad_norm, grad_clip_by="global_norm",
            num_epochs=ppo_settings.n_epochs, minibatch_size=ppo_settings.batch_size,
            train_batch_size_per_learner=ppo_settings.n_envs * ppo_settings.n_steps,
            use_kl_loss=ppo_settings.target_kl is not None,
            kl_target=ppo_settings.target_kl if ppo_settings.target_kl is not None else 0.01,
        )
        .debugging(seed=config.seed)
    )
    if multi:
        ppo = (ppo.multi_agent(policies={SHARED_MODULE}, policy_mapping_fn=shared_module,
                               count_steps_by="agent_steps")
               .rl_module(rl_module_spec=MultiRLModuleSpec(
                   rl_module_specs={SHARED_MODULE: spec})))
    else:
        ppo = ppo.rl_module(rl_module_spec=spec)
    return ppo
