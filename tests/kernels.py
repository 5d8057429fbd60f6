"""What the tests of the compiled kernels (``tests/test_simple_kernel.py``,
``tests/test_humanlike_kernel.py``) share."""

from __future__ import annotations

from typing import Any

import numpy as np


def same_bits(x: Any, y: Any) -> bool:
    x, y = np.asarray(x), np.asarray(y)
    return x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()


def play(env: Any, a: np.ndarray) -> tuple[np.ndarray, tuple]:
    """One step (and the reset after an end): the observation, reward and ends."""
    obs, reward, terminated, truncated, _ = env.step(a)
    if terminated or truncated:
        obs = env.reset()[0]
    return obs, (reward, terminated, truncated)
