"""Serve, court geometry and swept overlap tests (docs/reference.md §3, §4.3)."""

import numpy as np
import pytest

from rallysim.core import rules
from rallysim.core.court import Court


def test_court_dimensions_from_mjcf():
    c = Court.from_mjcf()
    assert (c.half_length, c.half_width) == pytest.approx((6.7, 3.05))
    assert c.net_top == pytest.approx(1.51)
    assert c.net_half_thickness == pytest.approx(0.025)
    assert (c.paper_zone_near, c.paper_zone_far) == pytest.approx((0.386, 6.658))


def test_serve_ranges_toward_each_receiver():
    rng = np.random.default_rng(0)
    for receiver in (0, 1):
        u = rng.random((20000, rules.SERVE_DRAWS))
        pos, vel = rules.sample_serve(u, np.full(20000, receiver))
        f = rules.FORWARD[receiver]
        x0 = f * pos[:, 0]  # in the receiver's own frame
        assert x0.min() >= 1.0 and x0.max() <= 6.0
        assert x0.min() < 1.01 and x0.max() > 5.99
        assert pos[:, 2].min() >= 1.0 and pos[:, 2].max() <= 1.5
        assert np.all(pos[:, 1] == 0) and np.all(vel[:, 1] == 0)
        speed = np.linalg.norm(vel, axis=1)
        assert speed.min() >= 10.0 - 1e-9 and speed.max() <= 27.5 + 1e-9
        assert np.all(f * vel[:, 0] < 0)  # toward the receiver
        phi = np.degrees(np.arctan2(vel[:, 2], np.abs(vel[:, 0])))
        t = (x0 - 1) / 5
        assert np.all(phi >= 45 + t * (15 - 45) - 1e-6) and np.all(phi <= 60 + 1e-6)
        s = speed / 5
        assert np.all(s >= 2 + 2 * t - 1e-9) and np.all(s <= 3 + 2.5 * t + 1e-9)
    near = x0 < 1.1  # near serves are steep and slow
    assert phi[near].min() > 42 and speed[near].max() < 15.5


def test_one_games_serve_on_floats_matches_the_array_code_bit_for_bit():
    rng = np.random.default_rng(0)
    for _ in range(2000):
        u, receiver = rng.random((1, rules.SERVE_DRAWS)), np.array([rng.integers(2)])
        one = rules.sample_serve(u, receiver)
        batch = rules.sample_serve(np.repeat(u, 2, axis=0), np.repeat(receiver, 2))
        for a, b in zip(one, batch, strict=True):
            assert a.tobytes() == b[:1].tobytes()
