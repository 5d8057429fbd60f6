"""Low-level training: the SB3 adapter, a seeded smoke run of PPO, the weights export."""

from __future__ import annotations

import json
import warnings

import numpy as np
import pytest

pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")
pytest.importorskip("safetensors")

from stable_baselines3 import PPO

from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv
from rallysim.eval.low_eval import evaluate_return
from rallysim.policies.mlp import load_policy
from rallysim.train.config import load_config
from rallysim.train.export import save_policy
from rallysim.train.runner import train_stage
from rallysim.train.sb3_vec import NativeVecEnv
from rallysim.train.stages import make_env

SMOKE_DECISIONS = 98_304  # 48 updates, about 7 s on two cores
SMOKE = load_config("low", None, {"ppo": {"n_envs": 32, "n_steps": 64, "batch_size": 512,
                                          "n_epochs": 10, "anneal_lr": False},
                                  "eval": {"episodes": 256, "every": 0},
                                  "budget": SMOKE_DECISIONS, "checkpoint_every": 10**9})


def deterministic(model):
    return lambda obs: model.predict(obs, deterministic=True)[0]


def test_adapter_follows_sb3_conventions():
    n = 16
    venv = NativeVecEnv(SimpleReturnVectorEnv(n, autoreset_mode="same_step"))
    venv.seed(3)
    obs = venv.reset()
    assert obs.shape == (n, 17) and obs.dtype == np.float32
    assert venv.get_attr("render_mode") == [None] * n
    assert venv.env_is_wrapped(object, indices=[0, 1]) == [False, False]
    rng = np.random.default_rng(0)
    returns = np.zeros(n)
    seen = 0
    for _ in range(120):
        obs, reward, dones, infos = venv.step(rng.uniform(-1, 1, (n, 3)).astype(np.float32))
        assert len(infos) == n and dones.dtype == bool and reward.dtype == np.float32
        returns += reward
        for e in range(n):
            if dones[e]:
                info = infos[e]
                assert info["terminal_observation"].shape == (17,)
                assert not np.array_equal(info["terminal_observation"], obs[e])
                assert info["TimeLimit.truncated"] is False  # serves always land in time
                assert info["episode"]["r"] == pytest.approx(returns[e], abs=1e-4)
                assert {"hit", "landing_error", "target_depth"} <= set(info)
                returns[e] = 0.0
                seen += 1
            else:
                assert infos[e] == {}
    assert seen > 2 * n

    # Same seed, same episodes; a same-step env is required.
    again = NativeVecEnv(SimpleReturnVectorEnv(n, autoreset_mode="same_step"))
    again.seed(3)
    np.testing.assert_array_equal(again.reset(), NativeVecEnv(
        SimpleReturnVectorEnv(n, autoreset_mode="same_step", seed=3)).reset())
    with pytest.raises(ValueError, match="same_step"):
        NativeVecEnv(SimpleReturnVectorEnv(n))


def test_adapter_truncation_is_flagged():
    venv = NativeVecEnv(SimpleReturnVectorEnv(4, max_decisions=3, autoreset_mode="same_step"))
    venv.seed(0)
    venv.reset()
    zero = np.zeros((4, 3), np.float32)
    for _ in range(2):
        _, _, dones, _ = venv.step(zero)
        assert not dones.any()
    _, _, dones, infos = venv.step(zero)
    assert dones.all()
    assert all(i["TimeLimit.truncated"] and i["episode"]["l"] == 3 for i in infos)


def test_quiet_training_on_the_paper_task_prints_nothing_on_stderr(tmp_path, capsys):
    from rallysim.cli import main
    from rallysim.sb3 import make_vec_env

    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        assert main(["train", "low", "--quiet", "--out", str(tmp_path), "--budget", "1024",
                     "--set", "ppo.n_envs=16", "ppo.n_steps=32", "ppo.batch_size=256",
                     "eval.episodes=4", "warm_start.decisions=1024"]) == 0
    assert [str(w.message) for w in caught if "out of date" in str(w.message)] == []
    assert capsys.readouterr().err == ""
    # the stage's config chose v0 (the paper's task); a user who makes it still hears
    # Gymnasium's advice
    with pytest.warns(DeprecationWarning, match="SimpleReturn-v0 is out of date"):
        make_vec_env("RallySim/SimpleReturn-v0", n_envs=1).close()


@pytest.mark.slow  # trains
def test_smoke_training_improves_over_untrained_policy(tmp_path):
    untrained = PPO("MlpPolicy", make_env(SMOKE), seed=0, device="cpu", **SMOKE.ppo_kwargs())
    before = evaluate_return(deterministic(untrained), episodes=SMOKE.eval.episodes,
                             seed=SMOKE.eval.seed)
    stats = train_stage(SMOKE, tmp_path / "a", progress=False)
    after = stats["final"]
    assert stats["steps"] == SMOKE_DECISIONS
    # Untrained: about 0.06 (the serve mostly falls past the racket); trained: 0.8-1.0 (it hits
    # nearly every serve, not yet over the net) for seeds 0-2.
    assert after["mean_reward"] > before.mean_reward + 0.6
    assert after["hit_rate"] > before.hit_rate + 0.5

    # Seeded runs are deterministic.
    short = load_config("low", None, {**SMOKE.to_dict(), "budget": 4096})
    first = train_stage(short, tmp_path / "b", progress=False)
    again = train_stage(short, tmp_path / "c", progress=False)
    assert again["final"]["mean_reward"] == first["final"]["mean_reward"]


