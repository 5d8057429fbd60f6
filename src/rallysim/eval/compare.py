"""Compare the paper's three methods on the rally with given (or shipped) policies."""

from __future__ import annotations

from typing import TYPE_CHECKING, Any

import numpy as np

from rallysim.core.tasks.rally import RallyConfig
from rallysim.eval.rally_eval import (
    PAPER_CAP,
    rally_lengths_direct,
    rally_lengths_turns,
    random_goals,
    rules_for_cap,
)
from rallysim.eval.stats import summarise_rallies
from rallysim.policies.registry import resolve
from rallysim.policies.types import HighLevel, LowLevel, Policy

if TYPE_CHECKING:
    from rallysim.train.progress import Heartbeat


METHODS = ("HRL", "Random High-level", "Monolithic")


def play_methods(high: HighLevel, low: LowLevel, mono: Policy, rallies: int, seed: int,
                 rules: RallyConfig, beat: Heartbeat | None = None,
                 label: str = "", player: str = "simple") -> dict[str, np.ndarray]:
    """Rally lengths of HRL (``high`` goals for ``low``), Random High-level (uniform random
    goals for ``low``: SIMPLE depths ~ U[2, 6] m) and Monolithic (``mono`` for both players):
    ``rallies`` rallies each of ``player``, played from evaluation seed ``seed``. ``beat``
    counts one per method played."""
    plays = {
        "HRL": lambda: rally_lengths_turns(high, low, rallies, seed, rules, player=player),
        "Random High-level": lambda: rally_lengths_turns(random_goals(seed, player), low,
                                                         rallies, seed, rules, player=player),
        "Monolithic": lambda: rally_lengths_direct(mono, rallies, seed, rules, player=player),
    }
    lengths = {}
    for method, play in plays.items():
        if beat is not None:
            beat.set_phase(f"{label}{method}", restart_rate=False)
        lengths[method] = play()
        if beat is not None:
            beat.update(beat.done + 1)
    return lengths


def evaluate_methods(low: str = "pretrained", high: str = "pretrained", mono: str = "pretrained",
                     rallies: int = 100, seeds: int = 3, shuttle: str = "paper",
                     cap: int = PAPER_CAP, beat: Heartbeat | None = None) -> dict[str, Any]:
    """HRL (``high`` goals for ``low``), Random High-level (goals ~ U[2, 6] m for ``low``) and
    Monolithic (``mono``): ``rallies`` rallies for each of ``seeds`` evaluation seeds, each
    ending at a landing or at ``cap`` hits."""
    if rallies < 1 or seeds < 1:
        raise ValueError("rallies and seeds must be >= 1")
    rules = rules_for_cap(cap, shuttle)
    low_level = resolve(low, "rally_low")
    lengths: dict[str, list[np.ndarray]] = {m: [] for m in METHODS}
    mono_act = resolve(mono, "mono")
    for s in range(seeds):
        seed = 2_000_000 + 1000 * s
        high_level = resolve(high, "high", "simple", seed)
        played = play_methods(high_level, low_level, mono_act, rallies, seed, rules, beat,
                              f"seed {s} ")
        for method, values in played.items():
            lengths[method].append(values)
    return {
        "policies": {"low": low, "high": high, "mono": mono}, "shuttle": shuttle, "cap": cap,
        "rallies_per_seed": rallies, "seeds": seeds,
        "methods": {m: summarise_rallies(g, cap=cap).to_dict() for m, g in lengths.items()},
        "lengths": {m: [g.tolist() for g in gs] for m, gs in lengths.items()},
    }
