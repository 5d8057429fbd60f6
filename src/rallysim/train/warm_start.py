"""Optional behaviour-cloning warm start of a PPO actor-critic from a teacher controller.

Not the paper's method (it trained the low level from scratch): runs that use it must say so.
The teacher (e.g. ``ScriptedController().act_return``) plays ``decisions`` decisions; the actor's
mean is fitted to its actions (MSE; the teacher's actions are already in [-1, 1]) and the critic
to the discounted returns it earned, so that PPO's first advantages are not noise that would
undo the clone. With ``dagger_rounds`` > 0 the clone then plays itself and the teacher labels
the states it reaches (DAgger), so that it also learns to recover from its own mistakes. The
log-std is then set to ``log_std`` (small: the clone is already good).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
import torch
from stable_baselines3 import PPO

from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv

Act = Callable[[np.ndarray], np.ndarray]


def _task_env(player: str, n_envs: int, shuttle: str) -> Any:
    if player == "humanlike":
        from rallysim.envs.humanlike_return_v0 import HumanLikeReturnVectorEnv

        return HumanLikeReturnVectorEnv(n_envs, shuttle=shuttle, autoreset_mode="same_step")
    return SimpleReturnVectorEnv(n_envs, shuttle=shuttle, autoreset_mode="same_step")


def teacher_dataset(teacher: Act, n_envs: int, decisions: int, gamma: float,
                    shuttle: str = "paper", seed: int = 0, player: str = "simple",
                    actor: Act | None = None
                    ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """(obs, teacher's actions, discounted returns, sample weights) of complete episodes
    played by ``actor`` (default: the teacher itself) in the ``player``'s low-level task. A
    teacher with ``imitation_weights()`` weighs its last call's actions (per environment, or
    per environment and action); else all weigh 1."""
    env = _task_env(player, n_envs, shuttle)
    obs, _ = env.reset(seed=seed)
    steps = max(1, decisions // n_envs)
    all_obs = np.empty((steps, n_envs, obs.shape[1]), np.float32)
    all_act = np.empty((steps, n_envs, env.single_action_space.shape[0]), np.float32)
    rewards = np.empty((steps, n_envs))
    weights = np.ones((steps, n_envs, all_act.shape[2]), np.float32)
    dones = np.empty((steps, n_envs), bool)
    weigh = getattr(teacher, "imitation_weights", None)
    for t in range(steps):
        act = np.asarray(teacher(obs), np.float32)
        all_obs[t], all_act[t] = obs, act
        if weigh is not None:  # per environment (n,) or per action too (n, actions)
            w = np.asarray(weigh(), np.float32)
            weights[t] = w[:, None] if w.ndim == 1 else w
        if actor is not None:
            act = np.asarray(actor(obs), np.float32)
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
    return all_obs[valid], all_act[valid], returns[valid].astype(np.float32), weights[valid]


def behaviour_clone(model: PPO, teacher: Act, decisions: int, epochs: int = 30,
                    batch_size: int = 4096, lr: float = 1e-3, log_std: float = -1.5,
                    shuttle: str = "paper", seed: int = 0, player: str = "simple",
                    dagger_rounds: int = 0, lr_decay: bool = False,
                    evaluate: Callable[[Act], dict[str, Any]] | None = None
                    ) -> dict[str, Any]:
    """Fit ``model``'s actor mean and critic to ``teacher``; return the final losses.
    ``lr_decay``: a cosine decay of the learning rate to 5 % over each fit's epochs.
    ``evaluate``: called with the deterministic clone after the first fit and after every
    DAgger round; its results are returned under ``rounds`` with the decisions labelled so
    far (the clone's learning curve)."""
    policy = model.policy
    optimiser = torch.optim.Adam(policy.parameters(), lr=lr)
    gen = torch.Generator().manual_seed(seed)

    def student(obs: np.ndarray) -> np.ndarray:
        with torch.no_grad():
            return model.policy.predict(obs, deterministic=True)[0]

    data: list[tuple[np.ndarray, ...]] = []
    rounds: list[dict[str, Any]] = []
    labelled = 0
    for k in range(dagger_rounds + 1):  # round 0: the teacher plays; then the clone does
        size = decisions if k == 0 else max(256, decisions // 4)
        data.append(teacher_dataset(teacher, 256, size, model.gamma, shuttle, seed + 7919 * k,
                                    player, actor=student if k else None))
        labelled += max(1, size // 256) * 256  # teacher_dataset plays whole batch steps
        losses = _fit(policy, optimiser, gen, data, epochs if k == 0 else max(1, epochs // 2),
                      batch_size, lr, lr_decay)
        if evaluate is not None:
            rounds.append({"round": k, "labelled_decisions": labelled, **losses,
                           **evaluate(student)})
    with torch.no_grad():
        policy.log_std.fill_(log_std)
    out: dict[str, Any] = {"samples": float(sum(len(d[0]) for d in data)), **losses}
    if evaluate is not None:
        out["rounds"] = rounds
    return out


def _fit(policy: Any, optimiser: Any, gen: Any, data: list[tuple[np.ndarray, ...]],
         epochs: int, batch_size: int, lr: float, lr_decay: bool) -> dict[str, float]:
    o = torch.as_tensor(np.concatenate([d[0] for d in data]))
    a = torch.as_tensor(np.concatenate([d[1] for d in data]))
    g = torch.as_tensor(np.concatenate([d[2] for d in data]))[:, None]
    w = torch.as_tensor(np.concatenate([d[3] for d in data]))  # (samples, actions)
    actor_loss = critic_loss = torch.zeros(())
    for epoch in range(epochs):
        if lr_decay:
            for group in optimiser.param_groups:
                group["lr"] = lr * (0.05 + 0.475 * (1.0 + np.cos(np.pi * epoch / epochs)))
        for idx in torch.randperm(len(o), generator=gen).split(batch_size):
            features = policy.extract_features(o[idx])
            latent_pi, latent_vf = policy.mlp_extractor(features)
            mean = policy.action_net(latent_pi)
            value = policy.value_net(latent_vf)
            actor_loss = torch.mean(w[idx] * (mean - a[idx]) ** 2)
            critic_loss = torch.mean((value - g[idx]) ** 2)
            optimiser.zero_grad()
            (actor_loss + 0.5 * critic_loss).backward()
            optimiser.step()
    return {"actor_mse": actor_loss.item(), "critic_mse": critic_loss.item()}
