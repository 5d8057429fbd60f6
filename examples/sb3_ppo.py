"""Stable-Baselines3 PPO on the SIMPLE low-level task through RallySim's batched VecEnv.

    python examples/sb3_ppo.py                    # 1M steps, about 90 s on two cores
    python examples/sb3_ppo.py --smoke            # 131,072 steps: a quick check that it learns
    python examples/sb3_ppo.py --vec sb3          # SB3's own make_vec_env, for comparison
    python examples/sb3_ppo.py --save runs/ppo    # also write runs/ppo.{safetensors,json}
    python examples/sb3_ppo.py --sb3-defaults --n-envs 8 --steps 300000   # SB3's PPO settings

``rallysim.sb3.make_vec_env`` returns an SB3 ``VecEnv`` over one batched MuJoCo model (all
environments stepped in one call); ``--vec sb3`` builds SB3's ``DummyVecEnv`` of one Python
env per environment instead (same dynamics, same seeds; measured 4x slower end to end with
these settings, 2,800 against 12,000 steps/s, PPO's own updates included).

The settings are RallySim's own for this task (run A of ``docs/research-log/training-notes.md``, the
defaults of ``rallysim train low`` but for its rollout shape and lr decay): 64 envs x 64 steps per
update, minibatches of 1024, 10 epochs, lr 3e-4, a 64x64 tanh MLP and a log-std started at
-0.5 (std 0.61). ``--sb3-defaults`` uses SB3's own PPO settings instead (n_steps 2048,
minibatches of 64, 10 epochs, a 64x64 tanh MLP, log-std 0). Measured on a shared 2-core VM
(docs/using-with.md): 1M steps gave mean reward 1.54, hit rate 0.98, 89 % landed in court,
median landing error 1.2 m; SB3's defaults on 8 envs learn to hit within 300k steps but land
almost nothing in court.

Prints the training speed and a ``result:`` line with the deterministic policy's numbers over
500 seeded evaluation episodes (RallySim's own evaluator): mean reward, hit rate, share landed
in court, median landing error in metres.
"""

from __future__ import annotations

import argparse
import time

import torch
from stable_baselines3 import PPO
from stable_baselines3.common.env_util import make_vec_env as sb3_make_vec_env

from rallysim.eval.low_eval import evaluate_return
from rallysim.sb3 import make_vec_env

# The paper's low-level task: SimpleReturn-v1 with goals="uniform" is SimpleReturn-v0 step for
# step (v1 only changes the default goal distribution), without Gymnasium's notice that
# v0 is out of date.
ENV_ID = "RallySim/SimpleReturn-v1"
ENV_KWARGS = {"goals": "uniform"}


def positive_int(text: str) -> int:
    value = int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=positive_int,
                        help="training env steps (default 1,000,000)")
    parser.add_argument("--smoke", action="store_true",
                        help="a quick check: 131,072 steps (unless --steps), 64 eval episodes")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--n-envs", type=positive_int, default=64)
    parser.add_argument("--vec", choices=("rallysim", "sb3"), default="rallysim",
                        help="rallysim: one batched model (fast); sb3: SB3's make_vec_env")
    parser.add_argument("--save", metavar="PREFIX", help="write the actor as safetensors+JSON")
    parser.add_argument("--sb3-defaults", action="store_true",
                        help="SB3's default PPO settings instead of RallySim's")
    args = parser.parse_args()
    steps = args.steps if args.steps is not None else (131_072 if args.smoke else 1_000_000)
    episodes = 64 if args.smoke else 500

    # One torch thread: on a small CPU a second thread competes with the simulator.
    torch.set_num_threads(1)
    if args.vec == "rallysim":
        env = make_vec_env(ENV_ID, n_envs=args.n_envs, seed=args.seed, env_kwargs=ENV_KWARGS)
    else:
        env = sb3_make_vec_env(ENV_ID, n_envs=args.n_envs, seed=args.seed,
                               env_kwargs=ENV_KWARGS)
    if args.sb3_defaults:
        model = PPO("MlpPolicy", env, seed=args.seed, device="cpu", verbose=0)
    else:
        model = PPO(
            "MlpPolicy", env,
            n_steps=64, batch_size=1024, n_epochs=10, learning_rate=3e-4,
            gamma=0.99, gae_lambda=0.95, clip_range=0.2,
            policy_kwargs={"net_arch": {"pi": [64, 64], "vf": [64, 64]},
                           "activation_fn": torch.nn.Tanh, "log_std_init": -0.5},
            seed=args.seed, device="cpu", verbose=0,
        )
    start = time.perf_counter()
    model.learn(total_timesteps=steps)
    wall = time.perf_counter() - start
    rate = model.num_timesteps / wall
    print(f"speed: {rate:,.0f} env steps/s ({model.num_timesteps:,} steps in {wall:.1f} s, "
          f"{args.n_envs} envs via {args.vec})")

    def policy(obs):
        return model.predict(obs, deterministic=True)[0]

    ev = evaluate_return(policy, episodes=episodes, seed=12345)
    print(f"result: steps={model.num_timesteps} steps_per_s={rate:.0f} "
          f"mean_reward={ev.mean_reward:.3f} hit_rate={ev.hit_rate:.3f} "
          f"in_court={ev.in_rate:.3f} landing_error_m={ev.median_error:.2f} "
          f"episodes={ev.episodes}")
    if args.save:
        # safetensors + JSON (no pickle); load with rallysim.policies.mlp.load_policy(PREFIX)
        # or pass PREFIX to `rallysim evaluate --low PREFIX`
        from rallysim.train.export import save_policy

        weights, meta = save_policy(model, args.save, env_id=ENV_ID)
        print(f"saved {weights} and {meta}")


if __name__ == "__main__":
    main()
