"""How long a batch takes to restart some of its games: ``SimpleReturnTask.reset`` of 8 of 256
SIMPLE games (about what one step's autoresets restart at N = 256), best of 7 x 2,000 calls.

Run: ``python benchmarks/reset_speed.py``; docs/benchmarks.md quotes it, run against the code
before and after a change alternately.
"""

from __future__ import annotations

import time

import numpy as np

from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv


def main() -> None:
    env = SimpleReturnVectorEnv(256, seed=0)
    env.reset(seed=0)
    task, games = env.task, np.arange(0, 256, 32)
    for _ in range(200):  # warm: the compiled kernels load from Numba's cache
        task.reset(games)
    best = np.inf
    for _ in range(7):
        start = time.perf_counter()
        for _ in range(2000):
            task.reset(games)
        best = min(best, (time.perf_counter() - start) / 2000)
    print(f"reset of 8 of 256 games: {best * 1e6:.1f} us")


if __name__ == "__main__":
    main()
