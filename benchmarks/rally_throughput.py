"""Throughput of the two-player rally views, beside the low-level env in the same run.

Run: ``python benchmarks/rally_throughput.py [--quick] [--json PATH]``

Rows, each the best of 3 timed repeats after a warm-up (the machine is shared and noisy):
- low-level ``SimpleReturnVectorEnv`` at N = 256, random actions: the reference;
- ``SimpleRallyVectorEnv`` with 256 rallies (512 player slots), random actions: rally decisions/s
  counting one decision per rally (both players act in it) and per player slot;
- ``RallyTask`` driven by the scripted controllers (policy cost included);
- ``SimpleRallyTurnVectorEnv`` with 256 rallies and the scripted low level: turn-based steps/s
  (one step = one turn, spanning many decisions) and the decisions/s inside them;
- the rally's ceilings: raw ``mujoco.mj_step`` of the very model the rally steps (256 rallies x
  2 players in one model), in a Python loop, five steps per decision: what MuJoCo alone costs;
  and the rally's ``Game.step`` alone (the compiled physics steps and judging, random actions,
  a game served again when its rally ends): what the game costs without the task's
  observations and rewards or the Gymnasium API.
Targets (issue 3): none fixed; the ratio to the low-level env is printed.
"""

from __future__ import annotations

import argparse
import json
import time
from collections.abc import Callable

import numpy as np

from rallysim.core.tasks.rally import RallyTask
from rallysim.envs.simple_rally_turn_v0 import SimpleRallyTurnVectorEnv
from rallysim.envs.simple_rally_v0 import SimpleRallyVectorEnv
from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv
from rallysim.policies import ScriptedController

N = 256


def best_rate(run: Callable[[], float], repeats: int = 3) -> float:
    """Best of ``repeats`` of ``run()``, which returns units done per second."""
    return max(run() for _ in range(repeats))


def timed(step: Callable[[], int], seconds: float) -> float:
    done, start = 0, time.perf_counter()
    while time.perf_counter() - start < seconds:
        done += step()
    return done / (time.perf_counter() - start)


def random_rate(env, slots: int, seconds: float) -> float:
    """Best decisions/s of ``env`` (N units, ``slots`` action rows) under random actions."""
    env.reset(seed=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (64, slots, 3))
    it = iter(range(10**12))

    def step() -> int:
        env.step(actions[next(it) % 64])
        return N

    step()
    return best_rate(lambda: timed(step, seconds))


def low_level(seconds: float) -> float:
    return random_rate(SimpleReturnVectorEnv(N, seed=0, autoreset_mode="same_step"), N, seconds)


def rally_random(seconds: float) -> float:
    env = SimpleRallyVectorEnv(N, seed=0, autoreset_mode="same_step")
    return random_rate(env, 2 * N, seconds)


def rally_scripted(seconds: float) -> float:
    task = RallyTask(N, seed=0)
    task.reset(np.arange(N))
    c = ScriptedController()
    goals = np.full(2 * N, 4.0)

    def step() -> int:
        obs = task.observe().reshape(-1, 20)
        _, term, trunc, _ = task.step(c(obs, goals).reshape(N, 2, 3))
        done = term | trunc
        if done.any():
            task.reset(np.flatnonzero(done))
        return N

    step()
    return best_rate(lambda: timed(step, seconds))


def rally_raw(seconds: float) -> float:
    """Rally decisions/s that MuJoCo's own step of the rally's model allows (5 per decision)."""
    import mujoco

    from rallysim.core.bodies import build_simple_world

    model = build_simple_world(N, 2)
    data = mujoco.MjData(model)

    def step() -> int:
        for _ in range(5):
            mujoco.mj_step(model, data)
        return N

    step()
    return best_rate(lambda: timed(step, seconds))


def rally_game(seconds: float) -> float:
    """Rally decisions/s of the rally's ``Game.step`` alone."""
    task = RallyTask(N, seed=0)
    game, cap = task.game, task.config.max_hits
    game.reset(np.arange(N), receiver=0)
    actions = np.random.default_rng(0).uniform(-1, 1, (64, N, 2, 3))
    it = iter(range(10**12))

    def step() -> int:
        game.step(actions[next(it) % 64])
        over = np.flatnonzero(~game.in_play | (game.hits >= cap))
        if len(over):
            game.reset(over, receiver=0)
        return N

    step()
    return best_rate(lambda: timed(step, seconds))


def turns_scripted(seconds: float) -> tuple[float, float]:
    env = SimpleRallyTurnVectorEnv(N, low_level="scripted", seed=0, autoreset_mode="same_step")
    env.reset(seed=0)
    rng = np.random.default_rng(0)
    decisions = [0]

    def step() -> int:
        _, _, _, _, info = env.step(rng.uniform(2, 6, (N, 1)))
        decisions[0] += int(info["decisions"].sum())
        return N

    step()
    best_turns, best_dec = 0.0, 0.0
    for _ in range(3):
        decisions[0] = 0
        start = time.perf_counter()
        turns = 0
        while time.perf_counter() - start < seconds:
            turns += step()
        wall = time.perf_counter() - start
        if turns / wall > best_turns:
            best_turns, best_dec = turns / wall, decisions[0] / wall
    return best_turns, best_dec


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--quick", action="store_true", help="short timings (smoke test)")
    parser.add_argument("--json", help="write every number to this path")
    args = parser.parse_args()
    seconds = 0.3 if args.quick else 2.0

    ref = low_level(seconds)
    rows = {
        "low-level SimpleReturnVectorEnv, random (reference)": (ref, ref),
        "rally SimpleRallyVectorEnv, random": (rally_random(seconds), None),
        "rally RallyTask + scripted controllers": (rally_scripted(seconds), None),
        "rally ceiling: raw mj_step of its model": (rally_raw(seconds), None),
        "rally ceiling: its Game.step alone": (rally_game(seconds), None),
    }
    turn_rate, turn_decisions = turns_scripted(seconds)
    print(f"N = {N} environments (rallies); decisions/s count one per environment per step\n")
    print("| benchmark | decisions/s | ratio to low-level | note |")
    print("|---|---:|---:|---|")
    results = {}
    for name, (rate, _) in rows.items():
        note = ("5 mj_step calls per decision, nothing else" if "mj_step" in name
                else "compiled steps and judging, no task or API" if "Game.step" in name
                else "both players act in each rally decision" if "rally" in name else "")
        print(f"| {name} | {rate:,.0f} | {rate / ref:.2f} | {note} |")
        results[name] = rate
    print(f"| turn-based SimpleRallyTurnVectorEnv, scripted low level | {turn_decisions:,.0f} | "
          f"{turn_decisions / ref:.2f} | {turn_rate:,.0f} turn steps/s |")
    results["turn steps/s"] = turn_rate
    results["turn decisions/s"] = turn_decisions
    if args.json:
        with open(args.json, "w") as f:
            json.dump(results, f, indent=2)


if __name__ == "__main__":
    main()
