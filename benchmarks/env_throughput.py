"""Throughput and memory of ``RallySim/SimpleReturn-v0``: the batched vector env and the single env.

Run: ``python benchmarks/env_throughput.py [--quick] [--json PATH] [--strict]``

Units
-----
All rates count per environment ("env-steps"). A *decision* is one environment advanced by one
``step``; a batched ``step`` at N environments is N decisions. A *physics step* is one
environment advanced by one MuJoCo step; a SimpleReturn decision is 5 physics steps of 0.02 s.

What is measured, all in one run
--------------------------------
ours
    ``SimpleReturnVectorEnv(num_envs=N, seed=0, autoreset_mode="same_step")`` at N = 1, 64,
    256 with uniform random actions in [-1, 1], pre-generated so that drawing them is not timed.
    Extra rows run ``ScriptedController.act_return`` in the loop (policy cost included).
ours, single env
    ``gym.make("RallySim/SimpleReturn-v0")`` and ``gym.make("RallySim/HumanLikeReturn-v0")``
    (Gymnasium's wrappers included) with pre-generated uniform random actions, reset when an
    episode ends: the way one environment is used without a vector env. The single envs and
    the single pendulum below are timed in turn, one repeat of each per round, so that a slower
    minute of a shared machine slows them all.
(a1) single-world raw ceiling
    ``mujoco.mj_step`` on ``build_simple_world(1, 1)``, the MJCF model of one SIMPLE player, in
    a tight Python loop and through ``mujoco.rollout`` (a C loop: no Python per step). The
    faster of the two is "the ceiling": what the physics alone costs per world when nothing
    else (rules, shuttle flight, observations, rewards, the Gymnasium API) is done.
(a2) batched raw model
    ``mj_step`` on ``build_simple_world(N, 1)``, the very model the env steps at that N (one
    ``mj_step`` = N env-physics-steps), Python loop and rollout. The loop is timed in turn
    with "ours" at the same N (one repeat of each per round), so that their ratio compares
    the same minutes of a shared machine. ours / (a2) is the share of the
    time that MuJoCo itself takes; the rest is the rules and the API around it.
(b) a standard Gymnasium MuJoCo env
    ``InvertedPendulum-v5`` in ``gymnasium.vector.SyncVectorEnv`` (same-step autoreset, random
    actions) at the same N: one Python env object per environment. Compared per physics step
    (decisions x ``frame_skip``, read from the env; 2 by default), since a decision means
    different work in the two envs. Its rendering stack imports ``glfw`` and ``imageio`` at
    module level; where they are missing, empty placeholder modules stand in (never rendered).
    Also as one ``gym.make("InvertedPendulum-v5")``, reset when an episode ends, against the
    single envs above.
memory
    In fresh subprocesses, so that this process's allocations do not count: the peak RSS of
    building the N = 256 env and running it, and the RSS growth over a 1,000,000-decision run
    (100,000 with ``--quick``) from 10 % of the run to its end. The peak is ``VmHWM`` of
    ``/proc/self/status``: a child's ``ru_maxrss`` is not used, because Linux carries the
    parent's high-water mark into a child started by vfork + exec (as ``subprocess`` does), so
    it would report this process's peak; ``ru_maxrss`` is only the fallback off Linux.

Each throughput figure is the best of 3 timed repeats (``time.perf_counter``) after a warm-up;
the exit code is 0 even when a target fails, unless ``--strict`` is given.
"""

from __future__ import annotations

import argparse
import importlib.util
import itertools
import json
import os
import platform
import resource
import subprocess
import sys
import time
import types
from collections.abc import Callable, Iterator
from dataclasses import asdict, dataclass
from importlib import metadata
from typing import Any

import gymnasium as gym
import mujoco
import numpy as np

from rallysim.core.bodies import build_simple_world
from rallysim.core.game import PHYSICS_STEPS_PER_DECISION
from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv
from rallysim.policies.scripted import ScriptedController

try:
    from mujoco import rollout as mj_rollout
except ImportError:  # pragma: no cover - older or trimmed bindings
    mj_rollout = None

Stepper = Callable[[int], None]  # advances a benchmark by k calls

NS = (1, 64, 256)
N_TARGET = 256
ACTION_BUFFER = 64  # pre-generated batches of random actions, cycled
CHUNK_S = 0.005  # calls are timed in chunks of about this long
ROLLOUT_SECONDS_PER_CALL = 0.002  # aim of the steps per rollout call (sized from the loop rate)
MIB = 1024 * 1024

