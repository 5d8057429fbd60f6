"""experiments/first_exchange.py: where rallies are lost, at a tiny size, and the research
log's table against its committed JSON."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from experiments import first_exchange

ROOT = Path(__file__).resolve().parents[1]


def test_the_scripted_profile():
    p = first_exchange.seed_profile(None, -1, rallies=24, goal=3.5)
    shares = [p[k] for k in ("lost_0_1", "lost_2", "lost_3_49", "capped")]
    assert abs(sum(shares) - 1.0) < 1e-12 and all(0.0 <= s <= 1.0 for s in shares)
    assert p["capped"] > 0.5  # the scripted pair sustains most rallies at 3.5 m
    # the scripted controller waits near its start (-2.7 m), not at the back of the court
    assert -3.2 < p["waiting_base_x_median"] < -2.0
    went_on = p["lost_turn"]["meetable_from_best_base"]["went_on"]
    assert went_on is not None and went_on > 0.8


@pytest.mark.parametrize("name", ["first_exchange_seeds10", "first_exchange_seeds10_generic"])
def test_the_research_log_shows_the_committed_profiles(name):
    data = json.loads((ROOT / "docs/data" / f"{name}.json").read_text())
    lines = first_exchange.table({int(k): v for k, v in data.items()})
    page = (ROOT / "docs/research-log/reproduce.md").read_text()
    for line in lines:
        assert line in page, line
