"""Single-file PPO (continuous actions) on the SIMPLE low-level task, in CleanRL's style.

    python examples/cleanrl_ppo.py               # about 1M steps, under two minutes on two cores
    python examples/cleanrl_ppo.py --smoke       # 131,072 steps: a quick check that it learns

Written for this project in the style of CleanRL's single-file scripts: the whole algorithm in
one file, every setting on the command line and the training loop read top to bottom. It is
not a copy of CleanRL's ``ppo_continuous_action.py``; what follows is this file's own layout:

- ``ActorCritic``: separate tanh MLPs for the action mean and the value (``mlp()``), and a
  state-independent log standard deviation started at -0.5 (std 0.61, RallySim's setting);
- ``collect()``: one rollout of ``--num-steps`` steps of every environment; an episode cut by
  the time limit gets the discounted value of its last observation added to its last reward;
- ``advantages()``: generalised advantage estimation (GAE), one backward pass over time;
- ``update()``: ``--epochs`` passes over the rollout in shuffled minibatches, the clipped
  surrogate objective plus a value regression, gradients clipped to ``--max-grad-norm``.

The settings are RallySim's for this task (as ``examples/sb3_ppo.py``): 64 envs x 64 steps
per update, 4 minibatches of 1024, 10 epochs, lr 3e-4 (constant; ``--lr-decay`` lowers it in
proportion to the steps left), gamma 0.99, GAE lambda 0.95, clip 0.2.

The env is Gymnasium 1.x's vector API over the registered id, with the id's *vector entry
point* (one batched MuJoCo model steps all environments in one call) and
``autoreset_mode="same_step"``: the observation returned with an episode's end is already the
next episode's first, the last one is ``info["final_obs"]``. No wrappers: RallySim's
observations are already scaled to [-1, 1], its rewards are O(1), and it clips actions to
[-1, 1] itself.

Training runs in whole rollouts, so ``--steps`` is rounded up to a multiple of
num-envs x num-steps (the script says so). Seeded: the same ``--seed`` on the same machine
gives the same numbers. Prints the speed and a ``result:`` line: the deterministic policy's
mean reward, hit rate, share landed in court and median landing error over seeded evaluation
episodes.
"""

from __future__ import annotations

import argparse
import itertools
import math
import time
from dataclasses import dataclass

import gymnasium as gym
import numpy as np
import torch
from torch import nn

import rallysim  # noqa: F401  (registers the RallySim/... ids)
from rallysim.eval.low_eval import evaluate_return

# The paper's low-level task: SimpleReturn-v1 with goals="uniform" is SimpleReturn-v0 step for
# step (v1 only changes the default goal distribution), without Gymnasium's notice that
# v0 is out of date.
ENV_ID = "RallySim/SimpleReturn-v1"
ENV_KWARGS = {"goals": "uniform"}
DEFAULT_STEPS, SMOKE_STEPS = 1_000_000, 131_072


def positive(kind):
    """An argparse type: ``kind`` (int or float) and > 0."""
    def parse(text: str):
        value = kind(text)
        if not value > 0:
            what = "integer" if kind is int else "number"
            raise argparse.ArgumentTypeError(f"must be a positive {what}, got {text}")
        return value
    parse.__name__ = f"positive {kind.__name__}"
    return parse


def parse_args() -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--steps", type=positive(int),
                   help=f"env steps to train (default {DEFAULT_STEPS:,}; rounded up to whole "
                        "rollouts)")
    p.add_argument("--smoke", action="store_true",
                   help=f"a quick check: {SMOKE_STEPS:,} steps (unless --steps), 64 "
                        "evaluation episodes")
    p.add_argument("--seed", type=int, default=0)
    p.add_argument("--num-envs", type=positive(int), default=64)
    p.add_argument("--num-steps", type=positive(int), default=64,
                   help="steps of each env per rollout")
    p.add_argument("--minibatches", type=positive(int), default=4)
    p.add_argument("--epochs", type=positive(int), default=10)
    p.add_argument("--lr", type=positive(float), default=3e-4)
    p.add_argument("--lr-decay", action="store_true",
                   help="scale the lr by the share of training steps still to run")
    p.add_argument("--gamma", type=float, default=0.99)
    p.add_argument("--gae-lambda", type=float, default=0.95)
    p.add_argument("--clip", type=float, default=0.2, help="PPO's ratio clip range")
    p.add_argument("--ent-coef", type=float, default=0.0)
    p.add_argument("--vf-coef", type=float, default=0.5)
    p.add_argument("--max-grad-norm", type=float, default=0.5)
    p.add_argument("--log-std-init", type=float, default=-0.5)
    p.add_argument("--hidden", type=positive(int), nargs="+", default=[64, 64],
                   help="hidden layer sizes of both MLPs")
    args = p.parse_args()
    rollout = args.num_envs * args.num_steps
    if rollout % args.minibatches:
        p.error(f"--minibatches {args.minibatches} does not divide a rollout of "
                f"{args.num_envs} x {args.num_steps} = {rollout} steps")
    asked = args.steps if args.steps is not None else (
        SMOKE_STEPS if args.smoke else DEFAULT_STEPS)
    args.updates = math.ceil(asked / rollout)
    args.total = args.updates * rollout
    rounded = "" if args.total == asked else f" ({asked:,} rounded up to whole rollouts)"
    print(f"training {args.total:,} env steps{rounded}: {args.updates} updates of "
          f"{args.num_envs} envs x {args.num_steps} steps", flush=True)
    args.eval_episodes = 64 if args.smoke else 500
    return args


