"""``Streams``: a batch's per-game PCG64 streams in one array, drawn by one compiled call, give
``np.random.default_rng(seed + i).random``'s doubles bit for bit."""

from __future__ import annotations

import copy
import pickle
import platform

import numpy as np
import pytest

from rallysim.core.streams import Streams


@pytest.mark.parametrize("seed", [0, 7, 12345, 2**32 + 5, 2**62])
def test_draws_equal_numpys_generators(seed):
    streams = Streams(40, seed)
    gens = [np.random.default_rng(seed + i) for i in range(40)]
    rng = np.random.default_rng(1)
    for _ in range(30):  # interleaved draws of other sizes from other subsets of games
        games = rng.choice(40, size=rng.integers(1, 40), replace=False)
        k = int(rng.integers(1, 9))
        expected = np.stack([gens[g].random(k) for g in games])
        np.testing.assert_array_equal(streams.random(games, k), expected)


def test_reseeding_a_game_restarts_its_stream_only():
    streams = Streams(3, 10)
    streams.random(np.arange(3), 5)
    streams.seed(np.array([2, 0]), 99)  # game 2 as 99, game 0 as 100
    after = streams.random(np.arange(3), 4)
    np.testing.assert_array_equal(after[2], np.random.default_rng(99).random(4))
    np.testing.assert_array_equal(after[0], np.random.default_rng(100).random(4))
    np.testing.assert_array_equal(after[1], np.random.default_rng(11).random(9)[5:])


def test_a_generator_goes_on_from_the_stream_without_moving_it():
    streams = Streams(2, 3)
    streams.random(np.array([1]), 6)
    gen = streams.generator(1)
    ahead = gen.random(5)
    np.testing.assert_array_equal(ahead, np.random.default_rng(4).random(11)[6:])
    np.testing.assert_array_equal(streams.random(np.array([1]), 5)[0], ahead)


def test_no_seed_gives_fresh_streams_and_copies_repeat():
    a, b = Streams(4), Streams(4)
    assert not np.array_equal(a.random(np.arange(4), 3), b.random(np.arange(4), 3))
    clones = [copy.deepcopy(a), pickle.loads(pickle.dumps(a))]
    expected = a.random(np.arange(4), 7)
    for clone in clones:
        np.testing.assert_array_equal(clone.random(np.arange(4), 7), expected)


def test_empty_draws_move_nothing():
    streams = Streams(2, 0)
    assert streams.random(np.array([], np.int64), 3).shape == (0, 3)
    assert streams.random(np.arange(2), 0).shape == (2, 0)
    np.testing.assert_array_equal(streams.random(np.arange(2), 1)[:, 0],
                                  [np.random.default_rng(s).random() for s in (0, 1)])


def test_bad_indices_are_refused_before_anything_is_drawn():
    streams = Streams(2, 0)
    before = streams.state.copy()
    for bad in (np.array([2]), np.array([-1]), np.array([True, False]), np.zeros((1, 1), int),
                np.array([0.5])):
        with pytest.raises(IndexError):
            streams.random(bad, 2)
        with pytest.raises(IndexError):
            streams.seed(bad, 3)
    np.testing.assert_array_equal(streams.state, before)


@pytest.mark.skipif(platform.machine() not in ("x86_64", "AMD64"),
                    reason="NumPy's C may fuse its uniform into an FMA on other CPUs")
def test_the_tasks_uniform_is_numpys():
    """The tasks draw a uniform in [lo, hi) as lo + (hi - lo) * u, which is
    ``Generator.uniform(lo, hi)``'s value where NumPy does not fuse it (x86-64)."""
    for lo, hi in ((-6.5, -2.44), (-1.3, 1.3), (2.0, 6.0), (0.0, 1.0)):
        a, b = np.random.default_rng(9), np.random.default_rng(9)
        u = a.random(10_000)
        np.testing.assert_array_equal(lo + (hi - lo) * u, [b.uniform(lo, hi) for _ in u])
