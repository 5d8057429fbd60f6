"""The core's rule pipeline: fresh events per decision, the rally state, the derived rule set,
serve strategies and the scoring rules (issue 16)."""

import copy
import functools
import itertools
import pickle
from dataclasses import FrozenInstanceError

import numpy as np
import pytest
from test_hits import swing_setup

from rallysim.core import rules
from rallysim.core.events import EventRows, Events
from rallysim.core.game import Game
from rallysim.core.humanlike import HumanLikeBodies
from rallysim.core.serve import (
    HUMANLIKE_SERVE_DRAWS,
    Draw,
    FedShots,
    HumanLikeServe,
    MachineServe,
)
from rallysim.core.shuttle import make_shuttle_model
from rallysim.core.state import SERVE, RallyState
from rallysim.core.streams import Streams
from rallysim.players import HUMANLIKE
from tests.conftest import humanlike_swing_at_face


def swing_until_hit(g: Game, decisions: int = 10):
    for _ in range(decisions):
        ev = g.step(np.array([[[1.0, 1.0, 0.0]]]))
        if ev.hit[0, 0]:
            return ev
    raise AssertionError("no hit")


def test_each_step_returns_new_events_that_later_steps_leave_alone():
    g = Game(2, 2, seed=0)
    g.reset(np.arange(2), receiver=np.array([0, 1]))
    rng = np.random.default_rng(0)
    kept = []
    for _ in range(60):
        ev = g.step(rng.uniform(-1, 1, (2, 2, 3)))
        kept.append((ev, copy.deepcopy(ev)))
    assert len({id(ev) for ev, _ in kept}) == len(kept)
    assert any(ev.landed.any() for ev, _ in kept)  # something happened to keep
    for ev, snapshot in kept:
        for name in vars(ev):
            np.testing.assert_array_equal(getattr(ev, name), getattr(snapshot, name))


@pytest.mark.parametrize(("n", "p"), [(1, 1), (64, 2)])
def test_new_events_are_blank_and_share_no_memory(n, p):
    rows = EventRows(n, p)
    assert (rows.rows >= rows.min_rows) == (n == 1)  # one game: rows of blocks; else copies
    twin = pickle.loads(pickle.dumps(rows))
    taken = [r.take() for r in (rows, twin) for _ in range(rows.rows + 2)]
    blank = Events.empty(n, p)
    for name in vars(blank):
        arrays = [getattr(ev, name) for ev in taken]
        for a in arrays:
            np.testing.assert_array_equal(a, getattr(blank, name))
        for a, b in itertools.combinations(arrays, 2):
            assert not np.shares_memory(a, b)


def test_hit_velocity_is_the_racket_velocity_at_the_hit_and_nan_otherwise():
    rho = 1.06
    th = -np.radians(20)
    g = swing_setup([-3.0 + rho * np.sin(th), 0, 0.65 + rho * np.cos(th)], [0, 0, 0])
    ev = swing_until_hit(g)
    v = ev.hit_velocity[0, 0]
    assert np.linalg.norm(v) == pytest.approx(ev.hit_speed[0, 0], rel=1e-12)
    assert v[1] == 0.0 and v[0] > 0  # the arm turns about y, swinging toward the net
    quiet = g.step(np.zeros((1, 1, 3)))
    assert not quiet.hit.any() and np.isnan(quiet.hit_velocity).all()


def test_humanlike_hit_velocity_comes_through_the_events():
    b = HumanLikeBodies(1, 1)
    g = Game(1, 1, seed=0, bodies=b, serve=HumanLikeServe())
    ev = g.step(humanlike_swing_at_face(g))
    assert ev.hit[0, 0] and ev.hit_velocity[0, 0, 2] > 1.0
    assert np.linalg.norm(ev.hit_velocity[0, 0]) == pytest.approx(ev.hit_speed[0, 0])
    assert not hasattr(b, "hit_velocity")  # one path for every player model


def test_rally_state_lives_in_the_game_and_copies_exactly():
    g = Game(3, 2, seed=1)
    g.reset(np.arange(3), receiver=np.array([0, 1, 0]))
    assert isinstance(g.state, RallyState) and g.armed is g.state.armed
    assert g.armed.tolist() == [[True, False], [False, True], [True, False]]
    assert g.last_hitter.tolist() == [SERVE] * 3
    for twin in (copy.deepcopy(g), pickle.loads(pickle.dumps(g))):
        for name in vars(g.state):
            np.testing.assert_array_equal(getattr(twin.state, name), getattr(g.state, name))
            assert not np.shares_memory(getattr(twin.state, name), getattr(g.state, name))
    reference = copy.deepcopy(g)
    actions = np.random.default_rng(2).uniform(-1, 1, (30, 3, 2, 3))
    for twin in (copy.deepcopy(g), pickle.loads(pickle.dumps(g))):
        for a in actions:
            ev_twin, ev = twin.step(a), g.step(a)
            for name in vars(ev):
                np.testing.assert_array_equal(getattr(ev_twin, name), getattr(ev, name))
        g = copy.deepcopy(reference)


