"""benchmarks/reference_returns.py: seeded runs of PPO and SAC on the tasks, pooled into the
table docs/rl-alone.md renders."""

from __future__ import annotations

import numpy as np
import pytest

from rallysim.train.reference_returns import TASKS, pool, render, run_one


def test_a_run_is_seeded_and_scores_its_task():
    """PPO on SimpleReturn-v0 for its smallest budget (two rollouts of the low stage's 256 x
    16): the same seed gives the same returns; the task's own measures come with them."""
    first = run_one("SimpleReturn-v0", "PPO", 0, 1e-6, 16)
    again = run_one("SimpleReturn-v0", "PPO", 0, 1e-6, 16)
    assert first["steps"] == 2 * 256 * 16
    assert len(first["returns"]) == 16 and first["returns"] == again["returns"]
    assert set(first["scores"]) == {"hit_rate", "median_landing_error", "goal_correlation"}
    assert 0.0 <= first["scores"]["hit_rate"] <= 1.0
    # each episode is one serve: at most 1 of hit and landing reward plus a little shaping
    assert max(first["returns"]) < 2.0 and min(first["lengths"]) >= 1


def test_sac_on_the_parallel_rally_plays_one_rally_per_pair_of_slots():
    run = run_one("SimpleRally-v0 (parallel)", "SAC", 1, 1e-6, 8)
    assert run["steps"] == 64 and run["scores"] == {}
    lengths = np.array(run["lengths"])
    assert len(lengths) == 8
    # the two players of a rally end together
    assert (lengths[0::2] == lengths[1::2]).all()


def test_pool_and_render():
    runs = [{"task": "SimpleRallyTurn-v1", "algo": "PPO", "seed": s, "steps": 4096,
             "unit": "turns", "train_wall_s": 10.0 + s, "returns": [float(s), float(s) + 2],
             "lengths": [3, 5], "scores": {}} for s in range(3)]
    (row,) = pool(runs)
    assert row["mean_return"]["value"] == pytest.approx(2.0)
    assert row["per_seed_return"] == [1.0, 2.0, 3.0]
    assert row["mean_length"]["value"] == pytest.approx(4.0)
    assert row["mean_return"]["low"] <= 2.0 <= row["mean_return"]["high"]
    table = render({"episodes": 2, "rows": [row]})
    assert "| SimpleRallyTurn-v1 | PPO | 4,096 turns | 2.00 [" in table
    assert "1.00 / 2.00 / 3.00" in table and "10 / 11 / 12" in table


def test_every_task_builds_its_env():
    for task in TASKS:
        env = task.make_env(4, 0)
        assert env.num_envs == 4
        env.close()


def test_the_goal_view_recomputes_the_task_reward():
    """Hindsight relabelling's reward function: for the goal the env drew it gives the reward
    the env gave, on every step (the scripted controller lands most shots, so the landing term
    is tested); at a landing, the achieved goal is the landing depth, scaled like the goal."""
    from rallysim.policies import ScriptedController
    from rallysim.sb3 import make_vec_env
    from rallysim.train.reference_returns import NO_LANDING, GoalReturnVecEnv

    env = GoalReturnVecEnv(make_vec_env("RallySim/SimpleReturn-v0", n_envs=32, seed=3))
    controller = ScriptedController()
    obs = env.reset()
    landings = 0
    for _ in range(60):
        flat = np.concatenate([obs["observation"], obs["desired_goal"]], axis=1)
        obs, reward, dones, infos = env.step(controller.act_return(flat))
        achieved = obs["achieved_goal"].copy()
        for e in np.flatnonzero(dones):
            achieved[e] = infos[e]["terminal_observation"]["achieved_goal"]
        desired = obs["desired_goal"].copy()
        for e in np.flatnonzero(dones):
            desired[e] = infos[e]["terminal_observation"]["desired_goal"]
        np.testing.assert_allclose(env.compute_reward(achieved, desired, infos), reward,
                                   atol=1e-6)
        for e in np.flatnonzero(dones):
            if infos[e]["reward_landing"] > 0:
                landings += 1
                assert achieved[e, 0] == pytest.approx((infos[e]["landing_depth"] - 4) / 2)
            else:
                assert achieved[e, 0] == NO_LANDING
    assert landings > 20
    # relabelled to where the shot landed, the landing term is its maximum, 1
    e = next(e for e in range(32) if achieved[e, 0] > NO_LANDING)
    assert env.env_method("compute_reward", achieved[e:e + 1], achieved[e:e + 1],
                          [{"reward_free": 0.0}])[0][0] == pytest.approx(1.0)
