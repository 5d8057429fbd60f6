"""experiments/reference_returns.py: seeded runs of PPO and SAC on the tasks, pooled into the
table docs/rl-alone.md renders."""

from __future__ import annotations

import numpy as np
import pytest

from experiments.reference_returns import TASKS, pool, render, run_one


@pytest.mark.slow  # trains
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


def _fixed_aim_episode(goal: float, seed: int = 3, envs: int = 32):
    """Each env's first episode under the goal view, the scripted controller aiming at 4 m
    whatever the env's goal (so the play is the same for every goal): per step the rewards,
    the achieved goals of the next observations (terminal ones at the end), the infos."""
    from experiments.reference_returns import NO_LANDING, GoalReturnVecEnv
    from rallysim.policies import ScriptedController
    from rallysim.sb3 import make_vec_env

    env = GoalReturnVecEnv(make_vec_env("RallySim/SimpleReturn-v0", n_envs=envs, seed=seed))
    env.set_options({"target_depth": goal})
    aim = ScriptedController()
    obs = env.reset()
    done = np.zeros(envs, bool)
    steps = []
    while not done.all():
        flat = np.concatenate([obs["observation"], obs["desired_goal"]], axis=1)
        obs, reward, dones, infos = env.step(aim(flat, np.full(envs, 4.0)))
        # a live observation never carries a landing: only the terminal one does
        assert (obs["achieved_goal"] == NO_LANDING).all()
        achieved = obs["achieved_goal"].copy()
        for e in np.flatnonzero(dones):
            achieved[e] = infos[e]["terminal_observation"]["achieved_goal"]
        steps.append((reward.copy(), achieved, infos, done.copy()))
        done |= dones
    return env, steps


def test_the_goal_view_relabels_with_the_envs_own_reward():
    """Hindsight relabelling's reward function: the same play (aimed at 4 m) under goal 3 m
    and under goal 5 m; ``compute_reward`` of the 3 m play's achieved goals for the 5 m goal
    gives, step by step, the reward the env itself gave the 5 m play. A shot that landed in
    court has its landing depth, scaled like the goal, as the achieved goal."""
    from experiments.reference_returns import NO_LANDING

    env, at3 = _fixed_aim_episode(3.0)
    _, at5 = _fixed_aim_episode(5.0)
    assert len(at3) == len(at5)
    landings = 0
    five = np.full((32, 1), (5.0 - 4.0) / 2.0, np.float32)
    for (r3, achieved, infos, before), (r5, _, _, _) in zip(at3, at5, strict=True):
        live = ~before  # envs still in their first episode
        np.testing.assert_allclose(env.compute_reward(achieved, five, infos)[live], r5[live],
                                   atol=1e-6)
        three = np.full((32, 1), -0.5, np.float32)
        np.testing.assert_allclose(env.compute_reward(achieved, three, infos)[live], r3[live],
                                   atol=1e-6)
        for e in np.flatnonzero(live & (achieved[:, 0] > NO_LANDING)):
            landings += 1
            assert achieved[e, 0] == pytest.approx((infos[e]["landing_depth"] - 4.0) / 2.0)
    assert landings >= 20
    assert not np.allclose(sum(r[0] for r in at3), sum(r[0] for r in at5))  # goals mattered


@pytest.mark.slow  # trains
def test_sac_with_hindsight_relabelling_runs_at_smoke_scale():
    run = run_one("SimpleReturn-v0", "SAC+HER", 0, 1e-6, 8)
    assert run["steps"] == 1280 and len(run["returns"]) == 8  # 640 random, then updates
    assert set(run["scores"]) == {"hit_rate", "median_landing_error", "goal_correlation"}
    with pytest.raises(ValueError, match="goal to relabel"):
        run_one("SimpleRally-v0 (parallel)", "SAC+HER", 0, 1e-6, 8)


@pytest.mark.slow  # trains
def test_random_actions_are_the_floor_row():
    run = run_one("SimpleRallyTurn-v1", "random", 0, 1.0, 4)
    assert run["steps"] == 0 and len(run["returns"]) == 4
    assert run == run_one("SimpleRallyTurn-v1", "random", 0, 1.0, 4)  # seeded
