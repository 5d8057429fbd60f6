"""Throughput of ``RallySim/HumanLikeReturn-v0``'s batched env beside raw MuJoCo on its model.

Run: ``python benchmarks/humanlike_throughput.py [--quick] [--json PATH] [--strict]``

Units: a *decision* is one environment advanced by one ``step`` (5 physics steps of 0.02 s); a
*physics step* is one environment (one player) advanced by 0.02 s. All rates are per
environment, so a batched call at N environments counts N.

Rows, all measured in one run:

ours
    ``HumanLikeReturnVectorEnv(N, autoreset_mode="same_step")`` with uniform random actions in
    [-1, 1] (pre-drawn, so drawing them is not timed), at N = 64 and 256; and at N = 256 driven
    by ``ScriptedSwing`` (policy cost included); and one ``gym.make("RallySim/HumanLikeReturn-v0")``
    (Gymnasium's wrappers included), reset when an episode ends.
bodies
    ``HumanLikeBodies.physics_step`` alone at N = 1, 64 and 256 with random actions held for 5
    steps: the servo solve, MuJoCo and the joint stops, without the rulebook, observations or
    API.
(a2) raw batched model
    ``mujoco.mj_step`` in a Python loop on ``build_humanlike_world(N, 1)``, the very model the
    env steps (one call = N physics steps), with motors holding the players still (MuJoCo's cost
    does not depend on the pose: nothing collides).
(a1) raw single world
    The same on ``build_humanlike_world(1, 1)``: one player per ``mj_step``, the cost any
    one-model-per-environment design starts from. Also through ``mujoco.rollout`` (a C loop)
    where available; the faster of the two is the single-world ceiling.

Each figure is the best of 3 timed repeats after a warm-up. The exit code is 0 even when the
target (>= 10,000 decisions/s at N = 256) fails, unless ``--strict`` is given.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import sys
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass

import gymnasium as gym
import mujoco
import numpy as np

from rallysim.core.game import PHYSICS_STEPS_PER_DECISION
from rallysim.core.humanlike import N_ACTIONS, HumanLikeBodies, build_humanlike_world
from rallysim.envs.humanlike_return_v0 import HumanLikeReturnVectorEnv
from rallysim.policies.scripted_swing import ScriptedSwing

try:
    from mujoco import rollout as mj_rollout
except ImportError:  # pragma: no cover - older or trimmed bindings
    mj_rollout = None

NS = (64, 256)
SINGLE_ID = "RallySim/HumanLikeReturn-v0"
TARGET_N, TARGET_DECISIONS = 256, 10_000.0
STEPS = PHYSICS_STEPS_PER_DECISION


@dataclass
class Budget:
    repeat_s: float  # seconds per timed repeat
    repeats: int


FULL, QUICK = Budget(1.5, 3), Budget(0.3, 2)


@dataclass
class Row:
    key: str
    label: str
    n: int
    decisions_per_s: float | None
    physics_per_s: float


def calls_per_second(step: Callable[[], None], budget: Budget) -> float:
    """Best rate of ``step`` calls over the repeats, after a warm-up."""
    for _ in range(3):
        step()
    best = 0.0
    for _ in range(budget.repeats):
        calls, start = 0, time.perf_counter()
        while (elapsed := time.perf_counter() - start) < budget.repeat_s:
            step()
            calls += 1
        best = max(best, calls / elapsed)
    return best


def random_actions(n: int, shape: tuple[int, ...], seed: int = 0):
    """An endless cycle of 64 pre-drawn uniform action batches."""
    batches = np.random.default_rng(seed).uniform(-1, 1, (64, n, *shape)).astype(np.float32)
    i = 0
    while True:
        yield batches[i % 64]
        i += 1


def env_stepper(n: int, scripted: bool = False) -> Callable[[], None]:
    env = HumanLikeReturnVectorEnv(n, seed=0, autoreset_mode="same_step")
    obs, _ = env.reset(seed=0)
    if scripted:
        controller, box = ScriptedSwing(), [obs]

        def step() -> None:
            box[0] = env.step(controller(box[0]))[0]
        return step
    actions = random_actions(n, (N_ACTIONS,))
    return lambda: env.step(next(actions))


def single_stepper() -> Callable[[], None]:
    """One decision of ``gym.make(SINGLE_ID)``, reset when its episode ends."""
    env = gym.make(SINGLE_ID)
    env.reset(seed=0)
    actions = random_actions(1, (N_ACTIONS,))

    def step() -> None:
        _, _, terminated, truncated, _ = env.step(next(actions)[0])
        if terminated or truncated:
            env.reset()
    return step


def bodies_stepper(n: int) -> Callable[[], None]:
    """One decision's worth (5 physics steps) of the bodies alone."""
    b = HumanLikeBodies(n, 1)
    b.reset(np.arange(n), np.full((n, 1), -3.0))
    actions = random_actions(n, (1, N_ACTIONS))

    def step() -> None:
        b.set_actions(next(actions).astype(np.float64))
        for _ in range(STEPS):
            b.physics_step()
    return step


def still_world(n: int) -> tuple[mujoco.MjModel, mujoco.MjData]:
    """The batched model with every player at its zero pose, motors holding it against gravity."""
    m = build_humanlike_world(n, 1)
    d = mujoco.MjData(m)
    d.mocap_pos[:, 0], d.mocap_pos[:, 2] = -3.0, HumanLikeBodies.hips_height
    mujoco.mj_forward(m, d)
    d.ctrl[:] = d.qfrc_bias
    return m, d