def mlp(sizes: list[int], out_gain: float) -> nn.Sequential:
    """A tanh MLP through ``sizes``. Weights orthogonal (gain sqrt 2 before a tanh,
    ``out_gain`` on the output layer), biases zero."""
    layers: list[nn.Module] = []
    for fan_in, fan_out in itertools.pairwise(sizes):
        linear = nn.Linear(fan_in, fan_out)
        nn.init.zeros_(linear.bias)
        layers += [linear, nn.Tanh()]
    layers.pop()  # no tanh after the output layer
    for linear in layers[::2]:
        gain = out_gain if linear is layers[-1] else math.sqrt(2.0)
        nn.init.orthogonal_(linear.weight, gain=gain)
    return nn.Sequential(*layers)


class ActorCritic(nn.Module):
    """A Gaussian policy N(mean(obs), exp(log_std)) and a value function, no shared layers."""

    def __init__(self, obs_dim: int, act_dim: int, hidden: list[int],
                 log_std_init: float) -> None:
        super().__init__()
        # a near-zero output layer: every action starts close to 0 whatever the observation
        self.mean = mlp([obs_dim, *hidden, act_dim], out_gain=0.01)
        self.value_net = mlp([obs_dim, *hidden, 1], out_gain=1.0)
        self.log_std = nn.Parameter(torch.full((act_dim,), float(log_std_init)))

    def policy(self, obs: torch.Tensor) -> torch.distributions.Normal:
        return torch.distributions.Normal(self.mean(obs), self.log_std.exp())

    def value(self, obs: torch.Tensor) -> torch.Tensor:
        return self.value_net(obs).squeeze(-1)


@dataclass
class Rollout:
    """One rollout, every field indexed [time, env]."""

    obs: torch.Tensor
    act: torch.Tensor
    logp: torch.Tensor  # log-probability of ``act`` under the policy that sampled it
    value: torch.Tensor
    reward: torch.Tensor  # time-limit bootstrap included
    ended: torch.Tensor  # 1.0 where the episode ended with this step


def collect(envs, model: ActorCritic, obs: np.ndarray, horizon: int, gamma: float,
            ep_return: np.ndarray, finished: list[float]) -> tuple[Rollout, np.ndarray]:
    """``horizon`` steps of every env from ``obs``; returns the rollout and the obs after it.
    Finished episodes' returns are appended to ``finished``."""
    steps = []
    for _ in range(horizon):
        o = torch.as_tensor(obs)
        with torch.no_grad():
            dist = model.policy(o)
            a = dist.sample()
            logp, v = dist.log_prob(a).sum(-1), model.value(o)
        obs, reward, terminated, truncated, info = envs.step(a.numpy())
        ep_return += reward
        ended = terminated | truncated
        finished.extend(ep_return[ended])
        ep_return[ended] = 0.0
        r = torch.as_tensor(reward, dtype=torch.float32)
        cut = np.flatnonzero(truncated & ~terminated)
        if cut.size:  # the episode would have gone on: credit what its last state was worth
            with torch.no_grad():
                r[cut] += gamma * model.value(torch.as_tensor(info["final_obs"][cut]))
        steps.append((o, a, logp, v, r, torch.as_tensor(ended, dtype=torch.float32)))
    fields = [torch.stack(column) for column in zip(*steps, strict=True)]
    return Rollout(*fields), obs


