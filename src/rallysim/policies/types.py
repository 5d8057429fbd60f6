"""The shapes of policies, named once for every module that takes or returns one."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

Policy = Callable[[np.ndarray], np.ndarray]
"""(M, observation) -> (M, action): a low-level task's policy or a Monolithic player."""

LowLevel = Callable[[np.ndarray, np.ndarray], np.ndarray]
"""(rally observations (M, obs), goals (M, *goal)) -> actions (M, action): a rally's low level."""

HighLevel = Callable[[np.ndarray], np.ndarray]
"""(M, observation) -> (M, *goal) goals: a rally's high level."""
