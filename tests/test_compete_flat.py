"""The flat competitive baseline: its env (``CompeteDecisionVectorEnv``: the learner acts every
decision, rewards are points), its stage (``rallysim train compete_mono``: a league of
``Direct`` snapshots, the actor started from the cooperative Monolithic policy, deterministic
per seed) and the actor loader it starts with."""

from __future__ import annotations

import copy
import json
import pickle
from pathlib import Path

import numpy as np
import pytest

from rallysim.envs.compete_turn import CompeteDecisionVectorEnv
from rallysim.eval.agents import Direct, agent
from rallysim.players import SIMPLE
from rallysim.policies.registry import resolve


def _env(n: int = 8, seed: int = 3, **kw) -> CompeteDecisionVectorEnv:
    return CompeteDecisionVectorEnv(n, [agent("scripted")], seed=seed, **kw)


def test_one_step_is_one_decision_of_the_motor_action():
    env = _env(4)
    obs, _ = env.reset(seed=1)
    assert obs.shape == (4, SIMPLE.rally_obs.size)
    assert env.single_action_space.shape == (SIMPLE.action.size,) == (3,)
    _, _, _, _, info = env.step(np.zeros((4, 3), np.float32))
    assert info["decisions"].tolist() == [1, 1, 1, 1]
    assert env.decisions_simulated == 4


def test_rewards_are_points_and_returning_shots_keeps_rallies_going():
    """300 decisions of 8 games against the scripted controller (seed 3): standing still
    loses 93 points and wins 11; the shipped cooperative Monolithic policy returns the shots,
    so its rallies last and only 14 points end in the same time."""
    mono = resolve("pretrained", "mono")

    def play(act) -> tuple[int, int, float]:
        env = _env()
        obs, _ = env.reset(seed=3)
        won = lost = 0
        total = 0.0
        for _ in range(300):
            obs, reward, _, _, info = env.step(act(obs))
            won += int(info["points_won"].sum())
            lost += int(info["points_lost"].sum())
            total += float(reward.sum())
        assert total == won - lost
        return won, lost, total

    still = play(lambda obs: np.zeros((len(obs), 3), np.float32))
    played = play(mono)
    assert still[1] > 0.8 * (still[0] + still[1]) and still[0] + still[1] > 80
    assert played[0] + played[1] < (still[0] + still[1]) / 4


def test_seeded_replay_and_copies():
    a, b = _env(seed=1), _env(seed=2)
    a.reset(seed=11)
    b.reset(seed=11)
    actions = np.random.default_rng(0).uniform(-1, 1, (40, 8, 3)).astype(np.float32)
    for act in actions[:20]:
        ra, rb = a.step(act), b.step(act)
        np.testing.assert_array_equal(ra[0], rb[0])
        np.testing.assert_array_equal(ra[1], rb[1])
    clones = [copy.deepcopy(a), pickle.loads(pickle.dumps(a))]
    for act in actions[20:]:
        obs, reward = a.step(act)[:2]
        for clone in clones:
            c_obs, c_reward = clone.step(act)[:2]
            np.testing.assert_array_equal(c_obs, obs)
            np.testing.assert_array_equal(c_reward, reward)


def test_bad_actions_are_refused():
    env = _env(2)
    env.reset(seed=0)
    with pytest.raises(ValueError):
        env.step(np.zeros((2, 1), np.float32))  # a goal, not a motor action
    with pytest.raises(ValueError):
        env.step(np.full((2, 3), np.nan, np.float32))


# -- the stage ---------------------------------------------------------------------------------
torch = pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from test_compete_train import TINY  # noqa: E402  (the hierarchical league's tiny run)

from rallysim.train.config import load_config  # noqa: E402
from rallysim.train.runner import build_model, train_stage  # noqa: E402


def _run(out: Path, **overrides) -> dict:
    config = load_config("compete_mono", overrides={**TINY, **overrides})
    return train_stage(config, out, progress=False)


@pytest.fixture(scope="module")
def flat_run(tmp_path_factory):
    out = tmp_path_factory.mktemp("flat") / "run"
    return out, _run(out)


