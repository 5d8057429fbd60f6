"""Ray RLlib PPO (new API stack) on the two-player rally, one module shared by both players.

    python examples/rllib_rally.py               # 20,480 player decisions, about 45 s
    python examples/rllib_rally.py --smoke       # 2,048 (CI)

Needs the ``ray`` extra (``pip install torch==2.13.0 && pip install "rallysim[ray]"``); without
it the script says so in one line and exits with status 2.

The env is RallySim's own RLlib adapter of ``simple_rally_v0.parallel_env()``,
``rallysim.rllib.envs.RallyMultiAgentEnv`` (RLlib's ``ParallelPettingZooEnv`` keeps the agents
in a set, whose order changes from one process to the next), registered under the name
``"rallysim_mono"`` by ``register_rllib_envs()``. Both players map to one RLModule,
``"shared"``. For the whole training pipeline on a cluster (the same stages, configs and
policy files as ``rallysim train``) use ``rallysim train mono --backend rllib``.

Kept small and quick for one machine: a local Ray with two CPUs, the driver samples itself
(``num_env_runners=0``: on one machine extra env runners cost more than they give, see
docs/rllib.md), batches of 1,024 agent steps.

Seeded by ``--seed``, but a run also depends on Python's string hashing: with
``PYTHONHASHSEED`` unset, runs with one seed give one of two results (measured; presumably the
two agent ids are taken from a set somewhere in the sampling, in hash order). Fix it as well to
repeat a run exactly: ``PYTHONHASHSEED=0 python examples/rllib_rally.py``.

Prints the training speed and a ``result:`` line: agent steps sampled, the mean episode return
per player of the last iteration, and the mean rally length (hits by both players) of the
deterministic policy over seeded evaluation rallies.
"""

from __future__ import annotations

import argparse
import logging
import math
import sys
import time

import numpy as np

try:
    import ray
    from ray.rllib.algorithms.ppo import PPOConfig
    from ray.rllib.core.rl_module.multi_rl_module import MultiRLModuleSpec
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec

    from rallysim.rllib.envs import ENV_NAMES, SHARED_MODULE, register_rllib_envs, shared_module
    from rallysim.rllib.module import RallyPPOTorchRLModule
    from rallysim.rllib.runner import module_policy
except ModuleNotFoundError as err:
    if (err.name or "").partition(".")[0] not in ("ray", "torch"):
        raise
    print(f"rllib_rally.py needs Ray RLlib and torch ({err}): install torch first, then the "
          'ray extra: pip install torch==2.13.0 && pip install "rallysim[ray]"', file=sys.stderr)
    sys.exit(2)
from rallysim.eval.rally_eval import rally_lengths_direct

BATCH = 1024  # agent steps (decisions of either player) per PPO update


def positive_int(text: str) -> int:
    value = int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=positive_int,
                        help="agent steps to sample (default 20,480)")
    parser.add_argument("--smoke", action="store_true",
                        help="a quick check: 2,048 steps (unless --steps), 16 eval rallies")
    parser.add_argument("--seed", type=int, default=0)
    args = parser.parse_args()
    steps = args.steps if args.steps is not None else (2 * BATCH if args.smoke else 20 * BATCH)
    eval_rallies = 16 if args.smoke else 200

    logging.getLogger("ray.rllib").setLevel(logging.ERROR)  # API-stack notices on every run
    ray.init(num_cpus=2, include_dashboard=False, logging_level="ERROR", log_to_driver=False)
    register_rllib_envs()  # "rallysim_low", "rallysim_high", "rallysim_mono"
    module = RLModuleSpec(
        # RLlib's default PPO module, with the log-std started at -0.5 as RallySim's trainer
        module_class=RallyPPOTorchRLModule,
        model_config={"fcnet_hiddens": [64, 64], "fcnet_activation": "tanh",
                      "vf_share_layers": False, "free_log_std": True, "log_std_init": -0.5},
    )
    config = (
        PPOConfig()
        .environment(ENV_NAMES["mono"], env_config={"shuttle": "paper"})
        .env_runners(num_env_runners=0, num_envs_per_env_runner=4)
        .multi_agent(policies={SHARED_MODULE}, policy_mapping_fn=shared_module,
                     count_steps_by="agent_steps")
        .rl_module(rl_module_spec=MultiRLModuleSpec(rl_module_specs={SHARED_MODULE: module}))
        .training(train_batch_size_per_learner=BATCH, minibatch_size=256, num_epochs=10,
                  lr=3e-4, gamma=0.99, lambda_=0.95, clip_param=0.2, entropy_coeff=0.0,
                  use_kl_loss=False, vf_clip_param=float("inf"))
        .debugging(seed=args.seed)
    )
    algo = config.build_algo()
    try:
        sampled, ep_return = 0, math.nan
        start = time.perf_counter()
        while sampled < steps:
            result = algo.train()
            runners = result["env_runners"]
            per_agent = runners.get("num_agent_steps_sampled_lifetime", {})
            sampled = int(sum(per_agent.values()) if isinstance(per_agent, dict) else per_agent)
            returns = runners.get("agent_episode_returns_mean") or {}
            if returns:  # per player; none in an iteration where no rally finished
                ep_return = float(np.mean(list(returns.values())))
        wall = time.perf_counter() - start
        rate = sampled / wall
        print(f"speed: {rate:,.0f} agent steps/s ({sampled:,} player decisions in {wall:.1f} "
              "s, training incl. updates)")
        # the shared module's deterministic actor as a NumPy policy for RallySim's evaluator
        policy = module_policy(algo.get_module(SHARED_MODULE))
        lengths = rally_lengths_direct(policy, eval_rallies, seed=12345)
        print(f"result: requested={steps} steps={sampled} steps_per_s={rate:.0f} "
              f"train_return={ep_return:.3f} mean_rally={lengths.mean():.2f} "
              f"rallies={len(lengths)}")
    finally:
        algo.stop()
        ray.shutdown()


if __name__ == "__main__":
    main()
