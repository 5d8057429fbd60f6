"""CleanRL-style single-file PPO (continuous actions) on RallySim/SimpleReturn-v0.

    python examples/cleanrl_ppo.py               # 1M steps, about a minute on two cores
    python examples/cleanrl_ppo.py --smoke       # a few thousand steps (CI)

Everything is in this file, in the style of CleanRL's ``ppo_continuous_action.py``: a vector
env, an actor-critic MLP, GAE, the clipped surrogate objective. The settings are RallySim's
own for this task (as ``examples/sb3_ppo.py``): 64 envs x 64 steps per update, 4 minibatches
of 1024, 10 epochs, a constant lr 3e-4, log-std started at -0.5.

Written for Gymnasium 1.x (CleanRL's own scripts target Gymnasium 0.29 and break on 1.x, e.g.
``TransformObservation``'s new signature); no wrappers are needed here because RallySim's
observations are already scaled to [-1, 1] and its env clips actions to [-1, 1] itself.

The env is ``gym.make_vec`` of the registered id with its *vector entry point*: one batched
MuJoCo model steps all environments in one call. ``autoreset_mode="same_step"`` gives the
semantics this loop assumes: the observation returned with ``done`` is already the next
episode's first, and the last one is in ``info["final_obs"]`` (used to bootstrap the value of
an episode cut by the time limit).

Prints the speed and a ``result:`` line: the deterministic policy's mean reward, hit rate,
share landed in court and median landing error over seeded evaluation episodes.
"""

from __future__ import annotations

import argparse
import time

import gymnasium as gym
import numpy as np
import torch
from torch import nn
from torch.distributions.normal import Normal

import rallysim  # noqa: F401  (registers RallySim/SimpleReturn-v0)
from rallysim.eval.low_eval import evaluate_return

ENV_ID = "RallySim/SimpleReturn-v0"


