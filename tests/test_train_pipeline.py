"""The training pipeline: configs, checkpoints (round trip, corruption, kill -9 resume), and a
smoke run of every stage on a tiny budget."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
import time

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from rallysim.policies.mlp import load_policy
from rallysim.train import checkpoint as ckpt
from rallysim.train.config import load_config, parse_overrides
from rallysim.train.runner import build_model, train_stage

TINY = {"n_envs": 16, "n_steps": 32, "batch_size": 256, "n_epochs": 2, "eval_episodes": 16,
        "eval_every": 0, "checkpoint_every": 1024}


def test_config_layers_and_errors(tmp_path):
    c = load_config("low")
    assert (c.net_arch, c.activation, c.log_std_init, c.gamma) == ((64, 64), "tanh", -0.5, 0.99)
    user = tmp_path / "mine.yaml"
    user.write_text("n_envs: 128\nlearning_rate: 0.001\n")
    c = load_config("low", user, parse_overrides(["n_envs=32", "net_arch=[32, 16]"]))
    assert (c.n_envs, c.learning_rate, c.net_arch) == (32, 0.001, (32, 16))
    with pytest.raises(ValueError, match="unknown setting"):
        load_config("low", None, {"lr": 1.0})
    user.write_text("n_envs: [\n")
    with pytest.raises(ValueError, match="not valid YAML"):
        load_config("low", user)
    with pytest.raises(ValueError, match="even n_envs"):
        load_config("mono", None, {"n_envs": 33})


def test_checkpoint_round_trip_restores_policy_and_optimiser(tmp_path):
    config = load_config("low", None, {**TINY, "decisions": 1024})
    model = build_model(config, tmp_path)
    model.learn(1024)
    path = ckpt.save_checkpoint(tmp_path, model, {"stage": "low", "network": config.network(),
                                                  "curve": {}})
    fresh = build_model(config, tmp_path)
    doc, tensors = ckpt.read_checkpoint(path, expect={"network": config.network()})
    ckpt.restore(fresh, doc, tensors)
    obs = np.random.default_rng(0).uniform(-1, 1, (8, 17)).astype(np.float32)
    a = model.predict(obs, deterministic=True)[0]
    b = fresh.predict(obs, deterministic=True)[0]
    np.testing.assert_array_equal(a, b)
    s0, s1 = model.policy.optimizer.state_dict(), fresh.policy.optimizer.state_dict()
    for pid in s0["state"]:
        np.testing.assert_array_equal(s0["state"][pid]["exp_avg"], s1["state"][pid]["exp_avg"])
    assert fresh.num_timesteps == model.num_timesteps


def test_corrupted_or_mismatched_checkpoint_gives_a_clear_error(tmp_path):
    config = load_config("low", None, {**TINY, "decisions": 512})
    model = build_model(config, tmp_path)
    path = ckpt.save_checkpoint(tmp_path, model, {"stage": "low", "network": config.network(),
                                                  "curve": {}})
    with pytest.raises(ckpt.CheckpointError, match="made with network"):
        ckpt.read_checkpoint(path, expect={"network": {**config.network(), "net_arch": [8]}})
    weights = path.with_name(json.loads(path.read_text())["weights"])
    weights.write_bytes(weights.read_bytes()[:-100])  # truncated, as by a dying disk
    with pytest.raises(ckpt.CheckpointError, match="corrupted"):
        ckpt.read_checkpoint(path)
    path.write_text("{not json")
    with pytest.raises(ckpt.CheckpointError, match="corrupted"):
        ckpt.read_checkpoint(path)
    policy = tmp_path / "p"
    (tmp_path / "p.json").write_text("{}")
    (tmp_path / "p.safetensors").write_bytes(b"\0" * 16)
    with pytest.raises(ValueError, match="not a rallysim-mlp-policy"):
        load_policy(policy)


def test_resume_after_kill_9_loses_at_most_one_interval(tmp_path):
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "rallysim.cli", "train", "low", "--decisions", "60000",
           "--out", str(out), "--quiet", "--set", "n_envs=16", "n_steps=32", "batch_size=256",
           "n_epochs=2", "eval_episodes=16", "eval_every=0", "checkpoint_every=4096"]
    env = {**os.environ, "PYTHONUNBUFFERED": "1"}
    proc = subprocess.Popen(cmd, env=env, stdout=subprocess.PIPE, stderr=subprocess.STDOUT)
    deadline = time.time() + 120
    while time.time() < deadline and ckpt.latest_checkpoint(out) is None:
        time.sleep(0.05)
    time.sleep(0.3)
    os.kill(proc.pid, signal.SIGKILL)
    proc.wait()
    saved = ckpt.latest_checkpoint(out)
    assert saved is not None, "no checkpoint before the kill"
    done = json.loads(saved.read_text())["decisions"]
    assert 4096 <= done < 60000
    result = subprocess.run(cmd, env=env, capture_output=True, text=True,
                            timeout=300)
    assert result.returncode == 0, result.stderr
    curve = json.loads((out / "curve.json").read_text())
    assert curve["steps"] >= 60000
    # the resumed run continued from the checkpoint: its rollouts pick up where it stopped
    steps = [r["steps"] for r in curve["rollouts"]]
    assert steps == sorted(steps) and steps[0] == 512


@pytest.mark.parametrize("stage", ["low", "high", "mono"])
def test_every_stage_smoke_runs_and_exports_a_loadable_policy(tmp_path, stage):
    overrides = {**TINY, "decisions": 1024 if stage != "high" else 256, "low_policy": "scripted"}
    if stage == "high":
        overrides.update(n_steps=8, batch_size=64)
    curve = train_stage(load_config(stage, None, overrides), tmp_path, progress=False)
    policy = load_policy(tmp_path / "policy")
    obs_size = 17 if stage == "low" else 20
    actions = policy(np.zeros((4, obs_size), np.float32))
    assert actions.shape == (4, 1 if stage == "high" else 3)
    assert np.all(np.abs(actions) <= 1)
    assert curve["final"] and curve["steps"] >= overrides["decisions"]
    if stage == "high":
        assert curve["decisions_simulated"] > curve["steps"]  # a turn spans many decisions
        assert curve["final"]["mean_rally"] > 10  # the scripted low level rallies


def test_humanlike_low_level_trains_and_reports_its_errors(tmp_path):
    overrides = {**TINY, "decisions": 1024, "env": "humanlike", "warm_start": "none"}
    config = load_config("low", None, overrides)
    # the player's packaged settings apply under the user's
    assert (config.net_arch, config.warm_start_dagger) == ((256, 256), 6)
    curve = train_stage(config, tmp_path, progress=False)
    final = curve["final"]
    assert {"hit_rate", "mean_angle_error", "mean_abs_speed_error"} <= set(final)
    assert 0.0 <= final["hit_rate"] <= 1.0
    policy = load_policy(tmp_path / "policy")
    assert policy(np.zeros((2, 85), np.float32)).shape == (2, 15)
    assert json.loads((tmp_path / "policy.json").read_text())["env_id"] == (
        "RallySim/HumanLikeReturn-v0")
    with pytest.raises(ValueError, match="no monolithic"):
        load_config("mono", None, {"env": "humanlike", "n_envs": 16})


def test_humanlike_warm_start_clones_aimed_swing_with_dagger(tmp_path):
    """The HUMAN-LIKE warm start fits the actor to AimedSwing (then DAgger on its own states):
    its actions move toward the teacher's on fresh serves."""
    from rallysim.envs.humanlike_return_v0 import HumanLikeReturnVectorEnv
    from rallysim.policies.aimed_swing import AimedSwing

    config = load_config("low", None, {**TINY, "env": "humanlike", "warm_start": "scripted",
                                       "warm_start_decisions": 8192, "warm_start_epochs": 20,
                                       "warm_start_dagger": 1})
    model = build_model(config, tmp_path)
    env = HumanLikeReturnVectorEnv(64, seed=99)
    obs, _ = env.reset(seed=99)
    teacher = AimedSwing()(obs)
    before = np.mean((model.predict(obs, deterministic=True)[0] - teacher) ** 2)
    from rallysim.train.runner import warm_start

    result = warm_start(model, config, progress=False)
    after = np.mean((model.predict(obs, deterministic=True)[0] - teacher) ** 2)
    assert result["teacher"] == "AimedSwing"
    # decisions = 0: the clone alone is trained and exported, no PPO after it
    clone_only = load_config("low", None, {**TINY, "env": "humanlike", "decisions": 0,
                                           "warm_start_decisions": 4096, "warm_start_epochs": 2,
                                           "warm_start_dagger": 0, "eval_episodes": 8})
    curve = train_stage(clone_only, tmp_path / "clone", progress=True)
    assert curve["steps"] == 0 and curve["final"]["episodes"] == 8
    assert load_policy(tmp_path / "clone" / "policy")(np.zeros((1, 85))).shape == (1, 15)
    with pytest.raises(ValueError, match="decisions must be >= 1"):
        load_config("low", None, {"decisions": 0, "warm_start": "none"})
    # the clone's 8192 decisions, then one DAgger round's 2048, less the unfinished episodes
    assert 0.3 * (8192 + 2048) < result["samples"] <= 8192 + 2048
    assert after < 0.5 * before
    # the clone's learning curve: evaluated after the clone and after the DAgger round
    rounds = result["rounds"]
    assert [r["labelled_decisions"] for r in rounds] == [8192, 8192 + 2048]
    assert all(r["episodes"] == config.eval_episodes and 0 <= r["hit_rate"] <= 1
               for r in rounds)


def test_humanlike_high_level_trains_over_the_scripted_low_level(tmp_path):
    overrides = {**TINY, "decisions": 256, "n_envs": 8, "n_steps": 32, "batch_size": 128,
                 "eval_episodes": 8, "env": "humanlike", "low_policy": "scripted"}
    curve = train_stage(load_config("high", None, overrides), tmp_path, progress=False)
    assert curve["decisions_simulated"] > 5 * curve["steps"]  # a turn spans many decisions
    assert curve["final"]["mean_rally"] >= 10  # the target
    policy = load_policy(tmp_path / "policy")
    assert policy(np.zeros((2, 86), np.float32)).shape == (2, 3)
    doc = json.loads((tmp_path / "policy.json").read_text())
    assert doc["env_id"] == "rallysim.envs.humanlike_rally_v0:HumanLikeRallyTurnVectorEnv"
