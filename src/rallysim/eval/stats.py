"""Honest summaries of rally lengths: point estimates with 95 % bootstrap confidence intervals.

Rally lengths come in groups, one per training seed (or evaluation seed). The bootstrap is
hierarchical: each replicate draws seeds with replacement, then rallies with replacement within
each drawn seed, so the interval carries both the seed-to-seed and the rally-to-rally spread.
The 50-hit cap censors long rallies, so the mean understates what an uncapped policy would do;
the survival curve P(length >= k) and the capped fraction show it instead.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from dataclasses import asdict, dataclass

import numpy as np

Statistic = Callable[[np.ndarray], np.ndarray]  # (B, M) replicates -> (B,)


def mean(x: np.ndarray) -> np.ndarray:
    return x.mean(axis=-1)


def median(x: np.ndarray) -> np.ndarray:
    return np.median(x, axis=-1)


def iqm(x: np.ndarray) -> np.ndarray:
    """Interquartile mean: the mean of the middle 50 % of values (robust, yet efficient)."""
    m = x.shape[-1]
    lo, hi = int(np.floor(0.25 * m)), int(np.ceil(0.75 * m))
    return np.sort(x, axis=-1)[..., lo:hi].mean(axis=-1)


STATISTICS: dict[str, Statistic] = {"mean": mean, "median": median, "iqm": iqm}


@dataclass(frozen=True)
class Estimate:
    value: float
    low: float
    high: float

    def fmt(self, digits: int = 2) -> str:
        return f"{self.value:.{digits}f} [{self.low:.{digits}f}, {self.high:.{digits}f}]"


def bootstrap_replicates(groups: Sequence[np.ndarray], n_boot: int,
                         rng: np.random.Generator) -> np.ndarray:
    """(n_boot, total) resampled data: seeds drawn with replacement, then values within each.

    Groups may differ in size; each replicate keeps the drawn groups' own sizes by resampling a
    group into the slot of the group it replaces (slots keep their sizes), so replicates stack."""
    groups = [np.asarray(g, dtype=np.float64) for g in groups]
    if not groups or any(len(g) == 0 for g in groups):
        raise ValueError("need at least one non-empty group of values")
    k = len(groups)
    picks = rng.integers(0, k, (n_boot, k))
    parts = []
    for slot, g_slot in enumerate(groups):
        size = len(g_slot)
        # (k, n_boot, size): every group resampled into this slot's size
        stacked = np.stack([g[rng.integers(0, len(g), (n_boot, size))] for g in groups])
        parts.append(stacked[picks[:, slot], np.arange(n_boot)])
    return np.concatenate(parts, axis=1)


def estimate(groups: Sequence[np.ndarray], statistic: Statistic, n_boot: int = 2000,
             seed: int = 0, level: float = 0.95) -> Estimate:
    """``statistic`` of the pooled values with a percentile bootstrap interval."""
    data = np.concatenate([np.asarray(g, np.float64) for g in groups])
    reps = statistic(bootstrap_replicates(groups, n_boot, np.random.default_rng(seed)))
    a = (1.0 - level) / 2.0
    return Estimate(float(statistic(data[None])[0]), float(np.quantile(reps, a)),
                    float(np.quantile(reps, 1.0 - a)))


def over_seeds(values: Sequence[float | None]) -> dict[str, float] | None:
    """The mean of one value per seed with its 95 % bootstrap interval (seeds resampled), as
    JSON-ready ``value``, ``low``, ``high``; None if any seed's value is undefined."""
    if not values or any(v is None for v in values):
        return None
    return asdict(estimate([np.array([v], np.float64) for v in values], mean))


def interval_cell(e: dict[str, float] | None, digits: int = 2) -> str:
    """``value [low, high]`` as a table cell (``—`` where undefined)."""
    if e is None:
        return "—"
    return f"{e['value']:.{digits}f} [{e['low']:.{digits}f}, {e['high']:.{digits}f}]"


def _share(count: np.ndarray, of: np.ndarray) -> np.ndarray:
    """count / of, NaN where there is nothing to count (bootstrap intervals skip those)."""
    with np.errstate(invalid="ignore", divide="ignore"):
        return np.where(of > 0, count / np.maximum(of, 1), np.nan)


def serve_return(x: np.ndarray) -> np.ndarray:
    """Share of rallies whose serve was returned (at least one hit)."""
    return (x >= 1).mean(axis=-1)


