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


@pytest.mark.parametrize("name", sorted(CASES))
def test_golden_episode(name):
    assert CASES[name]() == RECORDED[name], f"{name}: seeded episodes changed"
