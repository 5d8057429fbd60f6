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

TINY = {"ppo.n_envs": 16, "ppo.n_steps": 32, "ppo.batch_size": 256, "ppo.n_epochs": 2,
        "eval.episodes": 16, "eval.every": 0, "checkpoint_every": 1024}


def test_config_layers_and_errors(tmp_path):
    c = load_config("low")
    assert (c.ppo.net_arch, c.ppo.activation, c.ppo.log_std_init, c.ppo.gamma) == (
        (64, 64), "tanh", -0.5, 0.99)
    user = tmp_path / "mine.yaml"
    user.write_text("ppo:\n  n_envs: 128\n  learning_rate: 0.001\n")
    c = load_config("low", user, parse_overrides(["ppo.n_envs=32", "ppo.net_arch=[32, 16]"]))
    assert (c.ppo.n_envs, c.ppo.learning_rate, c.ppo.net_arch) == (32, 0.001, (32, 16))
    with pytest.raises(ValueError, match="unknown setting"):
        load_config("low", None, {"lr": 1.0})
    user.write_text("ppo: {n_envs: [\n")
    with pytest.raises(ValueError, match="not valid YAML"):
        load_config("low", user)
    with pytest.raises(ValueError, match=r"ppo\.n_envs divisible by 2"):
        load_config("mono", None, {"ppo.n_envs": 33})


def test_checkpoint_round_trip_restores_policy_and_optimiser(tmp_path):
    config = load_config("low", None, {**TINY, "budget": 1024})
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
    config = load_config("low", None, {**TINY, "budget": 512})
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


@pytest.mark.slow  # kills
def test_resume_after_kill_9_loses_at_most_one_interval(tmp_path):
    out = tmp_path / "run"
    cmd = [sys.executable, "-m", "rallysim.cli", "train", "low", "--budget", "60000",
           "--out", str(out), "--quiet", "--set", "ppo.n_envs=16", "ppo.n_steps=32",
           "ppo.batch_size=256", "ppo.n_epochs=2", "eval.episodes=16", "eval.every=0",
           "checkpoint_every=4096"]
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


@pytest.mark.parametrize("stage", ["low", pytest.param("high", marks=pytest.mark.slow), "mono"])
def test_every_stage_smoke_runs_and_exports_a_loadable_policy(tmp_path, stage):
    overrides = {**TINY, "budget": 1024 if stage != "high" else 256, "low_policy": "scripted"}
    if stage == "high":
        overrides.update({"ppo.n_steps": 8, "ppo.batch_size": 64})
    curve = train_stage(load_config(stage, None, overrides), tmp_path, progress=False)
    policy = load_policy(tmp_path / "policy")
    obs_size = 17 if stage == "low" else 20
    actions = policy(np.zeros((4, obs_size), np.float32))
    assert actions.shape == (4, 1 if stage == "high" else 3)
    assert np.all(np.abs(actions) <= 1)
    assert curve["final"] and curve["steps"] >= overrides["budget"]
    if stage == "high":
        assert curve["decisions_simulated"] > curve["steps"]  # a turn spans many decisions
        assert curve["final"]["mean_rally"] > 10  # the scripted low level rallies


def test_humanlike_low_level_trains_and_reports_its_errors(tmp_path):
    overrides = {**TINY, "budget": 1024, "player": "humanlike", "warm_start.teacher": "none"}
    config = load_config("low", None, overrides)
    # the player's packaged settings apply under the user's
    assert (config.ppo.net_arch, config.warm_start.dagger, config.warm_start.rally_dagger) == (
        (256, 256), 4, 2)
    curve = train_stage(config, tmp_path, progress=False)
    final = curve["final"]
    assert {"hit_rate", "mean_angle_error", "mean_abs_speed_error"} <= set(final)
    assert 0.0 <= final["hit_rate"] <= 1.0
    policy = load_policy(tmp_path / "policy")
    assert policy(np.zeros((2, 85), np.float32)).shape == (2, 15)
    assert json.loads((tmp_path / "policy.json").read_text())["env_id"] == (
        "RallySim/HumanLikeReturn-v0")


def test_humanlike_monolithic_baseline_trains_on_the_3d_rally(tmp_path):
    """The Monolithic baseline for HUMAN-LIKE players: one policy acting for both players of
    the 3-D rally every decision, exported for that rally and evaluated on it."""
    from rallysim.eval.rally_eval import rally_lengths_direct

    config = load_config("mono", None, {**TINY, "budget": 1024, "player": "humanlike"})
    assert config.ppo.net_arch == (256, 256)  # the player's packaged settings
    curve = train_stage(config, tmp_path, progress=False)
    assert curve["steps"] >= 1024 and 0.0 <= curve["final"]["mean_rally"] <= 50.0
    doc = json.loads((tmp_path / "policy.json").read_text())
    assert doc["env_id"] == "rallysim.envs.humanlike_rally_v0:HumanLikeRallyVectorEnv"
    policy = load_policy(tmp_path / "policy")
    assert policy(np.zeros((2, 86), np.float32)).shape == (2, 15)
    lengths = rally_lengths_direct(policy, 4, seed=3, player="humanlike")
    assert lengths.shape == (4,) and lengths.min() >= 0
    with pytest.raises(ValueError, match="size 86"):  # a SIMPLE rally is not its game
        rally_lengths_direct(policy, 2, seed=3)


