"""Evaluation of low-level policies on ``RallySim/SimpleReturn-v0`` (batched, seeded).

Each environment of a batch plays exactly one episode, seeded ``seed + i``: the same seed gives
the same serves, start states and goals, so evaluations of different policies (or checkpoints)
with one seed are paired comparisons.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import numpy as np

from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv
from rallysim.policies.types import Policy


@dataclass(frozen=True)
class ReturnEval:
    """Statistics of ``episodes`` low-level episodes."""

    episodes: int
    mean_reward: float
    hit_rate: float
    in_rate: float  # hit, and landed in the opponent court
    median_error: float  # median |landing depth - d*| over hit episodes, m (NaN: no hit)
    mean_error: float
    mean_length: float  # decisions per episode
    decisions: int

    def as_dict(self) -> dict[str, float]:
        return asdict(self)


def evaluate_return(policy: Policy, env: SimpleReturnVectorEnv | None = None,
                    episodes: int = 500, seed: int = 12345, shuttle: str = "paper",
                    ) -> ReturnEval:
    """Play ``episodes`` episodes (rounds of ``env.num_envs`` at a time; default: one env per
    episode) with ``policy`` and summarise them."""
    if env is None:
        env = SimpleReturnVectorEnv(episodes, shuttle=shuttle, autoreset_mode="same_step")
    n = env.num_envs
    rewards, hits, ins, errors, lengths = [], [], [], [], []
    for r in range(int(np.ceil(episodes / n))):
        obs, _ = env.reset(seed=seed + r * n)
        ret, length = np.zeros(n), np.zeros(n, np.int64)
        hit, done = np.zeros(n, bool), np.zeros(n, bool)
        while not done.all():
            obs, reward, term, trunc, info = env.step(np.asarray(policy(obs), np.float32))
            live = ~done
            ret[live] += reward[live]
            length[live] += 1
            hit[live] |= info["hit"][live]
            ended = live & (term | trunc)
            if ended.any():
                final = info.get("final_info", info)
                e = np.flatnonzero(ended)
                ins += (hit[e] & final["landed_in"][e]).tolist()
                errors += final["landing_error"][e][hit[e]].tolist()
                done |= ended
        rewards += ret.tolist()
        hits += hit.tolist()
        lengths += length.tolist()
    take = slice(0, episodes)
    errs = np.asarray(errors, float)
    errs = errs[np.isfinite(errs)]
    return ReturnEval(
        episodes=episodes,
        mean_reward=float(np.mean(rewards[take])),
        hit_rate=float(np.mean(hits[take])),
        in_rate=float(np.mean(ins[:episodes])),
        median_error=float(np.median(errs)) if len(errs) else float("nan"),
        mean_error=float(errs.mean()) if len(errs) else float("nan"),
        mean_length=float(np.mean(lengths[take])),
        decisions=int(np.sum(lengths)),
    )