def parse_args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=int, help="total env steps (default 1,000,000)")
    p.add_argument("--smoke", action="store_true",
                   help="a quick check: 8,192 steps (unless --steps), 64 eval episodes")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--num-envs", type=int, default=64)
    p.add_argument("--num-steps", type=int, default=64, help="steps per env per rollout")
    p.add_argument("--num-minibatches", type=int, default=4)
    p.add_argument("--update-epochs", type=int, default=10)
    p.add_argument("--learning-rate", type=float, default=3e-4)
    p.add_argument("--anneal-lr", action=argparse.BooleanOptionalAction, default=False,
                   help="decay the learning rate linearly to 0 (CleanRL's default; over 1M "
                        "steps it ended lower here)")
    p.add_argument("--gamma", type=float, default=0.99)
    p.add_argument("--gae-lambda", type=float, default=0.95)
    p.add_argument("--clip-coef", type=float, default=0.2)
    p.add_argument("--ent-coef", type=float, default=0.0)
    p.add_argument("--vf-coef", type=float, default=0.5)
    p.add_argument("--max-grad-norm", type=float, default=0.5)
    p.add_argument("--log-std-init", type=float, default=-0.5)
    args = p.parse_args()
    args.total_timesteps = args.steps or (8192 if args.smoke else 1_000_000)
    args.eval_episodes = 64 if args.smoke else 500
    args.batch_size = args.num_envs * args.num_steps
    args.minibatch_size = args.batch_size // args.num_minibatches
    args.num_iterations = max(1, args.total_timesteps // args.batch_size)
    return args


def layer_init(layer: nn.Linear, std: float = np.sqrt(2), bias: float = 0.0) -> nn.Linear:
    nn.init.orthogonal_(layer.weight, std)
    nn.init.constant_(layer.bias, bias)
    return layer


class Agent(nn.Module):
    def __init__(self, obs_size: int, act_size: int, log_std_init: float) -> None:
        super().__init__()
        self.critic = nn.Sequential(
            layer_init(nn.Linear(obs_size, 64)), nn.Tanh(),
            layer_init(nn.Linear(64, 64)), nn.Tanh(),
            layer_init(nn.Linear(64, 1), std=1.0),
        )
        self.actor_mean = nn.Sequential(
            layer_init(nn.Linear(obs_size, 64)), nn.Tanh(),
            layer_init(nn.Linear(64, 64)), nn.Tanh(),
            layer_init(nn.Linear(64, act_size), std=0.01),
        )
        # RallySim's trainer starts the log-std at -0.5 (std 0.61, the original ML-Agents
        # setting) instead of CleanRL's 0: see --log-std-init
        self.actor_logstd = nn.Parameter(torch.full((1, act_size), log_std_init))

    def get_value(self, x: torch.Tensor) -> torch.Tensor:
        return self.critic(x)

    def get_action_and_value(self, x: torch.Tensor, action: torch.Tensor | None = None):
        mean = self.actor_mean(x)
        probs = Normal(mean, self.actor_logstd.expand_as(mean).exp())
        if action is None:
            action = probs.sample()
        return action, probs.log_prob(action).sum(1), probs.entropy().sum(1), self.critic(x)


def main() -> None:
    args = parse_args()
    np.random.seed(args.seed)
    torch.manual_seed(args.seed)
    torch.set_num_threads(1)  # on a small CPU a second thread competes with the simulator

    envs = gym.make_vec(ENV_ID, num_envs=args.num_envs, vectorization_mode="vector_entry_point",
                        autoreset_mode="same_step")
    n = args.num_envs
    obs_size = envs.single_observation_space.shape[0]
    act_size = envs.single_action_space.shape[0]
    agent = Agent(obs_size, act_size, args.log_std_init)
    optimizer = torch.optim.Adam(agent.parameters(), lr=args.learning_rate, eps=1e-5)

    obs = torch.zeros((args.num_steps, n, obs_size))
    actions = torch.zeros((args.num_steps, n, act_size))
    logprobs = torch.zeros((args.num_steps, n))
    rewards = torch.zeros((args.num_steps, n))
    dones = torch.zeros((args.num_steps, n))
    values = torch.zeros((args.num_steps, n))

    global_step = 0
    episode_return = np.zeros(n)
    finished: list[float] = []
    next_obs_np, _ = envs.reset(seed=args.seed)
    next_obs = torch.as_tensor(next_obs_np)
    next_done = torch.zeros(n)
    start = time.perf_counter()
    for iteration in range(1, args.num_iterations + 1):
        if args.anneal_lr:
            frac = 1.0 - (iteration - 1.0) / args.num_iterations
            optimizer.param_groups[0]["lr"] = frac * args.learning_rate

        for step in range(args.num_steps):
            global_step += n
            obs[step] = next_obs
            dones[step] = next_done
            with torch.no_grad():
                action, logprob, _, value = agent.get_action_and_value(next_obs)
            values[step] = value.flatten()
            actions[step] = action
            logprobs[step] = logprob

            next_obs_np, reward, terminated, truncated, info = envs.step(action.numpy())
            episode_return += reward
            reward = reward.astype(np.float32)
            cut = truncated & ~terminated
            if cut.any():  # time limit: the episode goes on beyond it, so bootstrap its value
                final = torch.as_tensor(info["final_obs"][cut])
                with torch.no_grad():
                    reward[cut] += args.gamma * agent.get_value(final).flatten().numpy()
            done = terminated | truncated
            finished += episode_return[done].tolist()
            episode_return[done] = 0.0
            rewards[step] = torch.as_tensor(reward)
            next_obs = torch.as_tensor(next_obs_np)
            next_done = torch.as_tensor(done, dtype=torch.float32)

        # generalised advantage estimation
        with torch.no_grad():
            next_value = agent.get_value(next_obs).reshape(1, -1)
            advantages = torch.zeros_like(rewards)
            lastgaelam = torch.zeros(n)
            for t in reversed(range(args.num_steps)):
                if t == args.num_steps - 1:
                    nextnonterminal = 1.0 - next_done
                    nextvalues = next_value
                else:
                    nextnonterminal = 1.0 - dones[t + 1]
                    nextvalues = values[t + 1]
                delta = rewards[t] + args.gamma * nextvalues * nextnonterminal - values[t]
                lastgaelam = (delta + args.gamma * args.gae_lambda * nextnonterminal
                              * lastgaelam)
                advantages[t] = lastgaelam
            returns = advantages + values

        b_obs = obs.reshape(-1, obs_size)
        b_actions = actions.reshape(-1, act_size)
        b_logprobs = logprobs.reshape(-1)
        b_advantages = advantages.reshape(-1)
        b_returns = returns.reshape(-1)

        b_inds = np.arange(args.batch_size)
        for _epoch in range(args.update_epochs):
            np.random.shuffle(b_inds)
            for begin in range(0, args.batch_size, args.minibatch_size):
                mb = b_inds[begin:begin + args.minibatch_size]
                _, newlogprob, entropy, newvalue = agent.get_action_and_value(
                    b_obs[mb], b_actions[mb])
                ratio = (newlogprob - b_logprobs[mb]).exp()
                mb_adv = b_advantages[mb]
                mb_adv = (mb_adv - mb_adv.mean()) / (mb_adv.std() + 1e-8)
                pg_loss = torch.max(
                    -mb_adv * ratio,
                    -mb_adv * torch.clamp(ratio, 1 - args.clip_coef, 1 + args.clip_coef),
                ).mean()
                v_loss = 0.5 * ((newvalue.view(-1) - b_returns[mb]) ** 2).mean()
                loss = pg_loss - args.ent_coef * entropy.mean() + args.vf_coef * v_loss
                optimizer.zero_grad()
                loss.backward()
                nn.utils.clip_grad_norm_(agent.parameters(), args.max_grad_norm)
                optimizer.step()

        if iteration % max(1, args.num_iterations // 10) == 0 and finished:
            sps = global_step / (time.perf_counter() - start)
            print(f"step {global_step:>9,}  episodic return {np.mean(finished[-500:]):6.3f}  "
                  f"SPS {sps:,.0f}", flush=True)

    wall = time.perf_counter() - start
    envs.close()
    rate = global_step / wall
    print(f"speed: {rate:,.0f} env steps/s ({global_step:,} steps in {wall:.1f} s)")

    def policy(x: np.ndarray) -> np.ndarray:
        with torch.no_grad():  # the deterministic action: the Gaussian's mean
            return agent.actor_mean(torch.as_tensor(x)).numpy()

    ev = evaluate_return(policy, episodes=args.eval_episodes, seed=12345)
    print(f"result: steps={global_step} steps_per_s={rate:.0f} "
          f"train_return={np.mean(finished[-500:]) if finished else float('nan'):.3f} "
          f"mean_reward={ev.mean_reward:.3f} hit_rate={ev.hit_rate:.3f} "
          f"in_court={ev.in_rate:.3f} landing_error_m={ev.median_error:.2f} "
          f"episodes={ev.episodes}")


if __name__ == "__main__":
    main()
