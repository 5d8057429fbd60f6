"""Optional behaviour-cloning warm start of a PPO actor-critic from a teacher controller.

Not the paper's method (it trained the low level from scratch): runs that use it must say so.
The teacher (e.g. ``ScriptedController().act_return``) plays ``decisions`` decisions; the actor's
mean is fitted to its actions (MSE; the teacher's actions are already in [-1, 1]) and the critic
to the discounted returns it earned, so that PPO's first advantages are not noise that would
undo the clone. The log-std is then set to ``log_std`` (small: the clone is already good).
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import torch
from stable_baselines3 import PPO

from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv


def teacher_dataset(teacher: Callable[[np.ndarray], np.ndarray], n_envs: int, decisions: int,
                    gamma: float, shuttle: str = "paper",
                    seed: int = 0) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """(obs, actions, discounted returns) of the teacher's complete episodes."""
    env = SimpleReturnVectorEnv(n_envs, shuttle=shuttle, autoreset_mode="same_step")
    obs, _ = env.reset(seed=seed)
    steps = max(1, decisions // n_envs)
    all_obs = np.empty((steps, n_envs, obs.shape[1]), np.float32)
    all_act = np.empty((steps, n_envs, 3), np.float32)
    rewards = np.empty((steps, n_envs))
    dones = np.empty((steps, n_envs), bool)
    for t in range(steps):
        act = np.asarray(teacher(obs), np.float32)
        all_obs[t], all_act[t] = obs, act
        obs, r, term, trunc, _ = env.step(act)
        rewards[t], dones[t] = r, term | trunc
    returns = np.zeros((steps, n_envs))
    valid = np.zeros((steps, n_envs), bool)  # inside an episode that ended before the cut
    running = np.zeros(n_envs)
    complete = np.zeros(n_envs, bool)
    for t in range(steps - 1, -1, -1):
        complete |= dones[t]
        running = rewards[t] + gamma * running * ~dones[t]
        returns[t], valid[t] = running, complete
    return all_obs[valid], all_act[valid], returns[valid].astype(np.float32)


def behaviour_clone(model: PPO, teacher: Callable[[np.ndarray], np.ndarray], decisions: int,
                    epochs: int = 30, batch_size: int = 4096, lr: float = 1e-3,
                    log_std: float = -1.5, shuttle: str = "paper", seed: int = 0,
                    ) -> dict[str, float]:
    """Fit ``model``'s actor mean and critic to ``teacher``; return the final losses."""
    obs, act, ret = teacher_dataset(teacher, 256, decisions, model.gamma, shuttle, seed)
    policy = model.policy
    o = torch.as_tensor(obs)
    a = torch.as_tensor(act)
    g = torch.as_tensor(ret)[:, None]
    optimiser = torch.optim.Adam(policy.parameters(), lr=lr)
    gen = torch.Generator().manual_seed(seed)
    actor_loss = critic_loss = torch.zeros(())
    for _ in range(epochs):
        for idx in torch.randperm(len(o), generator=gen).split(batch_size):
            features = policy.extract_features(o[idx])
            latent_pi, latent_vf = policy.mlp_extractor(features)
            mean = policy.action_net(latent_pi)
            value = policy.value_net(latent_vf)
            actor_loss = torch.mean((mean - a[idx]) ** 2)
            critic_loss = torch.mean((value - g[idx]) ** 2)
            optimiser.zero_grad()
            (actor_loss + 0.5 * critic_loss).backward()
            optimiser.step()
    with torch.no_grad():
        policy.log_std.fill_(log_std)
    return {"samples": float(len(o)), "actor_mse": actor_loss.item(),
            "critic_mse": critic_loss.item()}