@pytest.mark.slow  # trains
def test_snapshots_are_monolithic_players(flat_run):
    out, curve = flat_run
    names = sorted(p.stem for p in (out / "pool").glob("*.json"))
    assert names == ["snapshot_000000000000", "snapshot_000000000512",
                     "snapshot_000000001024"]
    for name in names:
        doc = json.loads((out / "pool" / f"{name}.json").read_text())
        assert doc["metadata"]["stage"] == "compete_mono"
        # rallysim evaluate --mode competitive plays it as a Monolithic player
        assert isinstance(agent(str(out / "pool" / name)), Direct)
    assert isinstance(agent(str(out / "policy")), Direct)
    assert 0.0 <= curve["final"]["point_win_rate"] <= 1.0


@pytest.mark.slow  # trains
def test_the_actor_starts_from_the_cooperative_monolithic_policy(flat_run):
    """The first snapshot, taken before any update, is the shipped simple_mono's actor."""
    out, _ = flat_run
    first = resolve(str(out / "pool" / "snapshot_000000000000"), "mono")
    shipped = resolve("pretrained", "mono")
    for (w, b), (w0, b0) in zip(first.layers, shipped.layers, strict=True):
        np.testing.assert_array_equal(w, w0)
        np.testing.assert_array_equal(b, b0)
    np.testing.assert_array_equal(first.log_std, shipped.log_std)


@pytest.mark.slow  # trains
def test_same_seed_same_weights(flat_run, tmp_path):
    out, _ = flat_run
    again = tmp_path / "again"
    _run(again)
    assert (json.loads((again / "policy.json").read_text())["weights_sha256"]
            == json.loads((out / "policy.json").read_text())["weights_sha256"])


def test_load_actor_refuses_another_shape(tmp_path):
    from rallysim.policies.mlp import load_policy
    from rallysim.policies.registry import PRETRAINED
    from rallysim.train.export import load_actor

    model = build_model(load_config("compete_mono", overrides=TINY), tmp_path)
    with pytest.raises(ValueError, match="does not fit"):  # a 20 -> 1 actor, not 20 -> 3
        load_actor(model, load_policy(PRETRAINED / "simple_high"))
    with pytest.raises(ValueError, match="MLP actor"):
        load_actor(model, resolve("pretrained", "high"))  # the goal mapping around one


# -- the study -----------------------------------------------------------------------------------
@pytest.mark.slow  # trains
def test_a_tiny_flat_study(tmp_path, monkeypatch):
    from experiments import compete_flat_study as flat

    monkeypatch.setattr(flat, "OPPONENTS", ("scripted", "mono"))
    tiny = {k: v for k, v in TINY.items() if k != "budget"}
    path = flat.run_seed(0, tmp_path, budget=512, games=2, max_decisions=1500, overrides=tiny)
    doc = json.loads(path.read_text())
    assert [r["decisions"] for r in doc["ratings"]] == [0, 512]
    assert all(r["rating"] is not None for r in doc["ratings"])
    per_game = doc["versus"]["mono"]["per_game"]
    assert len(per_game["won"]) == 2 and doc["init_policy"] == "pretrained"
    result = flat.report(tmp_path)
    assert result["kind"] == "compete_flat" and result["opponents"] == ["scripted", "mono"]
    assert result["pooled"]["mono"]["value"] == pytest.approx(
        sum(per_game["won"]) / sum(per_game["points"]))
    text = flat.render(result)
    assert "| 0 | " in text and "| pooled | " in text
    assert f"{result['pooled']['mono']['value']:.3f}" in text
    assert json.loads((tmp_path / "compete_flat.json").read_text()) == result


def test_the_docs_table_matches_the_committed_flat_study():
    from rallysim.train.results_doc import regenerate

    root = Path(__file__).resolve().parents[1]
    doc = (root / "docs" / "competitive.md").read_text()
    assert "<!-- BEGIN GENERATED: compete_flat -->" in doc
    assert regenerate(doc, root / "docs" / "data") == doc
