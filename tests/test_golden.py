"""Seeded episodes of every env id and view, for each shuttle model, hash as recorded
(tests/golden.py). Behaviour-preserving refactors keep them; deliberate behaviour changes
regenerate them in their own commit."""

from __future__ import annotations

import json

import pytest
from golden import GOLDEN_FILE, cases

# exact hashes: they hold under the pinned numerics (tests/conftest.py)
pytestmark = pytest.mark.numerics

RECORDED: dict[str, str] = json.loads(GOLDEN_FILE.read_text())
CASES = dict(cases())


def test_every_view_has_a_recorded_hash():
    assert sorted(CASES) == sorted(RECORDED)
    assert set(CASES) > FAST  # (a renamed view is renamed here too)


# The fast tier (``pytest -m "not slow"``) hashes a cheap case of each kind of view, with the
# paper's shuttle; the slow tier hashes every shuttle, mode and view (the HUMAN-LIKE rallies'
# turn and parallel views take 5-15 s each).
FAST = {"SimpleReturn-v0/single/paper", "SimpleReturn-v0/vector/paper",
        "HumanLikeReturn-v0/single/paper", "HumanLikeReturn-v0/vector/paper",
        "simple_rally_v0/parallel/paper/cooperative", "simple_rally_v0/vector/paper",
        "simple_rally_v0/turn_vector/paper", "humanlike_rally_v0/vector/paper",
        "pretrained/simple"}


@pytest.mark.parametrize("name", [
    name if name in FAST else pytest.param(name, marks=pytest.mark.slow) for name in sorted(CASES)])
def test_golden_episode(name):
    assert CASES[name]() == RECORDED[name], f"{name}: seeded episodes changed"