def advantages(r: Rollout, last_value: torch.Tensor, gamma: float, lam: float) -> torch.Tensor:
    """GAE: A_t = delta_t + gamma lam A_{t+1}, with delta_t = r_t + gamma V(s_{t+1}) - V(s_t),
    and neither V(s_{t+1}) nor A_{t+1} counted when the episode ended at step t (with the
    same-step autoreset s_{t+1} is then another episode's first state)."""
    goes_on = 1.0 - r.ended
    next_value = torch.cat((r.value[1:], last_value[None]))
    delta = r.reward + gamma * goes_on * next_value - r.value
    adv = torch.empty_like(delta)
    acc = torch.zeros_like(last_value)
    for t in range(len(delta) - 1, -1, -1):
        acc = delta[t] + gamma * lam * goes_on[t] * acc
        adv[t] = acc
    return adv


def update(model: ActorCritic, optim: torch.optim.Optimizer, r: Rollout, adv: torch.Tensor,
           args: argparse.Namespace, gen: torch.Generator) -> None:
    """PPO's clipped-objective update over the flattened rollout."""
    obs, act = r.obs.flatten(0, 1), r.act.flatten(0, 1)
    old_logp, adv = r.logp.flatten(), adv.flatten()
    target = adv + r.value.flatten()  # the value regression's target: the lambda-return
    size = len(adv) // args.minibatches
    for _ in range(args.epochs):
        for idx in torch.randperm(len(adv), generator=gen).split(size):
            dist = model.policy(obs[idx])
            ratio = torch.exp(dist.log_prob(act[idx]).sum(-1) - old_logp[idx])
            a = adv[idx]
            a = (a - a.mean()) / (a.std() + 1e-8)
            surrogate = torch.minimum(ratio * a,
                                      ratio.clamp(1.0 - args.clip, 1.0 + args.clip) * a)
            value_loss = (model.value(obs[idx]) - target[idx]).square().mean()
            entropy = dist.entropy().sum(-1).mean()
            loss = -surrogate.mean() + args.vf_coef * value_loss - args.ent_coef * entropy
            optim.zero_grad()
            loss.backward()
            nn.utils.clip_grad_norm_(model.parameters(), args.max_grad_norm)
            optim.step()


def main() -> None:
    args = parse_args()
    torch.manual_seed(args.seed)  # the actions sampled in the rollouts
    gen = torch.Generator().manual_seed(args.seed)  # the minibatch shuffles
    torch.set_num_threads(1)  # on a small CPU a second thread competes with the simulator

    envs = gym.make_vec(ENV_ID, num_envs=args.num_envs, vectorization_mode="vector_entry_point",
                        autoreset_mode="same_step", **ENV_KWARGS)
    model = ActorCritic(envs.single_observation_space.shape[0],
                        envs.single_action_space.shape[0], args.hidden, args.log_std_init)
    optim = torch.optim.Adam(model.parameters(), lr=args.lr)

    obs, _ = envs.reset(seed=args.seed)
    ep_return = np.zeros(args.num_envs)
    finished: list[float] = []
    done_steps = 0
    start = time.perf_counter()
    for k in range(args.updates):
        if args.lr_decay:
            optim.param_groups[0]["lr"] = args.lr * (args.total - done_steps) / args.total
        rollout, obs = collect(envs, model, obs, args.num_steps, args.gamma, ep_return,
                               finished)
        done_steps += args.num_envs * args.num_steps
        with torch.no_grad():
            last_value = model.value(torch.as_tensor(obs))
        adv = advantages(rollout, last_value, args.gamma, args.gae_lambda)
        update(model, optim, rollout, adv, args, gen)
        if (k + 1) % max(1, args.updates // 10) == 0 and finished:
            print(f"{done_steps:>10,} steps  mean return of the last 500 episodes "
                  f"{np.mean(finished[-500:]):6.3f}  "
                  f"{done_steps / (time.perf_counter() - start):,.0f} steps/s", flush=True)
    wall = time.perf_counter() - start
    envs.close()
    rate = done_steps / wall
    print(f"speed: {rate:,.0f} env steps/s ({done_steps:,} steps in {wall:.1f} s)")

    def act(x: np.ndarray) -> np.ndarray:
        with torch.no_grad():  # the deterministic action: the Gaussian's mean
            return model.mean(torch.as_tensor(x)).numpy()

    ev = evaluate_return(act, episodes=args.eval_episodes, seed=12345)
    train_return = np.mean(finished[-500:]) if finished else float("nan")
    print(f"result: steps={done_steps} steps_per_s={rate:.0f} train_return={train_return:.3f} "
          f"mean_reward={ev.mean_reward:.3f} hit_rate={ev.hit_rate:.3f} "
          f"in_court={ev.in_rate:.3f} landing_error_m={ev.median_error:.2f} "
          f"episodes={ev.episodes}")


if __name__ == "__main__":
    main()
