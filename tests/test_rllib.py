"""The RLlib backend: env adapters, the PPO config mapping, the actor export, a local run."""

from __future__ import annotations

import json
import math
import subprocess
import sys

import numpy as np
import pytest

pytest.importorskip("ray")
pytest.importorskip("torch")

import torch
from ray.rllib.core.columns import Columns
from ray.rllib.utils.pre_checks.env import check_multiagent_environments

from rallysim.cli import main
from rallysim.envs.simple_rally_turn_v0 import raw_env as turn_env
from rallysim.envs.simple_rally_v0 import AGENTS, parallel_env
from rallysim.envs.simple_return_v0 import SimpleReturnEnv, SimpleReturnVectorEnv
from rallysim.policies.mlp import load_policy
from rallysim.rllib.envs import RallyMultiAgentEnv, TurnRallyMultiAgentEnv, make_return_env
from rallysim.rllib.export import actor_layers, export_module
from rallysim.rllib.ppo_config import build_ppo_config
from rallysim.train import stages
from rallysim.train.config import load_config


def build_module(stage: str = "low", **overrides):
    """A freshly initialised RLModule of the stage's PPO config (no Ray needed)."""
    torch.manual_seed(0)  # RLlib initialises the weights with torch's global generator
    config = load_config(stage, None, overrides)
    env = SimpleReturnEnv()
    spaces = (env.observation_space, env.action_space)
    spec = build_ppo_config(config, 0).get_rl_module_spec(
        spaces={"__env__": spaces, "default_policy": spaces})
    return spec.build()


def deterministic_actions(module, obs: np.ndarray) -> np.ndarray:
    """RLlib's own deterministic action: the action distribution's mode."""
    with torch.no_grad():
        out = module.forward_inference({Columns.OBS: torch.as_tensor(obs)})
        dist = module.get_inference_action_dist_cls().from_logits(
            out[Columns.ACTION_DIST_INPUTS])
        return dist.to_deterministic().sample().numpy()


