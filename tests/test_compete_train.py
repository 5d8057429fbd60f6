"""The compete stage (``rallysim train compete``): a league of snapshots on its schedule, saved
and resumed with its checkpoints, deterministic per seed; the opponent mix of the pool; a best
response against a fixed pool."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from rallysim.policies.mlp import load_policy
from rallysim.train import checkpoint as ckpt
from rallysim.train.config import load_config
from rallysim.train.runner import train_stage

# 512 turns per rollout; snapshots at 0 and every 512 turns; a tiny evaluation
TINY = {"budget": 1024, "ppo.n_envs": 8, "ppo.n_steps": 64, "ppo.batch_size": 256,
        "ppo.n_epochs": 2, "checkpoint_every": 512, "eval.every": 0, "eval.episodes": 2,
        "league.snapshot_every": 512, "league.max_decisions": 3000,
        "league.rating_games": 1, "league.ladder": "scripted"}


def _run(out: Path, **overrides) -> dict:
    config = load_config("compete", overrides={**TINY, **overrides})
    return train_stage(config, out, progress=False)


def _weights(out: Path) -> str:
    return json.loads((out / "policy.json").read_text())["weights_sha256"]


@pytest.fixture(scope="module")
def league_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("compete") / "run"
    return out, _run(out)


def test_snapshots_follow_the_schedule(league_run):
    out, curve = league_run
    names = sorted(p.stem for p in (out / "pool").glob("*.json"))
    assert names == ["snapshot_000000000000", "snapshot_000000000512",
                     "snapshot_000000001024"]
    for name in names:  # each is a loadable high level of the SIMPLE player
        policy = load_policy(out / "pool" / name)
        assert policy(np.zeros((3, 20), np.float32)).shape == (3, 1)
    final = curve["final"]
    assert final["games"] == 2 and 0.0 <= final["point_win_rate"] <= 1.0
    assert final["vs_scripted"]["points"] > 0


def test_the_league_is_saved_with_each_checkpoint(league_run):
    out, _ = league_run
    latest = ckpt.latest_checkpoint(out)
    doc = json.loads(latest.read_text())
    state = doc["stage_state"]
    assert [s["turns"] for s in state["snapshots"]] == [0, 512, 1024]
    # every snapshot was rated against the ladder: the ratings survive in the checkpoint
    assert len(state["history"]) == 3 and all("rating" in h for h in state["history"])
    # the ladder is the fixed yardstick: only the snapshots' ratings move
    assert sorted(state["ratings"]["players"]) == [s["name"] for s in state["snapshots"]]


def test_same_seed_same_weights(league_run, tmp_path):
    out, _ = league_run
    again = tmp_path / "again"
    _run(again)
    assert _weights(again) == _weights(out)
    assert (out / "pool" / "snapshot_000000000512.safetensors").read_bytes() == (
        again / "pool" / "snapshot_000000000512.safetensors").read_bytes()


def test_resume_keeps_the_league(tmp_path):
    short = tmp_path / "short"
    _run(short, budget=512)
    first = json.loads(ckpt.latest_checkpoint(short).read_text())["stage_state"]
    _run(short)  # the same folder, a larger budget: resumes
    state = json.loads(ckpt.latest_checkpoint(short).read_text())["stage_state"]
    assert state["snapshots"][:len(first["snapshots"])] == first["snapshots"]
    assert [s["turns"] for s in state["snapshots"]] == [0, 512, 1024]
    # the ratings went on from the saved ones instead of starting again
    assert state["history"][:2] == first["history"][:2]


def test_a_fixed_pool_takes_no_snapshots(tmp_path):
    out = tmp_path / "br"
    curve = _run(out, budget=512, **{"league.opponents": "scripted"})
    assert not (out / "pool").exists() or not list((out / "pool").glob("*.json"))
    assert curve["steps"] == 512


def test_pool_weights():
    from rallysim.train.league import League

    class Env:
        rng = np.random.default_rng(0)

        def set_opponents(self, agents, weights):
            self.agents, self.weights = agents, weights

    config = load_config("compete", overrides={"league.window": 2})
    league = League(config, Path("/nonexistent"), Env())
    league.snapshots = [{"name": f"s{i}", "turns": i} for i in range(5)]
    league._agents = {f"s{i}": object() for i in range(5)}
    agents, weights = league.opponents()
    # the latest (s4) half the time, the anchors (scripted) 0.3, the window (s2, s3) the rest
    assert agents[0] is league._agents["s4"]
    assert agents[1:3] == [league._agents["s2"], league._agents["s3"]]
    assert weights == pytest.approx([0.5, 0.1, 0.1, 0.3])
    assert sum(weights) == pytest.approx(1.0)