def test_save_load_round_trip(tmp_path):
    model = PPO("MlpPolicy", make_env(SMOKE), seed=1, device="cpu", **SMOKE.ppo_kwargs())
    with __import__("torch").no_grad():  # make the head non-trivial (it starts near zero)
        for p in model.policy.action_net.parameters():
            p.mul_(100.0)
    weights, meta = save_policy(model, tmp_path / "low", metadata={"note": "test"})
    assert weights.name == "low.safetensors" and meta.name == "low.json"
    spec = json.loads(meta.read_text())
    assert spec["architecture"]["sizes"] == [17, 64, 64, 3]
    assert spec["architecture"]["activation"] == "tanh"
    assert spec["metadata"] == {"note": "test"} and len(spec["weights_sha256"]) == 64

    policy = load_policy(tmp_path / "low")
    obs = np.random.default_rng(0).uniform(-1, 1, (300, 17)).astype(np.float32)
    expected = model.predict(obs, deterministic=True)[0]
    actions = policy(obs)
    assert actions.shape == (300, 3)
    assert np.abs(expected).max() > 0.5 and (np.abs(expected) == 1.0).any()  # clipping tested
    np.testing.assert_allclose(actions, expected, atol=1e-5)  # float32 sums in another order
    np.testing.assert_allclose(policy(obs[0]), actions[0], atol=1e-6)
    np.testing.assert_array_equal(policy.log_std, model.policy.log_std.detach().numpy())

    # Loading twice gives the very same actions.
    again = load_policy(tmp_path / "low")
    np.testing.assert_array_equal(again(obs), actions)


@pytest.mark.slow  # trains
def test_warm_started_training_is_bit_identical_per_seed(tmp_path):
    """The default pipeline's low stage (clone of the scripted controller, then PPO) on a
    tiny budget, twice with one seed: identical weights; another seed: different ones."""
    from rallysim.policies.mlp import sha256_file

    def run(seed: int, name: str) -> str:
        config = load_config("low", None, {
            "seed": seed, "warm_start.teacher": "scripted", "warm_start.decisions": 4096,
            "warm_start.epochs": 2, "ppo.n_envs": 32, "ppo.n_steps": 16,
            "ppo.batch_size": 256, "budget": 2048, "eval.every": 0, "eval.episodes": 16,
            "checkpoint_every": 1024})
        curve = train_stage(config, tmp_path / name, progress=False)
        assert curve["warm_start"]["samples"] > 0
        return sha256_file(tmp_path / name / "policy.safetensors")

    first = run(3, "a")
    assert run(3, "b") == first
    assert run(4, "c") != first


def test_a_short_behaviour_clone_moves_the_actor_toward_the_teacher(tmp_path):
    """The warm start alone (rallysim.train.warm_start), on a budget the fast tier affords:
    16,384 decisions of the scripted controller, 4 epochs, no DAgger."""
    from rallysim.train import stages
    from rallysim.train.runner import build_model, warm_start

    config = load_config("low", None, {
        "ppo.n_envs": 16, "ppo.n_steps": 32, "ppo.batch_size": 256, "eval.episodes": 16,
        "warm_start.teacher": "scripted", "warm_start.decisions": 16384,
        "warm_start.epochs": 4, "warm_start.batch_size": 256, "warm_start.dagger": 0})
    model = build_model(config, tmp_path)
    teacher, name = stages.of(config).teacher(config)
    obs, _ = SimpleReturnVectorEnv(64, seed=99).reset(seed=99)
    target = teacher(obs)

    def error() -> float:
        return float(np.mean((deterministic(model)(obs) - target) ** 2))

    before = error()
    result = warm_start(model, config, progress=False)
    assert result["teacher"] == name == "ScriptedController"
    # the finished episodes' decisions (11,586 here), not those still in flight at the end
    assert 0.5 * 16384 < result["samples"] <= 16384
    assert np.isfinite(result["actor_mse"]) and np.isfinite(result["critic_mse"])
    assert error() < 0.5 * before  # 0.81 before, 0.31 after


def test_the_warm_start_fits_its_critic_to_the_task_ppo_trains_on():
    """The SIMPLE task's reward options reach the warm start's env: the clone's critic is fitted
    to the returns of the task PPO then trains on (returnable adds to them), and the clone's
    labels and observations are the same either way."""
    from rallysim.policies import ScriptedController
    from rallysim.train.stages.low import LOW
    from rallysim.train.warm_start import teacher_dataset

    plain_cfg = load_config("low", None, {})
    cfg = load_config("low", None, {"returnable": 0.5, "ready": 0.25})
    assert LOW.clone_task(plain_cfg).options == {}
    assert LOW.clone_task(cfg).options == {"returnable": 0.5, "ready": 0.25}
    assert LOW.make_env(cfg).venv.task.returnable == 0.5  # what PPO trains on
    teacher = ScriptedController().act_return
    plain = teacher_dataset(teacher, LOW.clone_task(plain_cfg), 16, 1_024, 0.99, seed=3)
    extra = teacher_dataset(teacher, LOW.clone_task(cfg), 16, 1_024, 0.99, seed=3)
    assert np.array_equal(plain[0], extra[0]) and np.array_equal(plain[1], extra[1])
    gain = extra[2] - plain[2]
    assert gain.min() >= 0.0 and gain.mean() > 0.2
