"""Reference returns: what off-the-shelf PPO and SAC (Stable-Baselines3) reach on each RallySim
task at a fixed budget, over several seeds, so that a researcher knows which tasks are solvable
and by what.

Tasks (each through ``rallysim.sb3``'s batched ``VecEnv``):

``SimpleReturn-v0``
    the SIMPLE low-level task (``RallySim/SimpleReturn-v0``); also scored on fresh serves: hit
    rate, median landing error, goal correlation over reachable goals.
``HumanLikeReturn-v0``
    the HUMAN-LIKE low-level task; also scored: hit rate, mean angle and speed errors of the
    racket velocity at the hit.
``SimpleRallyTurn-v1``
    the rally turn by turn for one shared high level over the env's default (scripted) low
    level; an episode is a rally, a step a turn.
``SimpleRally-v0 (parallel)``
    the two-player rally at the decision rate, both players one policy (each rally-player pair
    a slot of ``SimpleRallyVectorEnv``), as the Monolithic baseline trains.

PPO uses the project's packaged settings for the stage that trains on the task
(``configs/low.yaml`` for the return tasks, ``high.yaml`` for the turn game, ``mono.yaml`` for
the rally); SAC uses one setting for all (``SAC_SETTINGS``). SAC with hindsight relabelling
(SB3's ``HerReplayBuffer``, the ``final`` strategy: a serve's goal replaced by where the shot
landed) runs where there is a goal to relabel, SimpleReturn, through ``GoalReturnVecEnv``.
Every run's deterministic policy then plays ``episodes`` fresh episodes
(one per env slot, seeded apart from training): mean return and length, pooled over seeds with
95 % bootstrap intervals (seeds, then episodes, resampled); the task metrics are means over
seeds with intervals over seeds.

    python -m experiments.reference_returns --json docs/data/reference_returns.json

(docs/rl-alone.md renders that JSON: a generated block, ``rallysim.train.study_tables``,
checked by a test.)
"""

from __future__ import annotations

import argparse
import json
import os
import sys
import time
from collections.abc import Callable
from concurrent.futures import ProcessPoolExecutor
from dataclasses import asdict, dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np
from stable_baselines3.common.vec_env import VecEnvWrapper

from rallysim.eval import stats
from rallysim.train.study_tables import render_reference_returns as render

KIND = "reference_returns"
EVAL_SEED = 2_000_000  # evaluation episodes: seeds apart from training's (seed + i)
SAC_SETTINGS: dict[str, Any] = {"batch_size": 256, "train_freq": 1, "gradient_steps": 2,
                                "learning_starts": 5000,
                                "policy_kwargs": {"net_arch": [64, 64]}}
SAC_ENVS = 8  # SAC's parallel envs: 8 transitions and 2 gradient steps per env step