@pytest.mark.parametrize(("shuttle", "players", "net", "full"), [
    ("paper", 2, rules.NET_REARM, False), ("paper-alg1", 2, rules.NET_REARM, False),
    ("aero", 2, rules.NET_BLOCK, True), ("paper", 1, rules.NET_NOTE, False),
    ("aero", 1, rules.NET_BLOCK, True)])
def test_the_rule_set_is_derived_once_from_shuttle_and_players(shuttle, players, net, full):
    r = rules.Rules.derive(make_shuttle_model(shuttle), players)
    assert (r.net, r.full_court, r.net_blocks) == (net, full, net == rules.NET_BLOCK)
    assert Game(1, players, shuttle=shuttle).rules == r
    with pytest.raises(FrozenInstanceError):
        r.net = rules.NET_NOTE
    with pytest.raises(ValueError, match="net rule"):
        rules.Rules(net="bounce", full_court=False)


def test_point_winner_and_game_over():
    # in on a side: that side's fault; out: the last hitter's, or the server's before a hit
    winner = rules.point_winner(land_side=np.array([0, 1, 1, 0]),
                                land_in=np.array([True, True, False, False]),
                                last_hitter=np.array([1, 0, 1, SERVE]),
                                server=np.array([0, 0, 0, 1]))
    assert winner.tolist() == [1, 0, 0, 0]
    score = np.array([[21, 19], [21, 20], [29, 30], [3, 0], [22, 20]])
    assert rules.game_over(score, 21, 2, 30).tolist() == [True, False, True, False, True]


def streams_of(*seeds: int) -> Draw:
    """A serve's ``draw`` from one stream per seed (``default_rng(seed)``'s)."""
    streams = Streams(len(seeds))
    for g, s in enumerate(seeds):
        streams.seed(np.array([g]), s)
    return functools.partial(streams.random, np.arange(len(seeds)))


def test_machine_serve_draws_its_uniforms_from_each_stream():
    pos, vel = MachineServe()(streams_of(3, 4), np.array([0, 1]))
    u = np.stack([np.random.default_rng(s).random(rules.SERVE_DRAWS) for s in (3, 4)])
    expected = rules.sample_serve(u, np.array([0, 1]))
    np.testing.assert_array_equal(pos, expected[0])
    np.testing.assert_array_equal(vel, expected[1])


@pytest.mark.parametrize(("before", "after"), [(0, 0), (4, 0), (0, 4)])
def test_humanlike_serve_keeps_the_unused_draws_in_their_place(before, after):
    draw = streams_of(5)
    pos, vel = HumanLikeServe(before, after)(draw, np.array([1]))
    ref = np.random.default_rng(5)
    u = ref.random(before + HUMANLIKE_SERVE_DRAWS + after)[before:before + 5][None]
    assert draw(1)[0, 0] == ref.random()  # the stream moved on by every draw
    from rallysim.core.serve import sample_humanlike_serves

    p0, v0 = sample_humanlike_serves(u)
    np.testing.assert_array_equal(pos, p0 * [-1, -1, 1])  # toward player 1: turned about z
    np.testing.assert_array_equal(vel, v0 * [-1, -1, 1])


def test_fed_shots_replace_the_machine_serve_in_their_share():
    always = FedShots(1.0)
    pos, _ = always(streams_of(*range(50)), np.zeros(50, np.int64))
    assert np.isin(pos[:, 0], always.bank()[:, 0]).all()
    half = FedShots(0.5)
    pos, _ = half(streams_of(*range(400)), np.zeros(400, np.int64))
    assert 0.35 < np.isin(pos[:, 0], half.bank()[:, 0]).mean() < 0.65
    with pytest.raises(ValueError, match="share"):
        FedShots(0.0)


def test_the_game_serves_once_with_its_strategy():
    g = Game(2, 2, seed=3, serve=HUMANLIKE.serve,
             bodies=HumanLikeBodies(2, 2))
    g.reset(np.arange(2), receiver=np.array([0, 1]), base_x=np.full((2, 2), -2.7))
    assert np.linalg.norm(g.shuttle.vel, axis=1) == pytest.approx(15.0)
    assert g.shuttle.shot_speed == pytest.approx(15.0)
    assert g.shuttle.pos[0, 0] > 0 > g.shuttle.pos[1, 0]  # from the far side of each receiver
