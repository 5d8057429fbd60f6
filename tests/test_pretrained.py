"""The shipped SIMPLE policies: they load without torch and play as the reproduction measured."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np

from rallysim.cli import main
from rallysim.eval.low_eval import evaluate_return
from rallysim.eval.rally_eval import rally_lengths_turns
from rallysim.policies.resolve import high_level_policy, low_level_policy, rally_low_level


def test_shipped_policies_load_without_torch():
    code = ("import sys; sys.modules['torch'] = None; sys.modules['stable_baselines3'] = None\n"
            "from rallysim.policies.resolve import load_network\n"
            "for role in ('low', 'high', 'mono'): load_network('pretrained', role)\n"
            "print('ok')")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True)
    assert out.stdout.strip() == "ok", out.stderr


def test_pretrained_low_level_returns_serves():
    r = evaluate_return(low_level_policy("pretrained"), episodes=256, seed=99)
    assert r.hit_rate > 0.95 and r.mean_reward > 1.5


def test_pretrained_hierarchy_rallies_long():
    lengths = rally_lengths_turns(high_level_policy("pretrained"), rally_low_level("pretrained"),
                                  32, seed=99)
    assert lengths.mean() > 30


def test_evaluate_pretrained_writes_every_number(tmp_path):
    path = tmp_path / "eval.json"
    assert main(["evaluate", "--pretrained", "--rallies", "8", "--seeds", "1", "--json",
                 str(path)]) == 0
    data = json.loads(path.read_text())
    assert set(data["methods"]) == {"HRL", "Random High-level", "Monolithic"}
    assert np.isfinite(data["methods"]["HRL"]["mean"]["value"])