@dataclass(frozen=True)
class Task:
    """One task: how to build its SB3 ``VecEnv``, whose PPO settings train on it, its budgets
    (SB3 steps; the turn game's are turns) and its extra score."""

    name: str
    stage: str  # the packaged config whose PPO settings train on this task
    ppo_steps: int
    sac_steps: int
    unit: str

    def make_env(self, n: int, seed: int) -> Any:
        from rallysim.envs import registration
        from rallysim.sb3 import make_vec_env

        if self.name == "SimpleRally-v0 (parallel)":
            from rallysim.envs.simple_rally_v0 import SimpleRallyVectorEnv
            from rallysim.train.sb3_vec import NativeVecEnv

            return NativeVecEnv(SimpleRallyVectorEnv(max(1, n // 2), seed=seed,
                                                     autoreset_mode="same_step"))
        ids = {"SimpleReturn-v0": registration.SIMPLE_RETURN_ID,
               "HumanLikeReturn-v0": registration.HUMANLIKE_RETURN_ID,
               "SimpleRallyTurn-v1": registration.SIMPLE_RALLY_TURN_V1_ID}
        return make_vec_env(ids[self.name], n_envs=n, seed=seed)


TASKS = (
    Task("SimpleReturn-v0", "low", 500_000, 30_000, "decisions"),
    Task("HumanLikeReturn-v0", "low", 500_000, 30_000, "decisions"),
    Task("SimpleRallyTurn-v1", "high", 20_000, 10_000, "turns"),
    Task("SimpleRally-v0 (parallel)", "mono", 500_000, 30_000, "player-decisions"),
)
ALGOS = ("random", "PPO", "SAC", "SAC+HER")  # random: uniform actions, untrained (the floor)
HER_TASKS = ("SimpleReturn-v0",)  # the tasks with a goal to relabel
NO_LANDING = -5.0  # the achieved goal (scaled depth) of a step without a scoring landing


class GoalReturnVecEnv(VecEnvWrapper):
    """SimpleReturn as a goal-conditioned task for hindsight relabelling: a dictionary of the
    player's observation (indices 0-15), ``desired_goal`` (index 16, the goal depth scaled as
    (d* - 4) / 2) and ``achieved_goal`` (where the shot landed, scaled alike, at the step it
    landed in court after a clean hit; ``NO_LANDING`` before and otherwise). ``compute_reward``
    gives the task's reward for any goal: the goal-free terms (shaping, hit), carried in each
    step's info, plus the landing term exp(-0.5 |depth - d*|) = exp(-|a - g|) in scaled units.
    """

    def __init__(self, venv: Any) -> None:
        import gymnasium as gym

        box = gym.spaces.Box(-np.inf, np.inf, (1,), np.float32)
        space = gym.spaces.Dict({"observation": gym.spaces.Box(-1.0, 1.0, (16,), np.float32),
                                 "achieved_goal": box, "desired_goal": box})
        super().__init__(venv, observation_space=space)

    @staticmethod
    def split(obs: np.ndarray, achieved: np.ndarray | None = None) -> dict[str, np.ndarray]:
        """The goal dictionary of flat task observations ``(..., 17)``; ``achieved``
        ``(n, 1)``, else ``NO_LANDING``."""
        obs = np.asarray(obs, np.float32)
        flat = obs.reshape(-1, obs.shape[-1])
        if achieved is None:
            achieved = np.full((len(flat), 1), NO_LANDING, np.float32)
        out = {"observation": flat[:, :16], "achieved_goal": achieved.reshape(-1, 1),
               "desired_goal": flat[:, 16:17]}
        return {k: v.reshape(*obs.shape[:-1], v.shape[-1]) for k, v in out.items()}

    def reset(self) -> Any:
        return self.split(self.venv.reset())

    def step_wait(self) -> Any:
        """The task's step as goal dictionaries; each info carries the step's goal-free reward
        (``reward_free``) for ``compute_reward``."""
        obs, reward, dones, infos = self.venv.step_wait()
        achieved = np.full((self.num_envs, 1), NO_LANDING, np.float32)
        for e, info in enumerate(infos):
            landing = info.get("reward_landing", 0.0) if dones[e] else 0.0
            info["reward_free"] = float(reward[e]) - landing
            if dones[e]:
                if landing > 0.0:
                    achieved[e, 0] = (info["landing_depth"] - 4.0) / 2.0
                info["terminal_observation"] = self.split(info["terminal_observation"],
                                                          achieved[e])
        # a new episode has landed nothing yet: the landing goes only into the episode's
        # terminal observation, which is where SB3's buffers read the last step from
        return self.split(obs), reward, dones, infos

    def compute_reward(self, achieved: np.ndarray, desired: np.ndarray, infos: Any
                       ) -> np.ndarray:
        free = np.array([i["reward_free"] for i in infos], np.float64)
        a, g = np.asarray(achieved)[..., 0], np.asarray(desired)[..., 0]
        landed = a > NO_LANDING + 1.0
        return (free + np.where(landed, np.exp(-np.abs(a - g)), 0.0)).astype(np.float32)

    def env_method(self, method_name: str, *args: Any, indices: Any = None,
                   **kwargs: Any) -> list[Any]:
        """SB3's ``HerReplayBuffer`` asks the vector env's first env for ``compute_reward``;
        the batched env behind this view has no per-env objects, so this view answers."""
        if method_name == "compute_reward":
            return [self.compute_reward(*args, **kwargs)]
        return self.venv.env_method(method_name, *args, indices=indices, **kwargs)


def _task_scores(task: Task, policy: Callable[[np.ndarray], np.ndarray], episodes: int
                 ) -> dict[str, float | None]:
    """The return tasks' own measures of the trained policy on fresh serves."""
    if task.name == "SimpleReturn-v0":
        from rallysim.eval.low_eval import goal_following, play_returns

        played = play_returns(policy, episodes=episodes, seed=EVAL_SEED)
        scores = goal_following(played, EVAL_SEED, "paper")
        return {k: None if np.isnan(scores[k]) else scores[k]
                for k in ("hit_rate", "median_landing_error", "goal_correlation")}
    if task.name == "HumanLikeReturn-v0":
        from rallysim.eval.humanlike_eval import evaluate_humanlike

        r = evaluate_humanlike(policy, episodes=episodes, seed=EVAL_SEED)
        return {k: None if r[k] is None or not np.isfinite(r[k]) else float(r[k])
                for k in ("hit_rate", "mean_angle_error", "mean_abs_speed_error")}
    return {}


def play_episodes(env: Any, policy: Callable[[np.ndarray], np.ndarray]
                  ) -> tuple[np.ndarray, np.ndarray]:
    """Every slot of ``env`` (an SB3 ``VecEnv``) plays one episode: returns and lengths."""
    n = env.num_envs
    obs = env.reset()
    ret, length = np.zeros(n), np.zeros(n, np.int64)
    done = np.zeros(n, bool)
    while not done.all():
        obs, reward, dones, _ = env.step(policy(obs))
        live = ~done
        ret[live] += reward[live]
        length[live] += 1
        done |= dones
    return ret, length


def _random_run(task: Task, seed: int, episodes: int) -> dict[str, Any]:
    """Uniform random actions over the task's action space: no training."""
    probe = task.make_env(1, seed)
    space = probe.action_space
    probe.close()
    rng = np.random.default_rng(seed)

    def policy(obs: np.ndarray) -> np.ndarray:
        n = len(obs)
        return rng.uniform(space.low, space.high, (n, *space.shape)).astype(space.dtype)

    ret, length = play_episodes(task.make_env(episodes, EVAL_SEED + 1000 * seed), policy)
    return {"task": task.name, "algo": "random", "seed": seed, "steps": 0, "unit": task.unit,
            "train_wall_s": 0.0, "returns": ret.tolist(), "lengths": length.tolist(),
            "scores": _task_scores(task, policy, episodes)}


def run_one(task_name: str, algo: str, seed: int, scale: float, episodes: int
            ) -> dict[str, Any]:
    """Train ``algo`` on the task for its budget (times ``scale``), then evaluate."""
    import torch
    from stable_baselines3 import PPO, SAC

    from rallysim.train.config import load_config

    torch.set_num_threads(1)
    task = next(t for t in TASKS if t.name == task_name)
    if algo == "random":
        return _random_run(task, seed, episodes)
    if algo == "PPO":
        ppo = load_config(task.stage).ppo
        steps = max(int(task.ppo_steps * scale), 2 * ppo.n_envs * ppo.n_steps)
        env = task.make_env(ppo.n_envs, seed)
        model: Any = PPO("MlpPolicy", env, seed=seed, device="cpu", verbose=0,
                         **ppo.sb3_kwargs())
    else:
        if algo == "SAC+HER" and task.name not in HER_TASKS:
            raise ValueError(f"{algo} needs a goal to relabel: {', '.join(HER_TASKS)}")
        # hindsight relabelling samples whole episodes: its first update waits until every
        # env has ended one (a return lasts < 80 decisions), even in a smoke run
        her_start = 80 * SAC_ENVS if algo == "SAC+HER" else 0
        steps = max(int(task.sac_steps * scale), 64, 2 * her_start)
        env = task.make_env(SAC_ENVS, seed)
        # (a smoke run is shorter than the usual random warm-up)
        first = max(min(SAC_SETTINGS["learning_starts"], steps // 2), her_start)
        settings = {**SAC_SETTINGS, "learning_starts": first}
        if algo == "SAC+HER":
            from stable_baselines3 import HerReplayBuffer

            env = GoalReturnVecEnv(env)
            settings.update(replay_buffer_class=HerReplayBuffer, replay_buffer_kwargs={
                "goal_selection_strategy": "final", "n_sampled_goal": 4,
                "copy_info_dict": True})
        model = SAC("MultiInputPolicy" if algo == "SAC+HER" else "MlpPolicy", env, seed=seed,
                    device="cpu", verbose=0, buffer_size=max(steps, 1000), **settings)
    t0 = time.perf_counter()
    model.learn(total_timesteps=steps)
    wall = time.perf_counter() - t0

    def policy(obs: np.ndarray) -> np.ndarray:
        seen = GoalReturnVecEnv.split(obs) if algo == "SAC+HER" else obs
        return model.predict(seen, deterministic=True)[0]

    ret, length = play_episodes(task.make_env(episodes, EVAL_SEED + 1000 * seed), policy)
    return {"task": task.name, "algo": algo, "seed": seed, "steps": int(model.num_timesteps),
            "unit": task.unit, "train_wall_s": round(wall, 1),
            "returns": ret.tolist(), "lengths": length.tolist(),
            "scores": _task_scores(task, policy, episodes)}


def pool(runs: list[dict[str, Any]]) -> list[dict[str, Any]]:
    """One row per task and algorithm: seeds pooled."""
    rows = []
    for task in TASKS:
        for algo in ALGOS:
            mine = sorted((r for r in runs if r["task"] == task.name and r["algo"] == algo),
                          key=lambda r: r["seed"])
            if not mine:
                continue
            ret = stats.estimate([np.array(r["returns"]) for r in mine], stats.mean)
            length = stats.estimate([np.array(r["lengths"], float) for r in mine], stats.mean)
            keys = list(mine[0]["scores"])
            rows.append({
                "task": task.name, "algo": algo, "unit": task.unit, "steps": mine[0]["steps"],
                "seeds": [r["seed"] for r in mine],
                "mean_return": asdict(ret),
                "per_seed_return": [float(np.mean(r["returns"])) for r in mine],
                "mean_length": asdict(length),
                "scores": {k: stats.over_seeds([r["scores"][k] for r in mine]) for k in keys},
                "train_wall_s": [r["train_wall_s"] for r in mine]})
    return rows


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--seeds", type=int, default=3)
    parser.add_argument("--scale", type=float, default=1.0,
                        help="multiply every budget (e.g. 0.01 for a smoke run)")
    parser.add_argument("--episodes", type=int, default=200)
    parser.add_argument("--tasks", nargs="*", default=[t.name for t in TASKS],
                        choices=[t.name for t in TASKS])
    parser.add_argument("--algos", nargs="*", default=list(ALGOS), choices=ALGOS)
    parser.add_argument("--workers", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--json", type=Path, help="write every run and the table's rows here")
    parser.add_argument("--merge", type=Path,
                        help="an earlier run's JSON: its runs join this one's in the table "
                             "(a task, algorithm and seed run here replaces the earlier one)")
    args = parser.parse_args(argv)
    if args.seeds < 1 or args.scale <= 0 or args.episodes < 2 or args.workers < 1:
        parser.error("--seeds, --workers >= 1; --scale > 0; --episodes >= 2")
    earlier = None
    if args.merge is not None:
        earlier = json.loads(args.merge.read_text())
        same = {"episodes": args.episodes, "scale": args.scale, "sac_settings": SAC_SETTINGS,
                "sac_envs": SAC_ENVS}
        differ = [k for k, v in same.items() if earlier.get(k) != v]
        if differ:
            parser.error(f"--merge: {args.merge} was run with other {', '.join(differ)}")
    jobs = [(t, a, s) for t in args.tasks for a in args.algos for s in range(args.seeds)
            if a != "SAC+HER" or t in HER_TASKS]
    t0 = time.perf_counter()
    runs = []
    with ProcessPoolExecutor(args.workers, mp_context=get_context("spawn")) as pool_:
        futures = [pool_.submit(run_one, t, a, s, args.scale, args.episodes) for t, a, s in jobs]
        for i, f in enumerate(futures, 1):
            r = f.result()
            runs.append(r)
            print(f"[{i}/{len(jobs)}] {r['task']} {r['algo']} seed {r['seed']}: mean return "
                  f"{np.mean(r['returns']):.3f}, {r['train_wall_s']:.0f} s "
                  f"({time.perf_counter() - t0:.0f} s elapsed)", flush=True)
    wall = round(time.perf_counter() - t0, 1)
    if earlier is not None:
        done = {(r["task"], r["algo"], r["seed"]) for r in runs}
        runs = [r for r in earlier["runs"]
                if (r["task"], r["algo"], r["seed"]) not in done] + runs
        wall += earlier["wall_s"]
    doc = {"kind": KIND, "episodes": args.episodes, "scale": args.scale,
           "sac_settings": SAC_SETTINGS, "sac_envs": SAC_ENVS, "wall_s": wall,
           "rows": pool(runs), "runs": runs}
    print(render(doc))
    if args.json is not None:
        args.json.write_text(json.dumps(doc, indent=1) + "\n")
        print(f"wrote {args.json}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
