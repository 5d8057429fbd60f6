"""Shuttle flight models against docs/reference.md §4, with numbers."""

import numpy as np
import pytest

from rallysim.core.shuttle import (
    GRAVITY,
    SHUTTLE_MODELS,
    AeroShuttle,
    PaperShuttle,
    ShuttleState,
    make_shuttle_model,
)
from tests.conftest import run_until_landed


def independent_paper_landing(p, v, dt=0.02):
    """docs/reference.md §4.1 written out by hand: v <- (v + g dt) * 0.97; p <- p + v dt;
    land at z = 0."""
    p, v = np.array(p, float), np.array(v, float)
    while True:
        v = (v + np.array([0.0, 0.0, -9.81]) * dt) * 0.97
        q = p + v * dt
        if q[2] < 0:
            t = p[2] / (p[2] - q[2])
            return p + t * (q - p)
        p = q


def test_paper_flight_matches_independent_integration(quiet_game):
    g = quiet_game("paper", seed=3)
    p0, v0 = g.shuttle.pos[0].copy(), g.shuttle.vel[0].copy()
    ev = run_until_landed(g)
    expected = independent_paper_landing(p0, v0)
    assert np.abs(ev.land_point[0, :2] - expected[:2]).max() < 1e-6
    assert ev.land_point[0, 0] < 0  # a serve lands on the receiver's side


def terminal_speed(model, steps=2000):
    s = ShuttleState.zeros(1)
    s.pos[0] = [0, 0, 1e4]
    for _ in range(steps):
        model.advance(s, 0.02)
    return float(np.linalg.norm(s.vel[0]))


def test_paper_terminal_speed():
    v = terminal_speed(PaperShuttle())
    # fixed point of v = 0.97 (v + g dt): 0.97 * 9.81 * 0.02 / 0.03 = 6.3434 m/s ("about 6.5")
    assert v == pytest.approx(0.97 * 9.81 * 0.02 / 0.03, abs=1e-9)
    assert abs(v - 6.5) < 0.2


def test_aero_terminal_speed_and_fall_curve():
    model = AeroShuttle()
    assert terminal_speed(model) == pytest.approx(6.7, abs=1e-3)
    s = ShuttleState.zeros(1)
    s.pos[0] = [0, 0, 100.0]
    for k in range(1, 101):
        model.advance(s, 0.02)
        exact = 6.7 * np.tanh(GRAVITY * 0.02 * k / 6.7)
        assert abs(-s.vel[0, 2] - exact) < 0.01


def test_aero_smash_hits_the_aerodynamic_wall():
    """A 100 m/s smash loses a factor e of speed over L = v_t^2 / g = 4.58 m (no gravity here
    would make it exact; with gravity it stays within a few per cent)."""
    model = AeroShuttle()
    s = ShuttleState.zeros(1)
    s.pos[0] = [0, 0, 50.0]
    s.vel[0] = [100.0, 0, 0]
    length = 6.7**2 / GRAVITY
    model.advance(s, 0.02)
    while s.pos[0, 0] < 1.5 * length:  # beyond that, gravity's share of the speed shows
        speed = np.linalg.norm(s.vel[0])
        assert speed == pytest.approx(100 * np.exp(-s.pos[0, 0] / length), rel=0.05)
        model.advance(s, 0.02)
    while s.pos[0, 0] < 3 * length:
        model.advance(s, 0.02)
    assert np.linalg.norm(s.vel[0]) < 10.0  # near terminal speed within a few metres


def test_paper_alg1_speed_profile_and_reset_at_shot():
    model = make_shuttle_model("paper-alg1")
    s = ShuttleState.zeros(1)
    s.pos[0] = [0, 0, 5]
    s.vel[0] = [10.0, 0, 10.0]
    s0 = s.shot_speed[0] = np.linalg.norm(s.vel[0])  # a serve or hit: its speed, time 0
    for k in range(1, 30):
        model.advance(s, 0.02)
        t = 0.02 * k
        if t < 0.6 - 1e-9:
            assert np.linalg.norm(s.vel[0]) == pytest.approx(s0 * (1 - t), rel=1e-9)
    assert s.shot_time[0] > 0.55
    s.vel[0] = [0, 0, 20.0]
    s.shot_speed[0], s.shot_time[0] = 20.0, 0.0  # a hit restarts the timer
    model.advance(s, 0.02)
    assert np.linalg.norm(s.vel[0]) == pytest.approx(20.0 * 0.98, rel=1e-9)


def test_unknown_model_lists_valid_names():
    with pytest.raises(ValueError) as err:
        make_shuttle_model("feather")
    for name in SHUTTLE_MODELS:
        assert repr(name) in str(err.value)
