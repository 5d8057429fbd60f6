"""Training's cheaper PyTorch settings change no bit of training, and reproduce's scheduler
starts the longest chains of work first."""

from __future__ import annotations

import contextlib

import pytest

torch = pytest.importorskip("torch")
pytest.importorskip("stable_baselines3")

from rallysim.train import runner, torch_speed  # noqa: E402
from rallysim.train.config import load_config  # noqa: E402
from rallysim.train.reproduce import SEED_STEPS, next_seed  # noqa: E402
from rallysim.train.runner import build_model, train_stage  # noqa: E402


def test_ppo_keeps_sb3s_adam_epsilon_and_steps_all_tensors_at_once(tmp_path):
    # passing optimizer_kwargs replaces SB3's own {"eps": 1e-5}: it must be restated
    model = build_model(load_config("low", None, {"ppo.n_envs": 8, "ppo.n_steps": 4,
                                                  "ppo.batch_size": 16}), tmp_path)
    group = model.policy.optimizer.param_groups[0]
    assert group["eps"] == 1e-5 and group["foreach"] is True


def test_distribution_checks_come_back_after_the_block():
    from torch.distributions import Distribution, Normal

    before = Distribution._validate_args
    with torch_speed.no_distribution_checks():
        # unchecked: a negative scale is not refused inside the block
        Normal(torch.zeros(1), -torch.ones(1))
    assert Distribution._validate_args == before
    if before:
        with pytest.raises(ValueError):
            Normal(torch.zeros(1), -torch.ones(1))


def _tiny_run(tmp_path, name: str) -> str:
    from rallysim.policies.mlp import sha256_file

    config = load_config("low", None, {
        "seed": 5, "warm_start.teacher": "scripted", "warm_start.decisions": 2048,
        "warm_start.epochs": 2, "warm_start.batch_size": 256, "ppo.n_envs": 32,
        "ppo.n_steps": 16, "ppo.batch_size": 128, "budget": 2048, "eval.every": 0,
        "eval.episodes": 8, "checkpoint_every": 10**6})
    train_stage(config, tmp_path / name, progress=False)
    return sha256_file(tmp_path / name / "policy.safetensors")


@pytest.mark.slow  # trains
def test_the_faster_settings_train_bit_identical_weights(tmp_path, monkeypatch):
    """Warm start and PPO with foreach Adam and no distribution checks, then with Adam's
    per-tensor loop and the checks on: the same weights, bit for bit."""
    fast = _tiny_run(tmp_path, "fast")
    monkeypatch.setitem(torch_speed.ADAM_KWARGS, "foreach", False)
    monkeypatch.setitem(torch_speed.SB3_ADAM_KWARGS, "foreach", False)
    monkeypatch.setattr(runner, "no_distribution_checks", contextlib.nullcontext)
    assert _tiny_run(tmp_path, "slow") == fast


def test_the_seed_with_most_steps_left_starts_first():
    # three seeds, two workers: seeds 0 and 1 trained their low levels; seed 2's low level
    # (four steps left) goes before seed 0's high level (three left)
    assert next_seed({0, 2}, {0: 1, 1: 1, 2: 0}) == 2
    assert next_seed({0, 1}, {0: 2, 1: 2}) == 0  # equals: the lowest seed
    assert SEED_STEPS == ("low", "high", "mono", "evaluate")