@pytest.mark.slow  # trains
def test_humanlike_warm_start_clones_aimed_swing_with_dagger(tmp_path):
    """The HUMAN-LIKE warm start fits the actor to AimedSwing (then DAgger on its own states):
    its actions move toward the teacher's on fresh serves."""
    from rallysim.envs.humanlike_return_v0 import HumanLikeReturnVectorEnv
    from rallysim.policies.aimed_swing import AimedSwing

    config = load_config("low", None, {**TINY, "player": "humanlike",
                                       "warm_start": {"teacher": "scripted", "decisions": 8192,
                                                      "epochs": 20, "dagger": 1,
                                                      "rally_dagger": 0}})
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
    clone_only = load_config("low", None, {**TINY, "player": "humanlike", "budget": 0,
                                           "warm_start.decisions": 4096,
                                           "warm_start.epochs": 2, "warm_start.dagger": 0,
                                           "warm_start.rally_dagger": 0, "eval.episodes": 8})
    curve = train_stage(clone_only, tmp_path / "clone", progress=True)
    assert curve["steps"] == 0 and curve["final"]["episodes"] == 8
    assert load_policy(tmp_path / "clone" / "policy")(np.zeros((1, 85))).shape == (1, 15)
    with pytest.raises(ValueError, match=r"budget \(decisions\) must be >= 1"):
        load_config("low", None, {"budget": 0, "warm_start.teacher": "none"})
    # the clone's 8192 decisions, then one DAgger round's 2048, less the unfinished episodes
    assert 0.3 * (8192 + 2048) < result["samples"] <= 8192 + 2048
    assert after < 0.5 * before
    # the clone's learning curve: evaluated after the clone and after the DAgger round
    rounds = result["rounds"]
    assert [r["labelled_decisions"] for r in rounds] == [8192, 8192 + 2048]
    assert all(r["episodes"] == config.eval.episodes and 0 <= r["hit_rate"] <= 1
               for r in rounds)


@pytest.mark.slow  # trains
def test_humanlike_high_level_trains_over_the_scripted_low_level(tmp_path):
    overrides = {**TINY, "budget": 256, "ppo.n_envs": 8, "ppo.n_steps": 32,
                 "ppo.batch_size": 128, "eval.episodes": 8, "player": "humanlike",
                 "low_policy": "scripted"}
    curve = train_stage(load_config("high", None, overrides), tmp_path, progress=False)
    assert curve["decisions_simulated"] > 5 * curve["steps"]  # a turn spans many decisions
    assert curve["final"]["mean_rally"] >= 10  # the target
    policy = load_policy(tmp_path / "policy")
    assert policy(np.zeros((2, 86), np.float32)).shape == (2, 3)
    doc = json.loads((tmp_path / "policy.json").read_text())
    assert doc["env_id"] == "RallySim/HumanLikeRallyTurn-v0"


def test_a_run_written_before_the_sections_and_player_rename_resumes(tmp_path):
    """A run folder written before the configuration had sections (flat config.yaml with
    ``env: humanlike``; its checkpoint's network records ``env``) resumes where it stopped,
    from its own config.yaml with a larger budget; another player's run is refused."""
    import shutil
    from pathlib import Path

    run = tmp_path / "run"
    shutil.copytree(Path(__file__).parent / "data" / "old_run_humanlike_low", run)
    with pytest.warns(DeprecationWarning) as caught:
        config = load_config("low", run / "config.yaml", {"budget": 1024})
    assert "setting 'env' is deprecated: use 'player'" in [str(w.message) for w in caught]
    assert (config.player, config.ppo.net_arch, config.checkpoint_every) == (
        "humanlike", (8, 8), 512)
    old = run / "checkpoints" / "step_000000000512.json"
    with pytest.raises(ckpt.CheckpointMismatch, match="made with network"):
        ckpt.read_checkpoint(old, expect={"network": {**config.network(), "player": "simple"}})
    lines: list[str] = []
    curve = train_stage(config, run, progress=False, say=lines.append)
    assert "resuming low from step_000000000512.json (512 decisions done)" in lines
    # the old run's rollout row, then this run's: 16 envs x 32 steps each
    assert [r["steps"] for r in curve["rollouts"]] == [512, 1024]
    assert curve["steps"] == 1024 and curve["final"]["episodes"] == 4
    saved = json.loads(ckpt.latest_checkpoint(run).read_text())
    assert saved["network"] == config.network() and saved["network"]["player"] == "humanlike"
    assert saved["config"]["ppo"]["net_arch"] == [8, 8]
