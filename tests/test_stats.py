"""Rally statistics: estimates, intervals, survival (issue 4's evaluation)."""

import numpy as np
import pytest

from rallysim.eval.stats import bootstrap_replicates, estimate, iqm, mean, summarise_rallies


def test_iqm_is_the_mean_of_the_middle_half():
    x = np.array([[0, 1, 2, 3, 4, 5, 6, 100]], float)
    assert iqm(x)[0] == pytest.approx(np.mean([2, 3, 4, 5]))


def test_bootstrap_interval_covers_the_truth_at_about_95_percent():
    rng = np.random.default_rng(0)
    covered = 0
    for trial in range(200):
        groups = [rng.exponential(10.0, 100) for _ in range(3)]
        e = estimate(groups, mean, n_boot=400, seed=trial)
        covered += e.low <= 10.0 <= e.high
    assert 0.88 <= covered / 200 <= 0.99


def test_hierarchical_bootstrap_widens_with_seed_spread():
    rng = np.random.default_rng(1)
    same = [rng.normal(20, 5, 100) for _ in range(3)]
    spread = [rng.normal(mu, 5, 100) for mu in (10, 20, 30)]
    w_same = estimate(same, mean, seed=0)
    w_spread = estimate(spread, mean, seed=0)
    assert (w_spread.high - w_spread.low) > 4 * (w_same.high - w_same.low)
    reps = bootstrap_replicates([np.arange(3.0), np.arange(5.0)], 10, rng)
    assert reps.shape == (10, 8)


def test_rally_summary_numbers():
    groups = [np.array([50, 50, 10, 0, 25]), np.array([50, 5, 5, 40])]
    s = summarise_rallies(groups, cap=50, n_boot=500)
    assert s.n_rallies == 9 and s.capped == 3
    assert s.mean.value == pytest.approx(235 / 9)
    assert s.median.value == 25
    assert s.survival[0] == 1.0 and s.survival[50] == pytest.approx(3 / 9)
    assert s.survival[6] == pytest.approx(6 / 9)
    assert all(a >= b for a, b in zip(s.survival, s.survival[1:], strict=False))
    assert s.mean.low <= s.mean.value <= s.mean.high
    with pytest.raises(ValueError):
        summarise_rallies([np.array([51])], cap=50)