TARGET_DECISIONS = 40_000.0
TARGET_CEILING_SHARE = 0.60
TARGET_VS_PENDULUM = 3.0
TARGET_SINGLE_DECISIONS = 10_000.0  # gym.make("RallySim/SimpleReturn-v0")
TARGET_SINGLE_VS_PENDULUM = 2.0  # per physics step, against one InvertedPendulum-v5 (issue 37)
TARGET_SINGLE_HUMANLIKE_DECISIONS = 5_000.0  # gym.make("RallySim/HumanLikeReturn-v0") (issue 37)
TARGET_BATCHED_SHARE = 0.60  # of raw mj_step of the same batched model (a2), N = 256 (issue 37)
SIMPLE_ID, HUMANLIKE_ID, PENDULUM_ID = ("RallySim/SimpleReturn-v0", "RallySim/HumanLikeReturn-v0",
                                       "InvertedPendulum-v5")
TARGET_PEAK_MB = 300.0
TARGET_GROWTH_MB = 5.0


@dataclass(frozen=True)
class Budget:
    """How long to time each configuration."""

    warmup_s: float
    repeat_s: float
    repeats: int
    peak_decisions: int
    growth_decisions: int


FULL = Budget(warmup_s=0.3, repeat_s=0.8, repeats=3, peak_decisions=51_200,
              growth_decisions=1_000_000)
QUICK = Budget(warmup_s=0.05, repeat_s=0.1, repeats=3, peak_decisions=12_800,
               growth_decisions=100_000)


@dataclass
class Row:
    """One measured configuration. Rates are per environment; ``None`` where not applicable."""

    key: str
    label: str
    n: int
    calls_per_s: float | None
    decisions_per_s: float | None
    physics_per_s: float | None
    note: str = ""


# -- timing ------------------------------------------------------------------------------------
def _calibrate(step: Stepper) -> int:
    """Calls per timed chunk: doubled until a chunk takes at least ``CHUNK_S``."""
    k = 1
    while True:
        start = time.perf_counter()
        step(k)
        if time.perf_counter() - start >= CHUNK_S or k >= 1 << 20:
            return k
        k *= 2


def _rate_for(step: Stepper, chunk: int, seconds: float) -> float:
    """Calls per second of ``step`` run in chunks for at least ``seconds``."""
    calls, start = 0, time.perf_counter()
    end = start + seconds
    while True:
        step(chunk)
        calls += chunk
        now = time.perf_counter()
        if now >= end:
            return calls / (now - start)


def calls_per_second(step: Stepper, budget: Budget) -> float:
    """Best calls/s over ``budget.repeats`` timed repeats, after a warm-up."""
    return interleaved_calls_per_second([step], budget)[0]


def interleaved_calls_per_second(steps: list[Stepper], budget: Budget) -> list[float]:
    """``calls_per_second`` of each of ``steps``, their repeats taken in turn (round r times
    each once)."""
    chunks = [_calibrate(step) for step in steps]
    for step, chunk in zip(steps, chunks, strict=True):
        _rate_for(step, chunk, budget.warmup_s)
    rates = [[_rate_for(step, chunk, budget.repeat_s) for step, chunk in zip(steps, chunks,
                                                                           strict=True)]
             for _ in range(budget.repeats)]
    return [max(column) for column in zip(*rates, strict=True)]


# -- ours --------------------------------------------------------------------------------------
def _make_env(n: int) -> SimpleReturnVectorEnv:
    env = SimpleReturnVectorEnv(num_envs=n, seed=0, autoreset_mode="same_step")
    env.reset(seed=0)
    return env


def _random_actions(n: int, seed: int = 0) -> Iterator[np.ndarray]:
    rng = np.random.default_rng(seed)
    batches = rng.uniform(-1.0, 1.0, (ACTION_BUFFER, n, 3)).astype(np.float32)
    return itertools.cycle(list(batches))


def ours_random_stepper(n: int) -> Stepper:
    env, actions = _make_env(n), _random_actions(n)

    def step(k: int) -> None:
        for _ in range(k):
            env.step(next(actions))

    return step


def ours_scripted_stepper(n: int) -> Stepper:
    env, controller = _make_env(n), ScriptedController()
    obs = [env.reset(seed=0)[0]]

    def step(k: int) -> None:
        for _ in range(k):
            obs[0] = env.step(controller.act_return(obs[0]))[0]

    return step


