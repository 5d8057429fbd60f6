"""Settings that make PyTorch's share of training cheaper without changing a single bit of it.

On two CPU cores PPO's updates, not the simulator, bound training (docs/benchmarks.md), and
a small network's update spends much of its time in per-tensor Python overhead:

- ``ADAM_KWARGS``: Adam updates every parameter tensor in one ``foreach`` call instead of a
  Python loop over tensors. The element-wise arithmetic is the same, so the weights are
  bit-identical (the fused kernel, ``fused=True``, is faster still but rounds differently, so
  it is not used). ``eps`` is SB3's own choice for PPO's Adam, restated because passing any
  ``optimizer_kwargs`` replaces SB3's default dict.
- ``no_distribution_checks``: ``torch.distributions`` checks every sample and parameter it is
  given against its support unless told not to; SB3 builds a Normal per batch, so the checks
  run thousands of times per rollout. They never change a value, only raise on bad input,
  and PPO's inputs come from the network itself.
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager
from typing import Any

ADAM_KWARGS: dict[str, Any] = {"foreach": True}
SB3_ADAM_KWARGS: dict[str, Any] = {"eps": 1e-5, **ADAM_KWARGS}


@contextmanager
def no_distribution_checks() -> Iterator[None]:
    """Turn ``torch.distributions``' argument checks off inside the block (they are a
    process-wide default, so the previous setting is restored on leaving)."""
    from torch.distributions import Distribution

    before = Distribution._validate_args
    Distribution.set_default_validate_args(False)
    try:
        yield
    finally:
        Distribution.set_default_validate_args(before)
