"""What PPO alone learns on the SIMPLE low level under a few task and input changes (issue 15's
exploration): one seed per variant, scored on fresh serves by ``score_low_level``.

Variants (combine with commas):
- ``v0``: RallySim/SimpleReturn-v0, the paper's task (goals ~ U[2, 6] m);
- ``v1``: RallySim/SimpleReturn-v1, goals the serve makes reachable;
- ``sharp``: landing term 2 exp(-2 |error|) in place of exp(-0.5 |error|) (a wrapper; not an env);
- ``phase``: 16 extra inputs: for 4 hit heights, the predicted time until the shuttle falls
  through it, its phase within the 0.1 s decision (sine, cosine) and the x offset there
  (a wrapper; the shipped policies do not see these).

PPO settings are the low stage's (64x64 tanh, 256 envs x 16 steps, minibatch 1024, 10 epochs,
lr 3e-4, log-std -0.5). The reference row is the scripted controller on the same serves.

    python benchmarks/low_rl_variants.py --variants v0 v1 v1,sharp v1,sharp,phase \
        --budget 5000000 --seed 0 --json runs/low_rl_variants.json
"""

from __future__ import annotations

import argparse
import json
import time

import numpy as np
import torch
from gymnasium import spaces
from stable_baselines3 import PPO
from stable_baselines3.common.vec_env import VecEnvWrapper

from rallysim.core.reach import PlayerState, ShotPlanner
from rallysim.eval.low_eval import score_low_level
from rallysim.policies import ScriptedController
from rallysim.policies.scripted import DECISION
from rallysim.sb3 import make_vec_env

PLANNER = ShotPlanner()
HEIGHTS = PLANNER.pivot_z + PLANNER.rho * np.cos(np.radians([-60.0, -40.0, -20.0, 0.0]))


def phase_features(obs: np.ndarray) -> np.ndarray:
    s = PlayerState.from_observations(obs)
    x, z = PLANNER.predict(s.pos, s.vel)
    crossed, step = PLANNER.falling_crossings(s.pos, z, HEIGHTS)
    feats = []
    for has, idx in zip(crossed.T, step.T, strict=True):
        th = np.where(has, PLANNER.times[idx], 0.0)
        xh = np.where(has, x[np.arange(len(x)), idx], s.base_x)
        ph = 2 * np.pi * th / DECISION
        feats += [np.sin(ph) * has, np.cos(ph) * has, np.minimum(th, 2.0) - 1.0,
                  np.clip((xh - s.base_x) / 2, -1, 1)]
    return np.stack(feats, 1).astype(np.float32)


class PhaseInputs(VecEnvWrapper):
    def __init__(self, venv) -> None:
        n = venv.observation_space.shape[0] + 4 * len(HEIGHTS)
        super().__init__(venv, observation_space=spaces.Box(-np.inf, np.inf, (n,), np.float32))

    def _f(self, o: np.ndarray) -> np.ndarray:
        return np.concatenate([o, phase_features(o)], 1)

    def reset(self) -> np.ndarray:
        return self._f(self.venv.reset())

    def step_wait(self):
        o, r, d, infos = self.venv.step_wait()
        for i in np.flatnonzero(d):
            infos[i]["terminal_observation"] = self._f(infos[i]["terminal_observation"][None])[0]
        return self._f(o), r, d, infos


class SharpLanding(VecEnvWrapper):
    def reset(self) -> np.ndarray:
        return self.venv.reset()

    def step_wait(self):
        o, r, d, infos = self.venv.step_wait()
        for i in np.flatnonzero(d):
            info = infos[i]
            if info.get("hit") and info.get("landed_in"):
                e = info["landing_error"]
                r[i] += 2.0 * np.exp(-2.0 * e) - np.exp(-0.5 * e)
        return o, r, d, infos


def train(variant: str, budget: int, seed: int) -> dict:
    opts = set(variant.split(","))
    env_id = "RallySim/SimpleReturn-v1" if "v1" in opts else "RallySim/SimpleReturn-v0"
    venv = make_vec_env(env_id, n_envs=256, seed=seed)
    if "sharp" in opts:
        venv = SharpLanding(venv)
    if "phase" in opts:
        venv = PhaseInputs(venv)
    model = PPO("MlpPolicy", venv, n_steps=16, batch_size=1024, n_epochs=10,
                learning_rate=3e-4, seed=seed, device="cpu", verbose=0,
                policy_kwargs={"net_arch": {"pi": [64, 64], "vf": [64, 64]},
                               "activation_fn": torch.nn.Tanh, "log_std_init": -0.5})
    start = time.perf_counter()
    model.learn(budget)
    wall = time.perf_counter() - start

    def act(o: np.ndarray) -> np.ndarray:
        o = np.concatenate([o, phase_features(o)], 1) if "phase" in opts else o
        return model.predict(o, deterministic=True)[0]

    return {"variant": variant, "seed": seed, "budget": budget, "wall_s": round(wall, 1),
            **score_low_level(act, 1000)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--variants", nargs="+", default=["v0", "v1", "v1,sharp",
                                                          "v1,sharp,phase"])
    parser.add_argument("--budget", type=int, default=5_000_000)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--json")
    args = parser.parse_args()
    torch.set_num_threads(1)
    rows = [{"variant": "scripted (reference)", "seed": None, "budget": 0, "wall_s": 0.0,
             **score_low_level(ScriptedController().act_return, 1000)}]
    for variant in args.variants:
        rows.append(train(variant, args.budget, args.seed))
        r = rows[-1]
        print(f"{variant}: hit {r['hit_rate']:.3f}, median error "
              f"{r['median_landing_error']:.2f} m, goal correlation "
              f"{r['goal_correlation']:.3f} (reachable goals), {r['wall_s']:.0f} s", flush=True)
    print("| variant | hit rate | median landing error | goal correlation (reachable) | "
          "median error (reachable) | wall |")
    print("|---|---|---|---|---|---|")
    for r in rows:
        print(f"| {r['variant']} | {r['hit_rate']:.3f} | {r['median_landing_error']:.2f} m | "
              f"{r['goal_correlation']:.3f} | {r['median_landing_error_reachable']:.2f} m | "
              f"{r['wall_s']:.0f} s |")
    if args.json:
        with open(args.json, "w") as f:
            json.dump(rows, f, indent=1)


if __name__ == "__main__":
    main()