def capped_fraction(cap: int) -> Statistic:
    """Share of rallies that reached the cap."""
    return lambda x: (x >= cap).mean(axis=-1)


def early_loss(cap: int) -> Statistic:
    """Share of rallies lost before the second hit (the serve or its first return missed); a
    rally that reached the cap was not lost."""
    return lambda x: ((x < 2) & (x < cap)).mean(axis=-1)


def first_return_miss(cap: int) -> Statistic:
    """Of the rallies whose serve was returned, the share whose first return was not returned
    (the rally ended at exactly one hit below the cap); NaN at cap 1 or with no return."""
    return lambda x: _share(((x == 1) & (cap > 1)).sum(axis=-1),
                            ((x >= 1) & (cap > 1)).sum(axis=-1))


def later_miss_rate(cap: int) -> Statistic:
    """The per-hit miss rate from the third hit on: rallies ending at k in [2, cap) hits, over
    every attempt at a hit k + 1 >= 3 made (a rally ending at k made k - 1 such attempts, one
    of them missed; a capped rally made cap - 2, none missed). NaN with no attempt."""

    def rate(x: np.ndarray) -> np.ndarray:
        missed = ((x >= 2) & (x < cap)).sum(axis=-1)
        attempts = np.where(x >= 2, np.where(x >= cap, cap - 2, x - 1), 0).sum(axis=-1)
        return _share(missed, attempts)

    return rate


def survival_curve(x: np.ndarray, ks: np.ndarray) -> np.ndarray:
    """P(length >= k) for each k of ``ks``, per row of ``x`` (B, M) -> (B, len(ks)); by sorting,
    so that long caps (1000 hits) cost no (B, k, M) array."""
    ordered = np.sort(x, axis=-1)
    below = np.stack([np.searchsorted(row, ks, side="left") for row in ordered])
    return 1.0 - below / x.shape[-1]


@dataclass(frozen=True)
class RallySummary:
    """Everything reported for one method's rally lengths."""

    n_rallies: int
    n_seeds: int
    cap: int
    mean: Estimate
    median: Estimate
    iqm: Estimate
    capped: int
    capped_fraction: Estimate
    serve_return: Estimate
    first_return_miss: Estimate
    early_loss: Estimate
    later_miss_rate: Estimate
    survival_k: list[int]
    survival: list[float]
    survival_low: list[float]
    survival_high: list[float]

    def to_dict(self) -> dict:
        return asdict(self)


def summarise_rallies(groups: Sequence[np.ndarray], cap: int = 50, n_boot: int = 2000,
                      seed: int = 0) -> RallySummary:
    """Mean, median, IQM (with 95 % CIs), capped count and fraction, where rallies are lost
    (serve returned, first return missed, lost before the second hit, the per-hit miss rate
    after that; each with its 95 % CI), and the survival curve P(length >= k) for k = 0..cap
    with pointwise 95 % bands, of rally lengths per seed."""
    groups = [np.asarray(g, np.float64) for g in groups]
    data = np.concatenate(groups)
    if np.any(data < 0) or np.any(data > cap):
        raise ValueError(f"rally lengths must lie in [0, {cap}]")
    reps = bootstrap_replicates(groups, n_boot, np.random.default_rng(seed))
    ks = np.arange(cap + 1)
    surv = survival_curve(data[None], ks)[0]
    surv_reps = survival_curve(reps, ks)  # (B, cap + 1)

    def est(stat: Statistic) -> Estimate:
        r = stat(reps)
        if np.isnan(r).all():
            return Estimate(float(stat(data[None])[0]), float("nan"), float("nan"))
        return Estimate(float(stat(data[None])[0]), float(np.nanquantile(r, 0.025)),
                        float(np.nanquantile(r, 0.975)))

    return RallySummary(
        n_rallies=len(data), n_seeds=len(groups), cap=cap,
        mean=est(mean), median=est(median), iqm=est(iqm),
        capped=int((data >= cap).sum()), capped_fraction=est(capped_fraction(cap)),
        serve_return=est(serve_return), first_return_miss=est(first_return_miss(cap)),
        early_loss=est(early_loss(cap)), later_miss_rate=est(later_miss_rate(cap)),
        survival_k=ks.tolist(), survival=surv.tolist(),
        survival_low=np.quantile(surv_reps, 0.025, axis=0).tolist(),
        survival_high=np.quantile(surv_reps, 0.975, axis=0).tolist(),
    )
