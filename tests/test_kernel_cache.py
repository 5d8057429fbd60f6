"""Numba's cache keeps the compiled kernels across processes
(``rallysim.core.native.jit``): a process that finds them cached loads them, compiles nothing
(the probes included) and steps to the bits of the process that compiled them."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numba

from rallysim.core import native

# A fresh process: both single envs played with seeded random actions, compiler passes counted
CHILD = r"""
import hashlib, json, warnings
import numpy as np
from numba.core import event
import gymnasium as gym
import rallysim

out = {}
with event.install_recorder("numba:run_pass") as passes:
    for env_id in ("RallySim/SimpleReturn-v0", "RallySim/HumanLikeReturn-v0"):
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            env = gym.make(env_id)
        digest = hashlib.sha256()
        obs, _ = env.reset(seed=5)
        rng = np.random.default_rng(5)
        for _ in range(300):
            a = rng.uniform(-1, 1, env.action_space.shape).astype(env.action_space.dtype)
            obs, reward, terminated, truncated, _ = env.step(a)
            digest.update(obs.tobytes() + np.float64(reward).tobytes()
                          + bytes([terminated, truncated]))
            if terminated or truncated:
                obs, _ = env.reset()
        out[env_id] = digest.hexdigest()
out["passes"] = len(passes.buffer)
print(json.dumps(out))
"""


def _fresh_process(cache_dir: str) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir)
    proc = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True,
                          text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


def test_a_second_process_loads_the_kernels_and_replays_the_first(tmp_path):
    first = _fresh_process(str(tmp_path))
    second = _fresh_process(str(tmp_path))
    assert first["passes"] > 0  # (the cache was empty: it compiled)
    assert second["passes"] == 0  # nothing compiled, not even a probe
    for env_id in ("RallySim/SimpleReturn-v0", "RallySim/HumanLikeReturn-v0"):
        assert second[env_id] == first[env_id]


def _calling(callee):
    def caller(x):
        return callee(x) + 1.0

    return caller


def _double(x):
    return 2.0 * x


def _triple(x):
    return 3.0 * x


def test_the_cache_key_is_what_a_kernel_calls_not_who_made_it():
    # the same functions, wrapped anew: one key (a pickle of the closure would differ)
    one = native.fingerprint(_calling(numba.njit(_double)))
    assert native.fingerprint(_calling(numba.njit(_double))) == one
    # a callee changed (in another file, say): another key, so the cached code is not reused
    assert native.fingerprint(_calling(numba.njit(_triple))) != one
    assert native.fingerprint(_calling(numba.njit(error_model="numpy")(_double))) != one