def single_stepper(env_id: str) -> tuple[Stepper, gym.Env]:
    """``gym.make(env_id)`` stepped with pre-drawn uniform random actions, reset at each
    episode's end (as a training or evaluation loop over one environment does)."""
    env = gym.make(env_id)
    env.reset(seed=0)
    space = env.action_space
    batches = np.random.default_rng(0).uniform(space.low, space.high,
                                               (ACTION_BUFFER, *space.shape))
    actions = itertools.cycle(list(batches.astype(space.dtype)))

    def step(k: int) -> None:
        for _ in range(k):
            _, _, terminated, truncated, _ = env.step(next(actions))
            if terminated or truncated:
                env.reset()

    return step, env


@dataclass(frozen=True)
class Single:
    """A single-env row to measure: ``physics_per_decision`` None: the env's ``frame_skip``."""

    key: str
    label: str
    env_id: str
    physics_per_decision: int | None = None


def bench_singles(singles: list[Single], budget: Budget) -> list[Row]:
    """The single-env rows, timed in turn (``interleaved_calls_per_second``)."""
    made, rows = [], {}
    stubbed = _stub_render_modules()  # (where bench_pendulum has not made them already)
    for single in singles:
        try:
            step, env = single_stepper(single.env_id)
        except Exception as exc:  # a missing dependency, a Gymnasium without the env, ...
            rows[single.key] = Row(single.key, single.label, 1, None, None, None,
                                   f"cannot be created: {type(exc).__name__}: {exc}")
            continue
        per = single.physics_per_decision or int(env.unwrapped.frame_skip)
        note = f"{per} physics steps per decision"
        if stubbed and single.env_id == PENDULUM_ID:
            note += f"; placeholder {', '.join(stubbed)} (render-only imports)"
        made.append((single, step, per, note))
    rates = interleaved_calls_per_second([step for _, step, _, _ in made], budget)
    for (single, _, per, note), calls in zip(made, rates, strict=True):
        rows[single.key] = Row(single.key, single.label, 1, calls, calls, calls * per, note)
    return [rows[single.key] for single in singles]


# -- (a) raw MuJoCo ----------------------------------------------------------------------------
def _raw_data(model: mujoco.MjModel) -> mujoco.MjData:
    """Data with a nonzero control: +-0.5 N m on alternate arms."""
    data = mujoco.MjData(model)
    data.ctrl[:] = np.where(np.arange(model.nu) % 2 == 0, 0.5, -0.5)
    mujoco.mj_forward(model, data)
    return data


def raw_loop_stepper(model: mujoco.MjModel) -> Stepper:
    data = _raw_data(model)
    qpos0 = data.qpos.copy()

    def step(k: int) -> None:
        # Nothing stops the driven arms here; restarting each chunk keeps the state bounded.
        data.qpos[:] = qpos0
        data.qvel[:] = 0.0
        for _ in range(k):
            mujoco.mj_step(model, data)

    return step


def raw_rollout_stepper(model: mujoco.MjModel, nstep: int) -> Stepper:
    """Each call is one ``mujoco.rollout`` of ``nstep`` steps from the initial state."""
    assert mj_rollout is not None
    data = _raw_data(model)
    spec = mujoco.mjtState.mjSTATE_FULLPHYSICS
    size = mujoco.mj_stateSize(model, spec)
    initial = np.empty((1, size))
    mujoco.mj_getState(model, data, initial[0], spec)
    control = np.broadcast_to(data.ctrl, (1, nstep, model.nu)).copy()
    states = np.empty((1, nstep, size))

    def step(k: int) -> None:
        for _ in range(k):
            mj_rollout.rollout(model, data, initial, control, nstep=nstep, state=states)

    return step


def bench_raw(key: str, label: str, model: mujoco.MjModel, n: int, budget: Budget,
              loop: float | None = None) -> list[Row]:
    """(a) rows for ``model`` (``n`` worlds per mj_step): Python loop (``loop`` calls/s where
    it was timed already), then rollout."""
    if loop is None:
        loop = calls_per_second(raw_loop_stepper(model), budget)
    rows = [Row(f"{key}_loop", f"{label}, Python loop", n, loop, None, loop * n)]
    if mj_rollout is None:
        rows.append(Row(f"{key}_rollout", f"{label}, rollout", n, None, None, None,
                        "mujoco.rollout not available"))
        return rows
    nstep = max(1, int(loop * ROLLOUT_SECONDS_PER_CALL))
    calls = calls_per_second(raw_rollout_stepper(model, nstep), budget)
    rows.append(Row(f"{key}_rollout", f"{label}, mujoco.rollout (C loop)", n, calls * nstep,
                    None, calls * nstep * n, f"{nstep} steps per rollout call"))
    return rows


