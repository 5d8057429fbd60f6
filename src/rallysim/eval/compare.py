"""Compare the paper's three methods on the rally with given (or shipped) policies."""

from __future__ import annotations

from typing import Any

import numpy as np

from rallysim.eval.rally_eval import (
    PAPER_CAP,
    rally_lengths_direct,
    rally_lengths_turns,
    random_goals,
    rules_for_cap,
)
from rallysim.eval.stats import summarise_rallies
from rallysim.policies.resolve import high_level_policy, mono_policy, rally_low_level


def evaluate_methods(low: str = "pretrained", high: str = "pretrained", mono: str = "pretrained",
                     rallies: int = 100, seeds: int = 3, shuttle: str = "paper",
                     cap: int = PAPER_CAP) -> dict[str, Any]:
    """HRL (``high`` goals for ``low``), Random High-level (goals ~ U[2, 6] m for ``low``) and
    Monolithic (``mono``): ``rallies`` rallies for each of ``seeds`` evaluation seeds, each
    ending at a landing or at ``cap`` hits."""
    if rallies < 1 or seeds < 1:
        raise ValueError("rallies and seeds must be >= 1")
    rules = rules_for_cap(cap, shuttle)
    low_level = rally_low_level(low)
    lengths: dict[str, list[np.ndarray]] = {"HRL": [], "Random High-level": [],
                                            "Monolithic": []}
    mono_act = mono_policy(mono)
    for s in range(seeds):
        seed = 2_000_000 + 1000 * s
        lengths["HRL"].append(rally_lengths_turns(high_level_policy(high, seed), low_level,
                                                  rallies, seed, rules))
        lengths["Random High-level"].append(
            rally_lengths_turns(random_goals(seed), low_level, rallies, seed, rules))
        lengths["Monolithic"].append(rally_lengths_direct(mono_act, rallies, seed, rules))
    return {
        "policies": {"low": low, "high": high, "mono": mono}, "shuttle": shuttle, "cap": cap,
        "rallies_per_seed": rallies, "seeds": seeds,
        "methods": {m: summarise_rallies(g, cap=cap).to_dict() for m, g in lengths.items()},
        "lengths": {m: [g.tolist() for g in gs] for m, gs in lengths.items()},
    }
