"""Evaluation of low-level policies on ``RallySim/SimpleReturn-v0`` (batched, seeded).

Each environment of a batch plays exactly one episode, seeded ``seed + i``: the same seed gives
the same serves, start states and goals, so evaluations of different policies (or checkpoints)
with one seed are paired comparisons.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass
from typing import Any

import numpy as np

from rallysim.core.reach import ShotPlanner
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


@dataclass(frozen=True)
class ReturnEpisodes:
    """Per-episode values of ``episodes`` low-level episodes, (episodes,) arrays."""

    reward: np.ndarray
    hit: np.ndarray
    landed_in: np.ndarray  # hit, and landed in the opponent court
    error: np.ndarray  # |landing depth - d*| (NaN: no landing)
    depth: np.ndarray  # landing depth beyond the net, m (NaN: no landing)
    goal: np.ndarray  # d*, m
    reach: np.ndarray  # (episodes, 2): ShotPlanner.reachable_depths at the episode's start
    length: np.ndarray  # decisions
    decisions: int  # decisions played, rounds' spare environments included


def play_returns(policy: Policy, env: SimpleReturnVectorEnv | None = None,
                 episodes: int = 500, seed: int = 12345, shuttle: str = "paper",
                 ) -> ReturnEpisodes:
    """Play ``episodes`` episodes (rounds of ``env.num_envs`` at a time; default: one env per
    episode) with ``policy``; environment ``i`` of a round seeded ``s`` is seeded ``s + i``."""
    if env is None:
        env = SimpleReturnVectorEnv(episodes, shuttle=shuttle, autoreset_mode="same_step")
    planner = ShotPlanner()
    n = env.num_envs
    keys = ("reward", "hit", "landed_in", "error", "depth", "goal", "reach", "length")
    rows: dict[str, list] = {k: [] for k in keys}
    for r in range(int(np.ceil(episodes / n))):
        obs, _ = env.reset(seed=seed + r * n)
        rows["goal"].append(env.task.goal.copy())
        rows["reach"].append(np.stack(planner.reachable_depths(obs), axis=1))
        ret, length = np.zeros(n), np.zeros(n, np.int64)
        hit, done = np.zeros(n, bool), np.zeros(n, bool)
        landed_in = np.zeros(n, bool)
        error, depth = np.full(n, np.nan), np.full(n, np.nan)
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
                landed_in[e] = hit[e] & final["landed_in"][e]
                error[e], depth[e] = final["landing_error"][e], final["landing_depth"][e]
                done |= ended
        for key, value in zip(keys[:5], (ret, hit, landed_in, error, depth), strict=True):
            rows[key].append(value)
        rows["length"].append(length)
    values = {k: np.concatenate(v)[:episodes] for k, v in rows.items()}
    return ReturnEpisodes(**values, decisions=int(sum(v.sum() for v in rows["length"])))


def evaluate_return(policy: Policy, env: SimpleReturnVectorEnv | None = None,
                    episodes: int = 500, seed: int = 12345, shuttle: str = "paper",
                    ) -> ReturnEval:
    """Play ``episodes`` episodes with ``policy`` (see ``play_returns``) and summarise them."""
    return summarise_returns(play_returns(policy, env, episodes, seed, shuttle))


def summarise_returns(ep: ReturnEpisodes) -> ReturnEval:
    """``evaluate_return``'s statistics of played episodes."""
    errs = ep.error[ep.hit]
    errs = errs[np.isfinite(errs)]
    return ReturnEval(
        episodes=len(ep.hit),
        mean_reward=float(np.mean(ep.reward)),
        hit_rate=float(np.mean(ep.hit)),
        in_rate=float(np.mean(ep.landed_in)),
        median_error=_median(errs),
        mean_error=float(errs.mean()) if len(errs) else float("nan"),
        mean_length=float(np.mean(ep.length)),
        decisions=ep.decisions,
    )


def score_low_level(policy: Policy, episodes: int = 1000, seed: int = 12345,
                    shuttle: str = "paper") -> dict[str, Any]:
    """How well a SIMPLE low level follows its goal on ``episodes`` fresh serves (goals
    ~ U[2, 6] m): see ``goal_following``."""
    ep = play_returns(policy, episodes=episodes, seed=seed, shuttle=shuttle)
    return goal_following(ep, seed, shuttle)


def goal_following(ep: ReturnEpisodes, seed: int, shuttle: str) -> dict[str, Any]:
    """``hit_rate``, ``median_landing_error`` (m, over hits) and ``goal_correlation``, the
    correlation of landing depth with the goal over the hits whose goal the serve makes
    reachable (``ShotPlanner.reachable_depths``: a full-speed shot from a meeting the player
    can make lands that deep); the same over every hit beside it, of episodes played from
    ``seed`` with ``shuttle``."""
    landed = ep.hit & np.isfinite(ep.depth)
    lo, hi = ep.reach[:, 0], ep.reach[:, 1]
    reachable = (ep.goal >= lo) & (ep.goal <= hi)  # (NaN bounds: nothing reachable)
    scored = landed & reachable
    return {
        "episodes": len(ep.hit), "seed": seed, "shuttle": shuttle,
        "hit_rate": float(np.mean(ep.hit)),
        "landed_in_rate": float(np.mean(ep.landed_in)),
        "median_landing_error": _median(ep.error[landed]),
        "goal_correlation": _correlation(ep.depth[scored], ep.goal[scored]),
        "reachable_share": float(np.mean(reachable)),
        "reachable_hits": int(scored.sum()),
        "median_landing_error_reachable": _median(ep.error[scored]),
        "goal_correlation_all": _correlation(ep.depth[landed], ep.goal[landed]),
        "mean_reward": float(np.mean(ep.reward)),
    }


def goal_scores(ep: ReturnEpisodes, seed: int, shuttle: str) -> dict[str, float | None]:
    """``goal_following``'s correlation and median error over reachable goals, ``None`` where
    too few hits leave one undefined (JSON has no NaN)."""
    scores = goal_following(ep, seed, shuttle)
    return {k: None if np.isnan(scores[k]) else scores[k]
            for k in ("goal_correlation", "median_landing_error_reachable")}


def _median(values: np.ndarray) -> float:
    return float(np.median(values)) if len(values) else float("nan")


def _correlation(a: np.ndarray, b: np.ndarray) -> float:
    """Pearson's r (NaN for fewer than 3 pairs or a constant side)."""
    if len(a) < 3 or np.std(a) == 0.0 or np.std(b) == 0.0:
        return float("nan")
    return float(np.corrcoef(a, b)[0, 1])