def test_import_rallysim_does_not_import_ray():
    code = ("import sys, rallysim, rallysim.cli, rallysim.train, rallysim.rllib; "
            "print(sorted(m for m in sys.modules if m == 'ray' or m.startswith('ray.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True)
    assert out.stdout.strip() == "[]"


def test_missing_extra_says_what_to_install(monkeypatch, capsys):
    import rallysim.rllib

    monkeypatch.setattr(rallysim.rllib, "missing_packages", lambda: ["ray"])
    assert main(["train", "low", "--backend", "rllib", "--decisions", "10"]) == 2
    err = capsys.readouterr().err
    assert "rallysim[ray]" in err and "missing: ray" in err
    with pytest.raises(ImportError, match=r"rallysim\[ray\]"):
        rallysim.rllib.require_ray()
    # RLlib-only flags on the default backend are refused
    assert main(["train", "low", "--env-runners", "2"]) == 2


def test_config_maps_onto_rllib_ppo():
    low = load_config("low", None, {"ppo.target_kl": None})
    ppo = build_ppo_config(low, env_runners=4)
    assert ppo.lr == [[0, 3e-4], [2_000_000, 0.0]]  # anneal_lr: linear to 0 over the budget
    assert (ppo.gamma, ppo.lambda_, ppo.clip_param) == (0.99, 0.95, 0.2)
    assert (ppo.entropy_coeff, ppo.vf_loss_coeff, ppo.grad_clip) == (0.0, 0.5, 0.5)
    assert (ppo.num_epochs, ppo.minibatch_size) == (10, 1024)
    assert ppo.train_batch_size_per_learner == 256 * 16
    assert (ppo.num_env_runners, ppo.num_envs_per_env_runner) == (4, 64)
    assert ppo.use_kl_loss is False and math.isinf(ppo.vf_clip_param)
    assert ppo.gym_env_vectorize_mode == "vector_entry_point"
    assert ppo.seed == 0 and ppo.is_multi_agent is False

    mono = build_ppo_config(load_config("mono", None, {"ppo.target_kl": 0.02, "seed": 3}), 2)
    assert mono.is_multi_agent and mono.count_steps_by == "agent_steps"
    assert mono.num_envs_per_env_runner == 16  # 64 slots = 32 rallies over 2 runners
    assert mono.lr == 3e-4 and mono.use_kl_loss and mono.kl_target == 0.02 and mono.seed == 3
    assert mono.policy_mapping_fn("player_1", None) == "shared"
    assert build_ppo_config(load_config("high"), 0).num_envs_per_env_runner == 64


def test_export_equals_rlmodule_deterministic_actions(tmp_path):
    module = build_module()
    assert np.allclose(module.pi.log_std.detach().numpy(), -0.5)  # log_std_init as SB3
    with torch.no_grad():  # a non-trivial head (it starts small), so clipping matters too
        for p in module.pi.net.parameters():
            p.mul_(30.0)
        module.pi.log_std.copy_(torch.tensor([-0.3, -0.7, -1.1]))
    layers, activation, log_std = actor_layers(module)
    assert [w.shape for w, _ in layers] == [(64, 17), (64, 64), (3, 64)]
    assert activation == "tanh" and np.allclose(log_std, [-0.3, -0.7, -1.1])

    weights, meta = export_module(module, tmp_path / "low", "RallySim/SimpleReturn-v0",
                                  metadata={"backend": "rllib"})
    assert weights.name == "low.safetensors"
    spec = json.loads(meta.read_text())
    assert spec["architecture"]["sizes"] == [17, 64, 64, 3]
    assert spec["metadata"] == {"backend": "rllib"}
    policy = load_policy(tmp_path / "low")
    obs = np.random.default_rng(0).uniform(-1, 1, (500, 17)).astype(np.float32)
    expected = deterministic_actions(module, obs)
    got = policy(obs)
    # float32 throughout; torch and NumPy sum the products in different orders
    np.testing.assert_allclose(got, np.clip(expected, -1.0, 1.0), rtol=1e-5, atol=1e-5)
    assert 0.05 < np.mean(np.abs(expected) > 1.0) < 0.95  # some means were clipped
    np.testing.assert_allclose(policy.log_std, [-0.3, -0.7, -1.1], atol=1e-7)


def test_the_runner_reads_rllibs_counters_and_the_modules_actor():
    """``rallysim.rllib.runner`` without a cluster: the budget's units and the mean return from
    RLlib's result dicts, and a module's deterministic actor as the NumPy policy it exports."""
    from rallysim.rllib.runner import _decisions, _episode_return, module_policy

    low, mono = load_config("low"), load_config("mono")
    # single-agent: env steps (decisions); multi-agent: agent steps, summed over the agents
    assert _decisions(low, {"num_env_steps_sampled_lifetime": 4096,
                            "num_agent_steps_sampled_lifetime": 7}) == 4096
    assert _decisions(mono, {"num_env_steps_sampled_lifetime": 7,
                             "num_agent_steps_sampled_lifetime": {"a": 1000, "b": 24}}) == 1024
    assert _decisions(low, {}) == 0
    assert _episode_return(low, {"episode_return_mean": 0.25}) == 0.25
    assert _episode_return(mono, {"agent_episode_returns_mean": {"a": 1.0, "b": 4.0}}) == 2.5
    assert math.isnan(_episode_return(mono, {})) and math.isnan(_episode_return(low, {}))
    module = build_module()
    policy = module_policy(module)
    obs = np.random.default_rng(1).uniform(-1, 1, (64, 17)).astype(np.float32)
    np.testing.assert_allclose(policy(obs), np.clip(deterministic_actions(module, obs), -1, 1),
                               rtol=1e-5, atol=1e-5)
    np.testing.assert_allclose(policy.log_std, -0.5, atol=1e-7)


def test_export_refuses_a_shared_encoder():
    from ray.rllib.core.rl_module.rl_module import RLModuleSpec

    from rallysim.rllib.module import RallyPPOTorchRLModule

    env = SimpleReturnEnv()
    module = RLModuleSpec(module_class=RallyPPOTorchRLModule,
                          observation_space=env.observation_space,
                          action_space=env.action_space,
                          model_config={"fcnet_hiddens": [8], "vf_share_layers": True,
                                        "free_log_std": True}).build()
    with pytest.raises(TypeError, match="vf_share_layers=False"):
        actor_layers(module)


def test_return_env_is_natively_batched():
    vec = make_return_env({"num_envs": 8, "shuttle": "aero", "incoming": "mixed"})
    assert isinstance(vec, SimpleReturnVectorEnv) and vec.num_envs == 8
    assert vec.task.incoming == "mixed" and vec.metadata["autoreset_mode"].value == "NextStep"
    assert isinstance(make_return_env({}), SimpleReturnEnv)


def test_rally_adapter_replays_the_parallel_env():
    env = RallyMultiAgentEnv({"shuttle": "paper"})
    check_multiagent_environments(env)
    ref = parallel_env(shuttle="paper")
    obs, _ = env.reset(seed=11)
    ref_obs, _ = ref.reset(seed=11)
    assert list(obs) == list(AGENTS)
    rng = np.random.default_rng(0)
    total = 0.0
    for _ in range(400):
        act = {a: rng.uniform(-1, 1, 3).astype(np.float32) for a in AGENTS}
        obs, rew, term, trunc, _ = env.step(act)
        ref_obs, ref_rew, ref_term, ref_trunc, _ = ref.step(act)
        for a in AGENTS:
            np.testing.assert_array_equal(obs[a], ref_obs[a])
            assert rew[a] == ref_rew[a]
        total += sum(rew.values())
        if term["__all__"] or trunc["__all__"]:
            assert all(ref_term.values()) or all(ref_trunc.values())
            obs, _ = env.reset(seed=12)
            ref_obs, _ = ref.reset(seed=12)
    assert total >= 0.0


@pytest.mark.slow
def test_turn_adapter_plays_turns_with_goals_from_unit_actions():
    env = TurnRallyMultiAgentEnv({"low_policy": "scripted"})
    check_multiagent_environments(env)
    ref = turn_env(low_level="scripted")
    obs, _ = env.reset(seed=5)
    ref.reset(seed=5)
    assert list(obs) == [ref.agent_selection] == ["player_0"]  # the serve comes to player 0
    rng = np.random.default_rng(1)
    rallies, turns, hits = 0, 0, 0.0
    while rallies < 3:
        agent = next(iter(obs))
        a = rng.uniform(-1, 1, 1).astype(np.float32)
        obs, rew, term, trunc, infos = env.step({agent: a})
        ref.step(4.0 + 2.0 * a)  # the adapter's goal mapping, as the SB3 high stage's
        turns += 1
        assert rew == {p: ref.rewards[p] for p in AGENTS}
        hits += rew["player_0"]
        if term["__all__"] or trunc["__all__"]:
            assert set(obs) == set(AGENTS)  # both see the end
            rallies += 1
            obs, _ = env.reset(seed=5 + rallies)
            ref.reset(seed=5 + rallies)
        else:
            assert list(obs) == [ref.agent_selection] and agent not in obs  # turns alternate
            np.testing.assert_array_equal(obs[ref.agent_selection],
                                          ref.observe(ref.agent_selection))
            assert infos[ref.agent_selection]["decisions"] >= 1
    assert turns > 3 and hits > 0.0  # the scripted low level hits: +0.2 per hit to both


@pytest.fixture(scope="module")
def local_ray():
    import ray

    ray.init(num_cpus=2, include_dashboard=False, logging_level="ERROR", log_to_driver=False)
    yield
    ray.shutdown()


@pytest.mark.slow  # trains
def test_local_training_writes_a_policy_that_evaluate_reads(local_ray, tmp_path, capsys):
    out = tmp_path / "low"
    args = ["train", "low", "--backend", "rllib", "--env-runners", "1", "--budget", "8000",
            "--out", str(out), "--set", "ppo.n_envs=32", "ppo.n_steps=64",
            "ppo.batch_size=512", "eval.episodes=64", "checkpoint_every=4000",
            "ppo.anneal_lr=false"]
    assert main(args) == 0
    curve = json.loads((out / "curve.json").read_text())
    assert curve["backend"] == "rllib" and curve["steps"] >= 8000
    rows = curve["iterations"]
    assert len(rows) == 4 and all(r["decisions"] - p["decisions"] >= 2048
                                  for p, r in zip([{"decisions": 0}, *rows], rows, strict=False))
    assert sorted(p.name for p in (out / "checkpoints").iterdir()) == [
        f"policy_step_{rows[i]['decisions']}.{ext}" for i in (1, 3) for ext in
        ("json", "safetensors")]
    # The exported file reproduces the run's final evaluation exactly.
    config = load_config("low", None, {"eval.episodes": 64})
    again = stages.evaluate(config, load_policy(out / "policy"))
    assert again == {k: v for k, v in curve["final"].items() if k in again}
    spec = json.loads((out / "policy.json").read_text())
    assert spec["metadata"]["backend"] == "rllib" and spec["env_id"] == "RallySim/SimpleReturn-v0"
    capsys.readouterr()
    assert main(["evaluate", "--low", str(out / "policy"), "--rallies", "4", "--seeds", "1"]) == 0
    assert "HRL" in capsys.readouterr().out


@pytest.mark.slow  # trains
@pytest.mark.parametrize("stage", ["mono", "high"])
def test_multi_agent_stages_count_decisions_of_both_players(local_ray, tmp_path, stage):
    from rallysim.rllib.runner import train_stage_rllib

    small = {"ppo.n_envs": 8, "ppo.n_steps": 64, "ppo.batch_size": 256, "budget": 1024,
             "eval.episodes": 4}
    if stage == "high":
        small["low_policy"] = "scripted"
    config = load_config(stage, None, small)
    curve = train_stage_rllib(config, tmp_path / stage, env_runners=1, progress=False)
    first = curve["iterations"][0]
    assert 512 <= first["decisions"] <= 512 + 64  # n_envs x n_steps agent steps per update
    assert math.isfinite(first["ep_rew_mean"]) and first["ep_rew_mean"] >= 0.0
    assert curve["final"]["rallies"] == 4
    policy = load_policy(tmp_path / stage / "policy")
    assert policy.obs_size == 20 and policy.layers[-1][0].shape[0] == (1 if stage == "high"
                                                                        else 3)
