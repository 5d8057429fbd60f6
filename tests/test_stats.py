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


def test_where_rallies_are_lost():
    """Serve returned, first return missed, early loss and the later per-hit miss rate, by hand:
    lengths 0, 1, 1, 2, 5, 50, 50 at cap 50."""
    from rallysim.eval.stats import survival_curve

    s = summarise_rallies([np.array([0, 1, 1, 2, 5]), np.array([50, 50])], cap=50, n_boot=300)
    assert s.serve_return.value == pytest.approx(6 / 7)
    assert s.first_return_miss.value == pytest.approx(2 / 6)
    assert s.early_loss.value == pytest.approx(3 / 7)
    # attempts at hits 3+: length 2 -> 1 (missed), 5 -> 4 (1 missed), 50 -> 48 each (none)
    assert s.later_miss_rate.value == pytest.approx(2 / (1 + 4 + 48 + 48))
    for e in (s.serve_return, s.first_return_miss, s.early_loss, s.later_miss_rate):
        assert e.low <= e.value <= e.high
    x = np.array([[0.0, 3, 3, 7]])
    assert survival_curve(x, np.array([0, 1, 3, 4, 7, 8]))[0].tolist() == [1, 0.75, 0.75, 0.25,
                                                                          0.25, 0]
    long = summarise_rallies([np.array([1000, 999, 2])], cap=1000, n_boot=50)
    assert len(long.survival) == 1001 and long.survival[1000] == pytest.approx(1 / 3)


def test_loss_statistics_with_nothing_to_count_or_cap_one():
    none_returned = summarise_rallies([np.array([0, 0, 0])], cap=50, n_boot=50)
    assert np.isnan(none_returned.first_return_miss.value)
    assert np.isnan(none_returned.later_miss_rate.value)
    assert none_returned.early_loss.value == 1.0
    capped_at_one = summarise_rallies([np.array([1, 1, 1, 0])], cap=1, n_boot=50)
    assert capped_at_one.early_loss.value == pytest.approx(0.25)  # the capped ones were not lost
    assert np.isnan(capped_at_one.first_return_miss.value)


def test_estimate_is_the_summarys_own_interval():
    """``estimate`` draws the replicates ``summarise_rallies`` draws: the same capped share."""
    from rallysim.eval.stats import capped_fraction
    rng = np.random.default_rng(3)
    groups = [rng.integers(0, 51, 200), rng.integers(0, 51, 150)]
    summary = summarise_rallies(groups, cap=50)
    assert estimate(groups, capped_fraction(50)) == summary.capped_fraction


def test_the_capped_check_fails_only_a_seed_shown_below_the_goal():
    """A seed whose 200 rallies reach the cap 180 or 172 times is not shown below 90 % (its
    interval reaches 0.9); one at 160 (80 %) is, as is machine seed 2 at cap 1000 (59 of 200)."""
    from rallysim.train.reproduce import capped_check

    def seed(capped: int, cap: int = 50) -> dict:
        return {"lengths": {"HRL": [cap] * capped + [1] * (200 - capped)}}

    assert capped_check({"0": seed(180), "1": seed(172)}, 50)
    assert not capped_check({"0": seed(180), "1": seed(160)}, 50)
    assert not capped_check({"0": seed(59, 1000)}, 1000)
