"""What the tests of the compiled kernels (``tests/test_simple_kernel.py``,
``tests/test_one_humanlike.py``) share."""

from __future__ import annotations

import os
from typing import Any

import numpy as np
import pytest

from rallysim.core import native
from rallysim.core.kernels import simple


def needs_compiled(kernel: native.Kernel) -> pytest.MarkDecorator:
    """Skip, visibly, where ``kernel`` cannot be had; CI requires it
    (``RALLYSIM_REQUIRE_COMPILED=1`` in .ci/run: then a missing one fails instead)."""
    return pytest.mark.skipif(
        kernel.get() is None and os.environ.get("RALLYSIM_REQUIRE_COMPILED") != "1",
        reason=f"no compiled kernel: {kernel.why_not}")


NEEDS_COMPILED_SIMPLE = needs_compiled(simple.Compiled)


def same_bits(x: Any, y: Any) -> bool:
    x, y = np.asarray(x), np.asarray(y)
    return x.dtype == y.dtype and x.shape == y.shape and x.tobytes() == y.tobytes()


def counting(game: Any) -> dict[str, int]:
    """Count the physics steps the fused path runs (free: "fused"; out of play: "held") and
    those the lanes code runs ("lanes"; held steps handed to it count in both)."""
    counts = {"fused": 0, "held": 0, "lanes": 0}
    free, held, lanes = game._one._free_steps, game._one._held_steps, game._step_lanes

    def fused_steps(g, steps):
        run = free(g, steps)
        counts["fused"] += run
        return run

    def held_steps(g, steps):
        counts["held"] += steps
        held(g, steps)

    def lanes_step(g, ops):
        counts["lanes"] += 1
        lanes(g, ops)

    game._one._free_steps, game._one._held_steps = fused_steps, held_steps
    game._step_lanes = lanes_step
    return counts


def play(env: Any, a: np.ndarray) -> tuple[np.ndarray, tuple]:
    """One step (and the reset after an end): the observation, reward and ends."""
    obs, reward, terminated, truncated, _ = env.step(a)
    if terminated or truncated:
        obs = env.reset()[0]
    return obs, (reward, terminated, truncated)