# -- (b) InvertedPendulum-v5 -------------------------------------------------------------------
def _stub_render_modules() -> list[str]:
    """Placeholder modules for the render-only imports of Gymnasium's MuJoCo envs."""
    stubbed = []
    for name in ("glfw", "imageio"):
        if name not in sys.modules and importlib.util.find_spec(name) is None:
            sys.modules[name] = types.ModuleType(name)
            stubbed.append(name)
    return stubbed


def pendulum_stepper(n: int) -> tuple[Stepper, int]:
    """SyncVectorEnv of ``n`` InvertedPendulum-v5 envs and its frame_skip."""
    kwargs: dict[str, Any] = {}
    mode = getattr(gym.vector, "AutoresetMode", None)
    if mode is not None:
        kwargs["autoreset_mode"] = mode.SAME_STEP
    env = gym.vector.SyncVectorEnv([lambda: gym.make("InvertedPendulum-v5")] * n, **kwargs)
    env.reset(seed=0)
    frame_skip = int(env.envs[0].unwrapped.frame_skip)
    space = env.single_action_space
    rng = np.random.default_rng(0)
    batches = rng.uniform(space.low, space.high, (ACTION_BUFFER, n, *space.shape))
    actions = itertools.cycle(list(batches.astype(space.dtype)))

    def step(k: int) -> None:
        for _ in range(k):
            env.step(next(actions))

    return step, frame_skip


def bench_pendulum(n: int, budget: Budget) -> Row:
    label = "(b) InvertedPendulum-v5, SyncVectorEnv"
    try:
        stubbed = _stub_render_modules()
        step, frame_skip = pendulum_stepper(n)
    except Exception as exc:  # a missing dependency, a Gymnasium without the env, ...
        return Row(f"pendulum_{n}", label, n, None, None, None,
                   f"cannot be created: {type(exc).__name__}: {exc}")
    calls = calls_per_second(step, budget)
    note = f"frame_skip {frame_skip}"
    if stubbed:
        note += f"; placeholder {', '.join(stubbed)} (render-only imports)"
    return Row(f"pendulum_{n}", label, n, calls, calls * n, calls * n * frame_skip, note)


# -- memory (subprocesses) ---------------------------------------------------------------------
def _proc_status_kib(field: str) -> int | None:
    try:
        with open("/proc/self/status") as f:
            for line in f:
                if line.startswith(field + ":"):
                    return int(line.split()[1])
    except OSError:
        pass
    return None


def _ru_maxrss_kib() -> int:
    peak = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss
    return peak // 1024 if sys.platform == "darwin" else peak  # bytes on macOS, KiB on Linux


def _rss_mib() -> float:
    kib = _proc_status_kib("VmRSS")
    return (kib if kib is not None else _ru_maxrss_kib()) / 1024


