"""Numba's cache keeps the compiled kernels of one game across processes
(``rallysim.core.native.jit``): a process that finds them cached loads them, compiles nothing
(the probes included) and steps to the bits of the process that compiled them."""

from __future__ import annotations

import json
import os
import subprocess
import sys

import numba

from rallysim.core import native
from tests.kernels import NEEDS_COMPILED_HUMANLIKE, NEEDS_COMPILED_SIMPLE

# A fresh process: both single envs played with seeded random actions, compiler passes counted
CHILD = r"""
import hashlib, json, warnings
import numpy as np
from numba.core import event
import gymnasium as gym
import rallysim
from rallysim.core import one_game, one_humanlike

out = {}
with event.install_recorder("numba:run_pass") as passes:
    for env_id, kernel in (("RallySim/SimpleReturn-v0", one_game.Compiled),
                           ("RallySim/HumanLikeReturn-v0", one_humanlike.Compiled)):
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
        out[env_id] = {"digest": digest.hexdigest(), **kernel.cache_stats()}
out["passes"] = len(passes.buffer)
print(json.dumps(out))
"""


def _fresh_process(cache_dir: str) -> dict:
    env = dict(os.environ, NUMBA_CACHE_DIR=cache_dir, RALLYSIM_KERNEL="compiled")
    proc = subprocess.run([sys.executable, "-c", CHILD], env=env, capture_output=True,
                          text=True, timeout=900)
    assert proc.returncode == 0, proc.stderr[-3000:]
    return json.loads(proc.stdout.strip().splitlines()[-1])


@NEEDS_COMPILED_SIMPLE
@NEEDS_COMPILED_HUMANLIKE
def test_a_second_process_loads_the_kernels_and_replays_the_first(tmp_path):
    first = _fresh_process(str(tmp_path))
    second = _fresh_process(str(tmp_path))
    assert first["passes"] > 0  # (the cache was empty: it compiled)
    assert second["passes"] == 0  # nothing compiled, not even a probe
    for env_id in ("RallySim/SimpleReturn-v0", "RallySim/HumanLikeReturn-v0"):
        assert first[env_id]["misses"] > 0 and first[env_id]["hits"] == 0
        assert second[env_id]["misses"] == 0
        assert second[env_id]["hits"] == first[env_id]["misses"]
        assert second[env_id]["digest"] == first[env_id]["digest"]


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
