"""The warm start's DAgger rounds inside the rally (``warm_start.rally_dagger``): the clone
plays both players of the turn-based rally and the teacher labels every decision it makes."""

from __future__ import annotations

import numpy as np
import pytest

pytest.importorskip("torch")

import torch

from rallysim.core.humanlike_obs import TARGET_SCALE
from rallysim.players import get_player
from rallysim.policies.aimed_swing import AimedSwing
from rallysim.train.config import load_config
from rallysim.train.stages.low import LOW
from rallysim.train.warm_start import _critic_loss, rally_dataset

HL = get_player("humanlike")


def _task():
    return LOW.clone_task(load_config("low", None, {"player": "humanlike"}))


def test_a_rally_dataset_is_the_teachers_labels_of_the_actors_rally():
    teacher = AimedSwing()
    calls = []

    def actor(obs):  # holds still: the rally's states are the actor's, not the teacher's
        calls.append(len(obs))
        return np.zeros((len(obs), 15), np.float32)

    obs, act, ret, weight = rally_dataset(teacher, _task(), 600, 5, actor, spread=0.5,
                                          n_rallies=32)
    assert obs.shape == (600, HL.low_obs.size) and act.shape == weight.shape == (600, 15)
    assert np.isnan(ret).all()  # a rally has no low-level return
    assert calls and set(calls) == {64}  # both players of 32 rallies, every decision
    np.testing.assert_array_equal(act, AimedSwing()(obs).astype(np.float32))  # its labels
    assert weight.max() > 1.0  # the teacher's imitation weights are kept
    # each turn's goal lies in the central half of the goal range: target speeds 2.25-3.75 m/s
    speed = np.linalg.norm(obs[:, -3:] * TARGET_SCALE, axis=1)
    assert speed.min() > 2.2 and speed.max() < 3.8
    again = rally_dataset(teacher, _task(), 600, 5, actor, spread=0.5, n_rallies=32)
    np.testing.assert_array_equal(again[0], obs)  # seeded
    other = rally_dataset(teacher, _task(), 600, 6, actor, spread=0.5, n_rallies=32)
    assert not np.array_equal(other[0], obs)


def test_held_rallies_are_not_labelled_twice():
    """A rally that waits, held still, for its batch repeats its observation: kept once."""
    def still(obs):
        return np.zeros((len(obs), 15), np.float32)

    obs, *_ = rally_dataset(AimedSwing(), _task(), 2000, 1, still, spread=0.5, n_rallies=32)
    rows = obs.view(np.void(obs.dtype.itemsize * obs.shape[1])).ravel()
    assert len(np.unique(rows)) == len(rows)


def test_the_critic_skips_samples_without_a_return():
    value = torch.tensor([[1.0], [2.0], [3.0]], requires_grad=True)
    target = torch.tensor([[0.0], [float("nan")], [1.0]])
    assert _critic_loss(value, target).item() == pytest.approx((1.0 + 4.0) / 2)
    full = torch.tensor([[0.0], [0.0], [1.0]])  # every return known: the plain mean
    assert _critic_loss(value, full).item() == pytest.approx((1.0 + 4.0 + 4.0) / 3)
    empty = _critic_loss(value, torch.full((3, 1), float("nan")))
    assert empty.item() == 0.0
    empty.backward()  # still a loss the fit can step on
    assert torch.equal(value.grad, torch.zeros(3, 1))
