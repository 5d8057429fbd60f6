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

# 512 turns per rollout; snapshots at 0 and every 512 turns; a tiny evaluation. Games stop
# after 1,500 decisions (ratings too: 5,000 by default), which still score 6-8 points against
# the scripted player: most of a run's time is these games, not PPO.
TINY = {"budget": 1024, "ppo.n_envs": 8, "ppo.n_steps": 64, "ppo.batch_size": 256,
        "ppo.n_epochs": 2, "checkpoint_every": 512, "eval.every": 0, "eval.episodes": 2,
        "league.snapshot_every": 512, "league.max_decisions": 1500,
        "league.rating_decisions": 1500, "league.rating_games": 1, "league.ladder": "scripted"}


def _run(out: Path, **overrides) -> dict:
    config = load_config("compete", overrides={**TINY, **overrides})
    return train_stage(config, out, progress=False)


def _weights(out: Path) -> str:
    return json.loads((out / "policy.json").read_text())["weights_sha256"]


@pytest.fixture(scope="module")
def league_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("compete") / "run"
    return out, _run(out)


@pytest.mark.slow  # trains
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


@pytest.mark.slow  # trains
def test_the_league_is_saved_with_each_checkpoint(league_run):
    out, _ = league_run
    latest = ckpt.latest_checkpoint(out)
    doc = json.loads(latest.read_text())
    state = doc["stage_state"]
    assert [s["turns"] for s in state["snapshots"]] == [0, 512, 1024]
    # every snapshot was rated against the ladder: the ratings survive in the checkpoint
    assert len(state["history"]) == 3 and all("rating" in h for h in state["history"])
    # the ladder (calibrated first; one rung keeps the defaults) is the fixed yardstick: only
    # the snapshots' ratings move
    players = state["ratings"]["players"]
    assert sorted(players) == sorted(["scripted", *(s["name"] for s in state["snapshots"])])
    assert players["scripted"] == {"mu": 25.0, "sigma": 25.0 / 3.0}


@pytest.mark.slow  # trains
def test_the_league_rates_with_the_shared_function(league_run, monkeypatch):
    # League.rate is eval.ratings.rate_against: the same games rated the same way give the
    # league's logged ratings float for float
    from rallysim.eval.agents import agent
    from rallysim.eval.ratings import Ratings, rate_against
    from rallysim.policies.registry import resolve

    out, _ = league_run
    state = json.loads(ckpt.latest_checkpoint(out).read_text())["stage_state"]
    config = load_config("compete", overrides=TINY)
    ratings = Ratings({"scripted": (25.0, 25.0 / 3.0)})
    low = resolve(config.low_policy, "rally_low", config.player)
    for record in state["history"]:
        played = rate_against(ratings, record["name"], agent(str(out / "pool" / record["name"])),
                              ["scripted"], games=1, seed=config.eval.seed,
                              max_decisions=config.league.rating_decisions,
                              shuttle=config.shuttle, low=low)
        assert ratings.ordinal(record["name"]) == record["rating"]
        assert played["scripted"].point_win_rate == record["point_win_rate"]["scripted"]
    assert ratings.to_json() == state["ratings"]

    import rallysim.eval.ratings as ratings_module
    from rallysim.train.league import League

    calls = []
    monkeypatch.setattr(ratings_module, "rate_against",
                        lambda *a, **k: calls.append(a[1]) or {})
    league = League.__new__(League)
    league.config, league.ratings = config, state["ratings"]
    league.snapshot_agent, league.low = (lambda name: None), low
    assert league.rate("new")["point_win_rate"] == {} and calls == ["new"]


@pytest.mark.slow  # trains
def test_same_seed_same_weights(league_run, tmp_path):
    out, _ = league_run
    again = tmp_path / "again"
    _run(again)
    assert _weights(again) == _weights(out)
    assert (out / "pool" / "snapshot_000000000512.safetensors").read_bytes() == (
        again / "pool" / "snapshot_000000000512.safetensors").read_bytes()


@pytest.mark.slow  # trains
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


@pytest.mark.slow  # trains
def test_a_fixed_pool_takes_no_snapshots(tmp_path):
    out = tmp_path / "br"
    curve = _run(out, budget=512, **{"league.opponents": "scripted"})
    assert not (out / "pool").exists() or not list((out / "pool").glob("*.json"))
    assert curve["steps"] == 512


def test_pool_weights():
    from rallysim.train.league import League
    from rallysim.train.stages import COMPETE

    class Env:
        rng = np.random.default_rng(0)

        def set_opponents(self, agents, weights):
            self.agents, self.weights = agents, weights

    config = load_config("compete", overrides={"league.window": 2})
    league = League(config, Path("/nonexistent"), Env(), COMPETE)
    league.snapshots = [{"name": f"s{i}", "turns": i} for i in range(5)]
    league._agents = {f"s{i}": object() for i in range(5)}
    agents, weights = league.opponents()
    # the latest (s4) half the time, the anchors (scripted) 0.3, the window (s2, s3) the rest
    assert agents[0] is league._agents["s4"]
    assert agents[1:3] == [league._agents["s2"], league._agents["s3"]]
    assert weights == pytest.approx([0.5, 0.1, 0.1, 0.3])
    assert sum(weights) == pytest.approx(1.0)
