"""The first step of a fresh process: Numba's compile after install, then its cache.

Each measurement is a fresh Python process that imports Gymnasium and RallySim, then times
``gym.make(env_id)``, ``reset`` and the first ``step``: what a user waits for before the first
step (the interpreter's start and the imports before ``gym.make`` are not counted; Numba's
import is, since it happens at the first step). Per env id: one process with an empty Numba
cache (a temporary ``NUMBA_CACHE_DIR``: the first compile after install), then ``--repeats``
processes that find that cache filled (every later start), as many with SciPy hidden where it
is installed (a core install has none; with it, Numba imports ``scipy.linalg`` at its first
use). Each process also counts the functions Numba compiled in that window: none, once the
cache is filled.

Run: ``python benchmarks/first_step.py [--repeats 5] [--json PATH]``
"""

from __future__ import annotations

import argparse
import importlib.abc
import importlib.util
import json
import os
import platform
import statistics
import subprocess
import sys
import tempfile
import time

IDS = ("RallySim/SimpleReturn-v0", "RallySim/HumanLikeReturn-v0")
SCIPY = importlib.util.find_spec("scipy") is not None


HIDE_SCIPY = "FIRST_STEP_HIDE_SCIPY"


class _NoSciPy(importlib.abc.MetaPathFinder):
    """Makes ``import scipy`` fail, as where it is not installed."""

    def find_spec(self, name: str, path: object, target: object = None) -> None:
        if name.split(".")[0] == "scipy":
            raise ModuleNotFoundError(f"No module named {name!r} (hidden)", name=name)


def child(env_id: str) -> dict:
    """In a fresh process: the time from before ``gym.make`` to after the first step, and
    whether the kernel was compiled here or loaded from the cache."""
    import warnings

    if os.environ.get(HIDE_SCIPY) == "1":
        sys.meta_path.insert(0, _NoSciPy())

    import gymnasium as gym
    import numpy as np

    import rallysim  # noqa: F401  (registers the ids)

    began = time.perf_counter()
    from numba.core import event  # (Numba's import counts: the first step would import it)

    with event.install_recorder("numba:compile") as compiles:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")  # (v0's "out of date" notice)
            env = gym.make(env_id)
        env.reset(seed=0)
        env.step(np.zeros(env.action_space.shape, env.action_space.dtype))
    first_step = time.perf_counter() - began
    # (events come in start and end pairs: count the starts)
    compiled = sum(1 for e in compiles.buffer if e[1].is_start)
    return {"first_step_s": first_step, "functions_compiled": compiled,
            "scipy_loaded": "scipy" in sys.modules}


def run_child(env_id: str, cache_dir: str, hide_scipy: bool = False) -> dict:
    """``child`` in a fresh process, with the whole process's wall time added."""
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir,
               **{HIDE_SCIPY: "1" if hide_scipy else "0"})
    began = time.perf_counter()
    proc = subprocess.run([sys.executable, __file__, "--child", env_id], env=env,
                          capture_output=True, text=True, check=True)
    result = json.loads(proc.stdout.strip().splitlines()[-1])
    result["process_s"] = time.perf_counter() - began
    return result


def measure(env_id: str, repeats: int) -> dict:
    with tempfile.TemporaryDirectory(prefix="numba-cache-") as cache_dir:
        cold = run_child(env_id, cache_dir)
        warm, core = [], []
        for _ in range(repeats):  # (in turn, so that a busier minute slows both)
            warm.append(run_child(env_id, cache_dir))
            if SCIPY:
                core.append(run_child(env_id, cache_dir, hide_scipy=True))
    return {"cold": cold, "warm": warm, "warm_median_s": _median(warm),
            "warm_max_s": max(w["first_step_s"] for w in warm),
            "warm_without_scipy": core, "warm_without_scipy_median_s": _median(core),
            "warm_loaded_from_cache": all(w["functions_compiled"] == 0 for w in warm + core)}


def _median(runs: list[dict]) -> float | None:
    return statistics.median(r["first_step_s"] for r in runs) if runs else None


def machine() -> dict:
    from importlib.metadata import version

    cpu = platform.processor()
    try:
        with open("/proc/cpuinfo") as f:
            cpu = next(line.split(":", 1)[1].strip() for line in f if "model name" in line)
    except (OSError, StopIteration):
        pass
    return {"cpu": cpu, "cpu_count": os.cpu_count(), "python": platform.python_version(),
            "numba": version("numba"), "load_average": os.getloadavg()}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--repeats", type=int, default=5, help="warm processes per env id")
    parser.add_argument("--json", metavar="PATH", help="write every number to this JSON file")
    parser.add_argument("--child", metavar="ENV_ID", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        print(json.dumps(child(args.child)))
        return
    info = machine()
    results = {env_id: measure(env_id, args.repeats) for env_id in IDS}
    print(f"{info['cpu_count']} CPUs ({info['cpu']}), Python {info['python']}, "
          f"Numba {info['numba']}, load average {info['load_average'][0]:.2f}\n")
    print("| env id | cold cache | warm cache (median, max) | warm, no SciPy (median) |\n"
          "|---|---:|---:|---:|")
    for env_id, r in results.items():
        core = r["warm_without_scipy_median_s"]
        print(f"| {env_id} | {r['cold']['first_step_s']:.2f} s | {r['warm_median_s']:.2f} s, "
              f"{r['warm_max_s']:.2f} s | {'-' if core is None else f'{core:.2f} s'} |")
    for env_id, r in results.items():
        print(f"{env_id}: every warm start loaded its kernel from the cache: "
              f"{r['warm_loaded_from_cache']}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"machine": info, "results": results}, f, indent=2)


if __name__ == "__main__":
    main()