def raw_rows(key: str, label: str, n: int, budget: Budget) -> list[Row]:
    m, d = still_world(n)
    rows = [Row(f"{key}_loop", f"{label}, Python loop", n, None,
                calls_per_second(lambda: mujoco.mj_step(m, d), budget) * n)]
    if mj_rollout is not None and n == 1:
        k = 1000
        state = np.zeros(mujoco.mj_stateSize(m, mujoco.mjtState.mjSTATE_FULLPHYSICS))
        mujoco.mj_getState(m, d, state, mujoco.mjtState.mjSTATE_FULLPHYSICS)
        ctrl = np.tile(d.ctrl, (k, 1))
        rate = calls_per_second(lambda: mj_rollout.rollout(m, d, state, ctrl), budget)
        rows.append(Row(f"{key}_rollout", f"{label}, mujoco.rollout (C loop)", n, None,
                        rate * k * n))
    return rows


def throughput_rows(budget: Budget) -> list[Row]:
    rows = []
    for n in NS:
        rate = calls_per_second(env_stepper(n), budget) * n
        rows.append(Row(f"ours_{n}", "HumanLikeReturnVectorEnv, random actions", n, rate,
                        rate * STEPS))
    rate = calls_per_second(env_stepper(TARGET_N, scripted=True), budget) * TARGET_N
    rows.append(Row(f"scripted_{TARGET_N}", "HumanLikeReturnVectorEnv + ScriptedSwing",
                    TARGET_N, rate, rate * STEPS))
    rate = calls_per_second(single_stepper(), budget)
    rows.append(Row("single", f"gym.make({SINGLE_ID!r}), random actions", 1, rate,
                    rate * STEPS))
    for n in (1, *NS):
        rate = calls_per_second(bodies_stepper(n), budget) * n
        rows.append(Row(f"bodies_{n}", "HumanLikeBodies.physics_step only, random actions", n,
                        rate, rate * STEPS))
    for n in NS:
        rows += raw_rows(f"a2_{n}", "(a2) raw mj_step, the batched N-player model", n, budget)
    rows += raw_rows("a1", "(a1) raw mj_step, one player", 1, budget)
    return rows


def _fmt(x: float | None, digits: int = 0) -> str:
    return "—" if x is None else f"{x:,.{digits}f}"


def throughput_table(rows: list[Row]) -> str:
    lines = ["| benchmark | N | decisions/s | physics steps/s |", "|---|---:|---:|---:|"]
    lines += [f"| {r.label} | {r.n} | {_fmt(r.decisions_per_s)} | {_fmt(r.physics_per_s)} |"
              for r in rows]
    return "\n".join(lines)


def ratio_table(rows: dict[str, Row]) -> tuple[str, dict]:
    ceiling = max(r.physics_per_s for k, r in rows.items() if k.startswith("a1_"))
    lines = ["| N | ours ÷ (a2) raw batched | bodies ÷ (a2) | ours ÷ bodies "
             "| ours ÷ (a1) single-world ceiling |", "|---:|---:|---:|---:|---:|"]
    out = {}
    for n in NS:
        ours, bodies = rows[f"ours_{n}"].physics_per_s, rows[f"bodies_{n}"].physics_per_s
        raw = rows[f"a2_{n}_loop"].physics_per_s
        out[str(n)] = {"ours_a2": ours / raw, "bodies_a2": bodies / raw,
                       "ours_bodies": ours / bodies, "ours_a1": ours / ceiling}
        r = out[str(n)]
        lines.append(f"| {n} | {r['ours_a2']:.2f} | {r['bodies_a2']:.2f} | "
                     f"{r['ours_bodies']:.2f} | {r['ours_a1']:.2f} |")
    return "\n".join(lines), out


def machine() -> str:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")),
                       cpu)
    except OSError:
        pass
    load = os.getloadavg() if hasattr(os, "getloadavg") else None
    return (f"{os.cpu_count()} CPUs ({cpu}), Python {platform.python_version()}, mujoco "
            f"{mujoco.__version__}, numpy {np.__version__}, load average {load}")


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="short timings: a smoke test")
    p.add_argument("--json", metavar="PATH", help="write every number to this JSON file")
    p.add_argument("--strict", action="store_true", help="exit 1 if the target fails")
    args = p.parse_args(argv)
    budget = QUICK if args.quick else FULL
    began = time.perf_counter()
    print("# HUMAN-LIKE env throughput" + (" (--quick)" if args.quick else ""))
    print(f"machine: {machine()}\n", flush=True)
    rows = throughput_rows(budget)
    by_key = {r.key: r for r in rows}
    ratios_md, ratios = ratio_table(by_key)
    dec = by_key[f"ours_{TARGET_N}"].decisions_per_s or 0.0
    ok = dec >= TARGET_DECISIONS
    print(f"## Throughput (per environment; best of {budget.repeats} x {budget.repeat_s} s)\n")
    print(throughput_table(rows) + "\n")
    print("## Ratios (physics steps/s)\n\n" + ratios_md + "\n")
    print(f"## Target\n\n| target | measured | result |\n|---|---:|---|\n| >= "
          f"{TARGET_DECISIONS:,.0f} decisions/s at N = {TARGET_N} | {dec:,.0f} | "
          f"{'PASS' if ok else 'FAIL'} |\n")
    print(f"total time: {time.perf_counter() - began:.1f} s")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"machine": machine(), "rows": [asdict(r) for r in rows],
                       "ratios": ratios, "target_pass": ok}, f, indent=2)
    return 1 if args.strict and not ok else 0


if __name__ == "__main__":
    sys.exit(main())
