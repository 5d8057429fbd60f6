"""The high stage's goal sweep: fixed-goal rallies over the frozen low level, the best goal as
PPO's starting mean, and its cost counted in the decisions the high stage simulated."""

from __future__ import annotations

import numpy as np
import pytest

from rallysim.eval.rally_eval import play_turns, rally_lengths_turns
from rallysim.players import HUMANLIKE, SIMPLE
from rallysim.train.goal_sweep import SWEEP_SEED_OFFSET, action_grid, grid_step, sweep_goals


def test_action_grid_spans_the_action_box():
    assert action_grid(5, 1)[:, 0].tolist() == [-1.0, -0.5, 0.0, 0.5, 1.0]
    grid = action_grid(3, 3)
    assert grid.shape == (27, 3)
    assert len({tuple(row) for row in grid}) == 27 and grid.min() == -1 and grid.max() == 1


def test_fixed_goals_play_as_a_high_level_that_always_picks_them():
    """An array of per-rally goals is the same as a high level choosing that goal each turn,
    and the cost counts every low-level decision and every turn."""
    lengths, decisions, turns = play_turns(np.full(3, 3.0), "scripted", 3, seed=4)
    same = rally_lengths_turns(lambda obs: np.full(len(obs), 3.0), "scripted", 3, seed=4)
    assert lengths.tolist() == same.tolist()
    # a rally lost after L hits has L + 1 turns, one capped at 50 hits ends on its 50th
    assert turns == int((lengths + (lengths < 50)).sum())
    assert decisions > 5 * turns


def test_the_sweep_picks_the_goal_with_the_longest_rallies():
    sweep = sweep_goals(SIMPLE, "scripted", 5, 2, seed=2)
    assert len(sweep["actions"]) == 5 and sweep["rallies_per_goal"] == 2
    means = np.array(sweep["mean_rally"])
    assert sweep["best_action"] == sweep["actions"][int(np.argmax(means))]
    assert sweep["best_mean_rally"] == means.max() > means.min()
    # each goal's mean is that of rallies played at it, on the sweep's own seed stream
    goals = SIMPLE.goal.from_action(np.repeat(action_grid(5, 1), 2, axis=0))
    lengths, decisions, turns = play_turns(goals, "scripted", 10, 2 + SWEEP_SEED_OFFSET)
    assert np.allclose(lengths.reshape(5, 2).mean(axis=1), means)
    assert (sweep["decisions"], sweep["turns"]) == (decisions, turns)


@pytest.mark.slow
def test_the_sweep_takes_three_dimensional_goals():
    sweep = sweep_goals(HUMANLIKE, "scripted", 2, 1, seed=0)
    assert np.array(sweep["actions"]).shape == (8, 3) and len(sweep["mean_rally"]) == 8


def test_a_sweep_needs_two_points_and_one_rally():
    with pytest.raises(ValueError, match="points >= 2 and rallies >= 1"):
        sweep_goals(SIMPLE, "scripted", 1, 4, seed=0)


@pytest.mark.slow
def test_the_high_stage_starts_at_the_swept_goal_and_counts_its_decisions(tmp_path):
    pytest.importorskip("stable_baselines3")
    from rallysim.train.config import load_config
    from rallysim.train.runner import build_model, train_stage

    overrides = {"ppo.n_envs": 8, "ppo.n_steps": 8, "ppo.batch_size": 64, "ppo.n_epochs": 1,
                 "eval.episodes": 8, "eval.every": 0, "checkpoint_every": 1024,
                 "budget": 64, "low_policy": "scripted", "goal_sweep": 2,
                 "goal_sweep_points": 5}
    config = load_config("high", None, overrides)
    model = build_model(config, tmp_path / "probe")
    from rallysim.train.stages import of

    sweep = of(config).start(config, model)
    assert sweep is not None
    obs = np.zeros((3, 20), np.float32)
    mean, _ = model.predict(obs, deterministic=True)
    assert np.allclose(mean, sweep["best_action"][0], atol=0.05)
    # one grid step wide: exploration covers the goals between the sweep's neighbours
    assert np.allclose(model.policy.log_std.detach().numpy(), np.log(grid_step(5)))
    assert grid_step(5) == 0.5 and grid_step(9) == 0.25

    curve = train_stage(config, tmp_path / "run", progress=False)
    assert curve["start"] == sweep
    without = train_stage(load_config("high", None, {**overrides, "goal_sweep": 0}),
                          tmp_path / "plain", progress=False)
    assert "start" not in without
    # the sweep's decisions are counted beside the turns' own
    assert curve["decisions_simulated"] - sweep["decisions"] > curve["steps"]
    with pytest.raises(ValueError, match="goal_sweep applies to the high stage only"):
        load_config("low", None, {"goal_sweep": 4})
