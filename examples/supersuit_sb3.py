"""SuperSuit + Stable-Baselines3 PPO on the two-player rally, one policy for both players.

    python examples/supersuit_sb3.py               # 20,480 steps, about 20 s on two cores
    python examples/supersuit_sb3.py --vec native  # the same PPO on RallySim's batched slots
    python examples/supersuit_sb3.py --smoke       # 2,048 steps (CI)

SuperSuit's ``pettingzoo_env_to_vec_env_v1`` turns the PettingZoo parallel env
``rallysim.envs.simple_rally_v0.parallel_env()`` into a vector env with one slot per player,
and ``concat_vec_envs_v1`` stacks copies of it behind SB3's ``VecEnv`` API, so PPO trains one
policy that plays both sides. One step of a slot is one decision of one player.

Two SuperSuit 3.11 quirks on SB3 2.x are worked around here: its ``VecEnv`` has no ``seed()``
(so PPO gets no ``seed=``: the envs are seeded through ``reset(seed=...)`` and torch through
SB3's ``set_random_seed``), and it writes no episode statistics (``VecMonitor`` adds them).

Each env there is a Python object stepped one at a time. ``--vec native`` trains the same PPO
on RallySim's own batched version of the same slots instead,
``NativeVecEnv(SimpleRallyVectorEnv(rallies, autoreset_mode="same_step"))`` (what
``rallysim train mono`` uses): the same rally with the same observation and action spaces
per slot (other random serves for a seed), all rallies stepped in one call.

Prints the training speed and a ``result:`` line: steps, the mean return per player of the
last 100 training episodes (SB3's ``ep_rew_mean``), and the mean rally length (hits by both
players) of the deterministic policy over seeded evaluation rallies.
"""

from __future__ import annotations

import argparse
import time
import warnings

import numpy as np
import torch
from stable_baselines3 import PPO
from stable_baselines3.common.utils import set_random_seed

from rallysim.eval.rally_eval import rally_lengths_direct


def positive_int(text: str) -> int:
    value = int(text)
    if value <= 0:
        raise argparse.ArgumentTypeError(f"must be a positive integer, got {text}")
    return value


def supersuit_env(rallies: int, seed: int):
    """SuperSuit's vector env of ``rallies`` parallel rallies (two slots each) for SB3."""
    import supersuit as ss
    from stable_baselines3.common.vec_env import VecMonitor

    from rallysim.envs.simple_rally_v0 import parallel_env

    env = ss.pettingzoo_env_to_vec_env_v1(parallel_env())  # 2 slots: player_0, player_1
    env = ss.concat_vec_envs_v1(env, rallies, num_cpus=0, base_class="stable_baselines3")
    env.venv.reset(seed=seed)  # later resets continue these seeded streams
    with warnings.catch_warnings():
        # SB3's VecEnv asks the env for its render_mode through get_attr, which SuperSuit
        # 3.11's ConcatVecEnv does not have; SB3 then warns and uses None, which is right here
        # (nothing is rendered)
        warnings.filterwarnings("ignore", "The `render_mode` attribute is not defined",
                                UserWarning)
        return VecMonitor(env)


def native_env(rallies: int, seed: int):
    """RallySim's batched rally slots behind SB3's VecEnv API (writes episode statistics)."""
    from rallysim.envs.simple_rally_v0 import SimpleRallyVectorEnv
    from rallysim.sb3 import NativeVecEnv

    return NativeVecEnv(SimpleRallyVectorEnv(rallies, autoreset_mode="same_step", seed=seed))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--steps", type=positive_int,
                        help="training steps, all slots (default 20,480)")
    parser.add_argument("--smoke", action="store_true",
                        help="a quick check: 2,048 steps (unless --steps), 16 eval rallies")
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--rallies", type=positive_int, default=8,
                        help="rallies stepped together")
    parser.add_argument("--vec", choices=("supersuit", "native"), default="supersuit",
                        help="supersuit: SuperSuit over parallel_env(); native: RallySim's "
                             "batched SimpleRallyVectorEnv slots")
    args = parser.parse_args()
    steps = args.steps if args.steps is not None else (2048 if args.smoke else 20_480)
    eval_rallies = 16 if args.smoke else 200

    torch.set_num_threads(1)  # on a small CPU a second thread competes with the simulator
    make = supersuit_env if args.vec == "supersuit" else native_env
    env = make(args.rallies, args.seed)
    set_random_seed(args.seed)
    # RallySim's settings for the rally (rallysim/train/configs/mono.yaml), scaled to fewer
    # envs: 64 steps per slot per update, 10 epochs, log-std started at -0.5
    model = PPO("MlpPolicy", env, n_steps=64, batch_size=256, n_epochs=10,
                learning_rate=3e-4, policy_kwargs={"log_std_init": -0.5}, device="cpu",
                verbose=0)
    start = time.perf_counter()
    model.learn(total_timesteps=steps)
    wall = time.perf_counter() - start
    rate = model.num_timesteps / wall
    print(f"speed: {rate:,.0f} env steps/s ({model.num_timesteps:,} player decisions in "
          f"{wall:.1f} s, {env.num_envs} slots via {args.vec})")

    def policy(obs: np.ndarray) -> np.ndarray:
        return model.predict(obs, deterministic=True)[0]

    returns = [e["r"] for e in model.ep_info_buffer]  # the last 100 episodes
    lengths = rally_lengths_direct(policy, eval_rallies, seed=12345)
    print(f"result: vec={args.vec} steps={model.num_timesteps} steps_per_s={rate:.0f} "
          f"train_return={np.mean(returns) if returns else float('nan'):.3f} "
          f"mean_rally={lengths.mean():.3f} rallies={len(lengths)}")


if __name__ == "__main__":
    main()