def child_memory(decisions: int) -> dict[str, Any]:
    """Build the N = 256 env, run ``decisions`` random decisions; RSS samples every 10 %."""
    start_mib = _rss_mib()
    env, actions = _make_env(N_TARGET), _random_actions(N_TARGET)
    built_mib = _rss_mib()
    calls = -(-decisions // N_TARGET)
    marks = {max(1, round(calls * i / 10)): i * 10 for i in range(1, 11)}
    samples: dict[str, float] = {}
    start = time.perf_counter()
    for call in range(1, calls + 1):
        env.step(next(actions))
        if call in marks:
            samples[str(marks[call])] = _rss_mib()
    seconds = time.perf_counter() - start
    hwm = _proc_status_kib("VmHWM")
    return {
        "decisions": calls * N_TARGET,
        "seconds": seconds,
        "rss_after_imports_mib": start_mib,
        "rss_after_build_mib": built_mib,
        "rss_by_percent_mib": samples,
        "peak_rss_mib": (hwm if hwm is not None else _ru_maxrss_kib()) / 1024,
        "peak_source": "VmHWM" if hwm is not None else "ru_maxrss",
        "ru_maxrss_mib": _ru_maxrss_kib() / 1024,
    }


def run_child(decisions: int) -> dict[str, Any]:
    """``child_memory`` in a fresh interpreter; its result, or an ``error`` entry."""
    cmd = [sys.executable, os.path.abspath(__file__), "--child-memory", str(decisions)]
    proc = subprocess.run(cmd, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        return {"error": proc.stderr.strip().splitlines()[-1:] or [f"exit {proc.returncode}"]}
    return json.loads(proc.stdout.strip().splitlines()[-1])


def measure_memory(budget: Budget) -> dict[str, Any]:
    peak = run_child(budget.peak_decisions)
    growth = run_child(budget.growth_decisions)
    if "error" not in growth:
        by_pct = growth["rss_by_percent_mib"]
        growth["growth_mib"] = by_pct["100"] - by_pct["10"]
    return {"peak": peak, "growth": growth}


# -- report ------------------------------------------------------------------------------------
def machine_info() -> dict[str, Any]:
    cpu = platform.processor() or platform.machine()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next((ln.split(":", 1)[1].strip() for ln in f if ln.startswith("model name")),
                       cpu)
    except OSError:
        pass

    def version(dist: str) -> str:
        try:
            return metadata.version(dist)
        except metadata.PackageNotFoundError:
            return "not installed"

    return {
        "cpu_count": os.cpu_count(),
        "cpu": cpu,
        "platform": platform.platform(),
        "python": platform.python_version(),
        "load_average": list(os.getloadavg()) if hasattr(os, "getloadavg") else None,
        "mujoco": mujoco.__version__,
        "numpy": np.__version__,
        "gymnasium": gym.__version__,
        "rallysim": version("rallysim"),
        "mujoco_distribution": f"mujoco-core {version('mujoco-core')}",
        "numba": version("numba"),  # (the single SIMPLE env's compiled kernel: the fast extra)
    }


def _fmt(x: float | None, digits: int = 0) -> str:
    return "—" if x is None else f"{x:,.{digits}f}"


def _ratio(a: float | None, b: float | None) -> float | None:
    return None if a is None or not b else a / b


def throughput_table(rows: list[Row]) -> str:
    lines = ["| benchmark | N | decisions/s | physics steps/s | note |",
             "|---|---:|---:|---:|---|"]
    for r in rows:
        lines.append(f"| {r.label} | {r.n} | {_fmt(r.decisions_per_s)} | "
                     f"{_fmt(r.physics_per_s)} | {r.note} |")
    return "\n".join(lines)


def ratios(rows: dict[str, Row]) -> dict[str, dict[str, float | None]]:
    """Per N: ours (random actions) physics steps/s divided by each reference's."""
    ceiling = max((rows[k].physics_per_s or 0.0 for k in ("a1_loop", "a1_rollout")), default=0.0)
    out = {}
    for n in NS:
        ours = rows[f"ours_{n}"].physics_per_s
        out[str(n)] = {
            "a1_ceiling": _ratio(ours, ceiling),
            "a1_loop": _ratio(ours, rows["a1_loop"].physics_per_s),
            "a2_loop": _ratio(ours, rows[f"a2_{n}_loop"].physics_per_s),
            "a2_rollout": _ratio(ours, rows[f"a2_{n}_rollout"].physics_per_s),
            "pendulum": _ratio(ours, rows[f"pendulum_{n}"].physics_per_s),
        }
    return out


def single_ratio(rows: dict[str, Row]) -> float | None:
    """The single SIMPLE env's physics steps/s divided by one InvertedPendulum-v5's."""
    return _ratio(rows["single_simple"].physics_per_s, rows["single_pendulum"].physics_per_s)


def ratio_table(rat: dict[str, dict[str, float | None]]) -> str:
    lines = ["| N | ours ÷ (a1) ceiling | ours ÷ (a1) loop | ours ÷ (a2) loop "
             "| ours ÷ (a2) rollout | ours ÷ (b) InvertedPendulum-v5 |",
             "|---:|---:|---:|---:|---:|---:|"]
    for n, r in rat.items():
        cells = " | ".join(_fmt(r[k], 2) for k in
                           ("a1_ceiling", "a1_loop", "a2_loop", "a2_rollout", "pendulum"))
        lines.append(f"| {n} | {cells} |")
    return "\n".join(lines)


def targets(rows: dict[str, Row], rat: dict[str, dict[str, float | None]],
            memory: dict[str, Any], growth_decisions: int) -> list[dict[str, Any]]:
    r256 = rat[str(N_TARGET)]
    peak = memory["peak"].get("peak_rss_mib")
    growth = memory["growth"].get("growth_mib")

    def check(name: str, value: float | None, goal: str, ok: bool | None,
              unit: str = "") -> dict[str, Any]:
        return {"target": name, "value": value, "unit": unit, "goal": goal,
                "status": "n/a" if ok is None else ("PASS" if ok else "FAIL")}

    def at_least(v: float | None, g: float) -> bool | None:
        return None if v is None else v >= g

    def below(v: float | None, g: float, strict: bool) -> bool | None:
        return None if v is None else (v < g if strict else v <= g)

    dec = rows[f"ours_{N_TARGET}"].decisions_per_s
    single, single_humanlike = (rows["single_simple"].decisions_per_s,
                                rows["single_humanlike"].decisions_per_s)
    vs_pendulum = single_ratio(rows)
    return [
        check("decisions/s at N=256", dec, f">= {TARGET_DECISIONS:,.0f}",
              at_least(dec, TARGET_DECISIONS)),
        check("physics steps/s ÷ (a1) single-world ceiling, N=256", r256["a1_ceiling"],
              f">= {TARGET_CEILING_SHARE:.2f}", at_least(r256["a1_ceiling"],
                                                         TARGET_CEILING_SHARE), "x"),
        check("physics steps/s ÷ InvertedPendulum-v5, N=256", r256["pendulum"],
              f">= {TARGET_VS_PENDULUM:.1f}", at_least(r256["pendulum"], TARGET_VS_PENDULUM),
              "x"),
        check("peak RSS, N=256 (fresh process)", peak, f"<= {TARGET_PEAK_MB:.0f}",
              below(peak, TARGET_PEAK_MB, strict=False), "MiB"),
        check(f"RSS growth, 10 % -> 100 % of {growth_decisions:,} decisions", growth,
              f"< {TARGET_GROWTH_MB:.0f}", below(growth, TARGET_GROWTH_MB, strict=True), "MiB"),
        check(f"decisions/s, single env (gym.make {SIMPLE_ID})", single,
              f">= {TARGET_SINGLE_DECISIONS:,.0f}", at_least(single, TARGET_SINGLE_DECISIONS)),
        check(f"physics steps/s, single env ÷ single {PENDULUM_ID}", vs_pendulum,
              f">= {TARGET_SINGLE_VS_PENDULUM:.1f}",
              at_least(vs_pendulum, TARGET_SINGLE_VS_PENDULUM), "x"),
        check(f"decisions/s, single env (gym.make {HUMANLIKE_ID})", single_humanlike,
              f">= {TARGET_SINGLE_HUMANLIKE_DECISIONS:,.0f}",
              at_least(single_humanlike, TARGET_SINGLE_HUMANLIKE_DECISIONS)),
        check("physics steps/s ÷ (a2) batched raw loop, N=256", r256["a2_loop"],
              f">= {TARGET_BATCHED_SHARE:.2f}", at_least(r256["a2_loop"], TARGET_BATCHED_SHARE),
              "x"),
    ]


def target_table(checks: list[dict[str, Any]]) -> str:
    lines = ["| target | measured | goal | result |", "|---|---:|---:|---|"]
    for c in checks:
        value = _fmt(c["value"], 0 if c["unit"] == "" else 2)
        lines.append(f"| {c['target']} | {value} {c['unit']} | {c['goal']} {c['unit']} "
                     f"| {c['status']} |")
    return "\n".join(lines)


def memory_table(memory: dict[str, Any]) -> str:
    lines = ["| subprocess | decisions | RSS after imports | after build | peak | growth |",
             "|---|---:|---:|---:|---:|---:|"]
    for name, m in memory.items():
        if "error" in m:
            lines.append(f"| {name} | failed: {m['error']} | | | | |")
            continue
        lines.append(f"| {name} | {m['decisions']:,} | {m['rss_after_imports_mib']:.1f} MiB | "
                     f"{m['rss_after_build_mib']:.1f} MiB | {m['peak_rss_mib']:.1f} MiB | "
                     f"{_fmt(m.get('growth_mib'), 2)} MiB |")
    return "\n".join(lines)


# -- main --------------------------------------------------------------------------------------
def throughput_rows(budget: Budget) -> list[Row]:
    rows, raw_loops = [], {}
    for n in NS:
        # ours and (a2)'s loop on the same model timed in turn: their ratio is the target's
        calls, raw_loops[n] = interleaved_calls_per_second(
            [ours_random_stepper(n), raw_loop_stepper(build_simple_world(n, 1))], budget)
        rows.append(Row(f"ours_{n}", "rallysim SimpleReturnVectorEnv, random actions", n, calls,
                        calls * n, calls * n * PHYSICS_STEPS_PER_DECISION))
    for n in NS:
        calls = calls_per_second(ours_scripted_stepper(n), budget)
        rows.append(Row(f"scripted_{n}", "rallysim + ScriptedController.act_return", n, calls,
                        calls * n, calls * n * PHYSICS_STEPS_PER_DECISION, "policy cost included"))
    rows += bench_raw("a1", "(a1) raw mj_step, 1 world", build_simple_world(1, 1), 1, budget)
    for n in NS:
        rows += bench_raw(f"a2_{n}", "(a2) raw mj_step, N worlds", build_simple_world(n, 1), n,
                          budget, raw_loops[n])
    rows += [bench_pendulum(n, budget) for n in NS]
    rows += bench_singles([
        Single("single_simple", f"rallysim gym.make({SIMPLE_ID!r}), random actions",
               SIMPLE_ID, PHYSICS_STEPS_PER_DECISION),
        Single("single_humanlike", f"rallysim gym.make({HUMANLIKE_ID!r}), random actions",
               HUMANLIKE_ID, PHYSICS_STEPS_PER_DECISION),
        Single("single_pendulum", f"(b) gym.make({PENDULUM_ID!r}), random actions",
               PENDULUM_ID),
    ], budget)
    return rows


def parse_args(argv: list[str] | None = None) -> argparse.Namespace:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--quick", action="store_true", help="short timings: a smoke test (< 30 s)")
    p.add_argument("--json", metavar="PATH", help="write every number to this JSON file")
    p.add_argument("--strict", action="store_true", help="exit 1 if any target fails")
    p.add_argument("--child-memory", type=int, metavar="DECISIONS", help=argparse.SUPPRESS)
    return p.parse_args(argv)


def main(argv: list[str] | None = None) -> int:
    args = parse_args(argv)
    if args.child_memory is not None:
        print(json.dumps(child_memory(args.child_memory)))
        return 0
    budget = QUICK if args.quick else FULL
    began = time.perf_counter()
    info = machine_info()
    print("# rallysim env throughput" + (" (--quick)" if args.quick else ""))
    print(f"machine: {info['cpu_count']} CPUs ({info['cpu']}), {info['platform']}, "
          f"Python {info['python']}, load average {info['load_average']}")
    print(f"versions: mujoco {info['mujoco']} ({info['mujoco_distribution']}), numpy "
          f"{info['numpy']}, gymnasium {info['gymnasium']}, numba {info['numba']}, "
          f"rallysim {info['rallysim']}\n",
          flush=True)

    memory = measure_memory(budget)  # first, while this process is still small
    rows = throughput_rows(budget)
    by_key = {r.key: r for r in rows}
    rat = ratios(by_key)
    checks = targets(by_key, rat, memory, budget.growth_decisions)
    elapsed = time.perf_counter() - began

    print("## Throughput (per environment; best of "
          f"{budget.repeats} x {budget.repeat_s} s)\n\n{throughput_table(rows)}\n")
    print(f"## Ours (random actions) ÷ references, physics steps/s\n\n{ratio_table(rat)}\n")
    print(f"Single env ÷ single {PENDULUM_ID}, physics steps/s: "
          f"{_fmt(single_ratio(by_key), 2)}\n")
    print(f"## Memory (N = {N_TARGET}, fresh subprocesses)\n\n{memory_table(memory)}\n")
    print(f"## Targets\n\n{target_table(checks)}\n")
    print(f"total time: {elapsed:.1f} s")

    if args.json:
        with open(args.json, "w") as f:
            json.dump({"machine": info, "budget": asdict(budget),
                       "rows": [asdict(r) for r in rows], "ratios": rat,
                       "single_vs_pendulum": single_ratio(by_key), "memory": memory,
                       "targets": checks, "total_seconds": elapsed}, f, indent=2)
    failed = any(c["status"] == "FAIL" for c in checks)
    return 1 if args.strict and failed else 0


if __name__ == "__main__":
    sys.exit(main())
