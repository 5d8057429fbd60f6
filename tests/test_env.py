"""RallySim/SimpleReturn-v0: API, rewards, determinism, bad input (docs/reference.md §6,
issue #2)."""

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import rallysim  # noqa: F401  (registers the envs)
from rallysim.envs.simple_return_v0 import SimpleReturnEnv, SimpleReturnVectorEnv
from rallysim.eval.low_eval import evaluate_return
from rallysim.policies import ScriptedController
from tests.conftest import check_seeded_and_batched


def test_registered_and_checked():
    env = gym.make("RallySim/SimpleReturn-v0")
    assert env.observation_space.shape == (17,) and env.action_space.shape == (3,)
    # "human" is listed but needs a display; rgb_array rendering is checked in test_env_render
    check_env(env.unwrapped, skip_render_check=True)
    vec = gym.make_vec("RallySim/SimpleReturn-v0", num_envs=4)
    assert isinstance(vec, SimpleReturnVectorEnv) and vec.num_envs == 4


def test_observations_stay_in_bounds_under_random_play():
    env = SimpleReturnVectorEnv(64, seed=1)
    obs, _ = env.reset(seed=1)
    rng = np.random.default_rng(0)
    for _ in range(300):
        assert obs.dtype == np.float32 and obs.shape == (64, 17)
        assert np.all(obs >= -1) and np.all(obs <= 1)
        obs, *_ = env.step(rng.uniform(-3, 3, (64, 3)))


def test_same_seed_same_trajectory_and_vector_matches_single():
    actions = np.random.default_rng(0).uniform(-1, 1, (40, 3, 3))
    check_seeded_and_batched(SimpleReturnEnv, SimpleReturnVectorEnv, actions)


def test_bad_actions_raise_and_leave_state_untouched():
    env = SimpleReturnVectorEnv(2, seed=0)
    env.reset(seed=0)
    game = env.task.game
    before = (game.shuttle.pos.copy(), game.bodies.theta.copy(), env.task.elapsed.copy())
    for bad, word in [(np.full((2, 3), np.nan), "NaN"), (np.array([[np.inf, 0, 0], [0, 0, 0]]),
                      "inf"), (np.zeros((2, 4)), "shape"), (np.zeros(3), "shape"),
                      ("left", "real numbers")]:
        with pytest.raises(ValueError, match=word):
            env.step(bad)
    assert np.array_equal(before[0], game.shuttle.pos)
    assert np.array_equal(before[1], game.bodies.theta)
    assert np.array_equal(before[2], env.task.elapsed)
    single = SimpleReturnEnv()
    single.reset(seed=0)
    with pytest.raises(ValueError, match="NaN"):
        single.step([np.nan, 0, 0])


def test_out_of_range_actions_are_clipped():
    a = SimpleReturnEnv()
    b = SimpleReturnEnv()
    a.reset(seed=3)
    b.reset(seed=3)
    oa = a.step([5.0, -7.0, 2.0])[0]
    ob = b.step([1.0, -1.0, 1.0])[0]
    assert np.array_equal(oa, ob)


def test_unknown_options_and_models_list_the_valid_ones():
    env = SimpleReturnEnv()
    with pytest.raises(ValueError, match="target_depth"):
        env.reset(options={"goal": 3.0})
    with pytest.raises(ValueError, match=r"\[2, 6\]"):
        env.reset(options={"target_depth": 9.0})
    with pytest.raises(ValueError, match="'paper', 'paper-alg1', 'aero'"):
        SimpleReturnEnv(shuttle="wind")
    with pytest.raises(ValueError, match="same_step"):
        SimpleReturnVectorEnv(2, autoreset_mode="sometimes")


def test_goal_is_settable_and_observed():
    env = SimpleReturnEnv()
    obs, info = env.reset(seed=0, options={"target_depth": 5.0, "base_x": -2.0, "arm_angle": 0.0})
    assert info["target_depth"] == 5.0
    assert obs[16] == pytest.approx(0.5)  # (5 - 4) / 2
    assert obs[0] == pytest.approx(-0.2)  # -2 m / 10
    vec = SimpleReturnVectorEnv(3)
    obs, _ = vec.reset(seed=0, options={"target_depth": [2.0, 4.0, 6.0]})
    assert obs[:, 16] == pytest.approx([-1.0, 0.0, 1.0])


def test_shaping_reward_values():
    env = SimpleReturnEnv()
    env.reset(seed=0, options={"base_x": -4.0, "arm_angle": 0.0})
    # toward the shuttle (it starts at x > 0): 5 physics steps closing in -> +0.001 each
    r = env.step([0.0, -1.0, 1.0])[1]
    assert r == pytest.approx(5 * 0.001)
    env.reset(seed=0, options={"base_x": -4.0, "arm_angle": 0.0})
    r = env.step([0.0, -1.0, 0.0])[1]  # standing still: -0.005 each
    assert r == pytest.approx(5 * -0.005)
    env.reset(seed=0, options={"base_x": -6.5, "arm_angle": 0.0})
    r = env.step([0.0, -1.0, -1.0])[1]  # pushing against the back of its range: not moving
    assert r == pytest.approx(5 * -0.005)
    # retreating slower than the serve approaches still closes the gap: +0.001 each
    env.reset(seed=0, options={"base_x": -4.0, "arm_angle": 0.0})
    r = env.step([0.0, -1.0, -1.0])[1]
    assert r == pytest.approx(5 * 0.001)


def landing_case(depth_goal, land_x, net=False, hit=True):
    """Put a hit shuttle just above the floor so that it lands at ``land_x`` this decision."""
    env = SimpleReturnEnv()
    env.reset(seed=0, options={"target_depth": depth_goal, "base_x": -6.5, "arm_angle": 0.0})
    g = env.task.game
    g.armed[:] = False
    g.has_hit[:] = hit
    g.net_touched[:] = net
    g.shuttle.pos[0] = [land_x, 0.0, 0.01]
    g.shuttle.vel[0] = [0.0, 0.0, -5.0]
    g._refresh()
    return env.step([0.0, -1.0, 0.0])


def test_landing_reward_values():
    _, r, term, _, info = landing_case(4.0, 5.0)
    assert term and info["landed_in"]
    assert r == pytest.approx(np.exp(-0.5 * info["landing_error"]))
    assert info["landing_error"] == pytest.approx(1.0, abs=1e-9)
    assert landing_case(4.0, 5.0, net=True)[1] == 0.0  # touched the net after the hit
    assert landing_case(4.0, 6.66)[1] == 0.0  # beyond the original trigger box
    assert landing_case(4.0, -3.0)[1] == 0.0  # own side
    # not hit: the shaping of the steps before a hit still counts
    assert landing_case(4.0, 5.0, hit=False)[1] == pytest.approx(-0.005)
    # the reward's terms in info: landing only
    _, r, _, _, info = landing_case(4.0, 5.0)
    assert (info["reward_shaping"], info["reward_hit"]) == (0.0, 0.0)
    assert info["reward_landing"] == r == pytest.approx(np.exp(-0.5))


def test_hit_reward_and_info():
    env = SimpleReturnEnv()
    env.reset(seed=0, options={"base_x": -3.0, "arm_angle": -1.0})
    g = env.task.game
    g.shuttle.pos[0] = [-3.0 + 1.06 * np.sin(-0.35), 0, 0.65 + 1.06 * np.cos(-0.35)]
    g.shuttle.vel[0] = [0.0, 0.0, 0.0]
    g._refresh()
    _, r, _, _, info = env.step([1.0, 1.0, 0.0])
    assert info["hit"] and info["racket_speed"] == pytest.approx(7.42)
    assert 1.0 - 0.025 <= r <= 1.0  # +1 for the hit, shaping for the steps before it
    assert info["reward_hit"] == 1.0 and info["reward_landing"] == 0.0
    assert info["reward_shaping"] == pytest.approx(r - 1.0) and info["reward_shaping"] < 0


def test_reward_terms_sum_to_the_reward_in_both_tasks():
    """Each step's info names the reward's terms (Gymnasium's MuJoCo v5 habit); over a seeded
    batch of scripted play they add up to the reward exactly, and every term occurs."""
    from rallysim.envs.humanlike_return_v0 import HumanLikeReturnVectorEnv
    from rallysim.players import HUMANLIKE

    cases = ((SimpleReturnVectorEnv(16, seed=0), ScriptedController().act_return,
              ("reward_shaping", "reward_hit", "reward_landing")),
             (SimpleReturnVectorEnv(16, seed=0, returnable=0.5, ready=0.5),
              ScriptedController().act_return, ("reward_shaping", "reward_hit",
                                                 "reward_landing", "reward_returnable",
                                                 "reward_ready")),
             (HumanLikeReturnVectorEnv(16, seed=0), HUMANLIKE.scripted_task_low(),
              ("reward_hit", "reward_velocity")))
    for env, policy, keys in cases:
        obs, _ = env.reset(seed=0)
        totals = dict.fromkeys(keys, 0.0)
        for _ in range(40):
            obs, reward, _, _, info = env.step(policy(obs))
            assert np.array_equal(sum(info[k] for k in keys), reward)
            for k in keys:
                totals[k] += float(np.abs(info[k]).sum())
        assert all(v > 0 for v in totals.values()), totals


def test_returnable_rewards_a_hit_the_opponent_can_meet():
    """``returnable`` adds its reward on exactly the hits whose shot ``ShotPlanner`` says the
    opponent can meet, and changes nothing else: the same play without it gets the same
    trajectory and that much less reward; the single env seeded s + i replays slot i."""
    from rallysim.core.reach import ShotPlanner
    from rallysim.core.simple_obs import PLAYER_OBS_SIZE

    act, planner = ScriptedController().act_return, ShotPlanner()
    n, steps = 24, 60
    env = SimpleReturnVectorEnv(n, returnable=0.5, autoreset_mode="same_step")
    plain = SimpleReturnVectorEnv(n, autoreset_mode="same_step")
    obs, _ = env.reset(seed=5)
    plain_obs, _ = plain.reset(seed=5)
    actions, rewards, hits, returnable = [], [], 0, 0
    for _ in range(steps):
        a = act(obs)
        obs, r, term, trunc, info = env.step(a)
        plain_obs, plain_r, _, _, plain_info = plain.step(a)
        assert np.array_equal(obs, plain_obs) and "reward_returnable" not in plain_info
        assert np.array_equal(plain_r + info["reward_returnable"], r)
        hit = info["hit"]
        assert not info["reward_returnable"][~hit].any()
        if hit.any():  # where no episode ended, obs is the state just after the hit
            live = hit & ~term & ~trunc
            ok = planner.returnable(obs[live, :PLAYER_OBS_SIZE])
            assert np.array_equal(info["reward_returnable"][live], 0.5 * ok)
        hits += int(hit.sum())
        returnable += int(np.count_nonzero(info["reward_returnable"]))
        actions.append(a)
        rewards.append(r)
    assert hits >= n and 0 < returnable < hits  # both kinds of shot occur
    for i in range(3):
        single = SimpleReturnEnv(returnable=0.5)
        single.reset(seed=5 + i)
        for k in range(steps):
            _, r, term, trunc, info = single.step(actions[k][i])
            assert r == rewards[k][i]
            assert info["reward_returnable"] in (0.0, 0.5)
            if term or trunc:
                break


def test_ready_rewards_standing_mid_range_when_the_shot_lands():
    """``ready`` pays at the landing that ends an episode in which the player hit, more the
    nearer its base stands to -3.75 m, and nothing otherwise."""
    env = SimpleReturnVectorEnv(24, ready=0.5, autoreset_mode="same_step")
    obs, _ = env.reset(seed=3)
    act, paid, unpaid_landings = ScriptedController().act_return, [], 0
    for _ in range(60):
        hit_before = env.task.game.has_hit[:, 0].copy()
        base_before = env.task.game.bodies.base_x[:, 0].copy()
        obs, _, term, _, info = env.step(act(obs))
        ready = info["reward_ready"]
        assert not ready[~term].any()
        for i in np.flatnonzero(term):
            if hit_before[i] or info["hit"][i]:
                paid.append(ready[i])
                assert 0.0 < ready[i] <= 0.5
                # the base moves at most 5 m/s: 0.5 m in the last decision
                lo = 0.5 * np.exp(-0.5 * (abs(base_before[i] + 3.75) + 0.5))
                assert ready[i] >= lo
            else:
                unpaid_landings += 1
                assert ready[i] == 0.0
    assert len(paid) >= 10 and unpaid_landings >= 1
    single = SimpleReturnEnv(ready=0.5, returnable=0.25)
    single.reset(seed=0, options={"base_x": -3.75})
    assert single.reward_keys == ("reward_shaping", "reward_hit", "reward_landing",
                                  "reward_returnable", "reward_ready")
    assert SimpleReturnEnv().reward_keys == single.reward_keys[:3]
    for _ in range(30):
        _, r, term, _, info = single.step([0, 0, 0])
        assert sum(info[k] for k in single.reward_keys) == r
        if term:
            break


def test_truncation_at_max_decisions():
    env = SimpleReturnEnv(max_decisions=3)
    env.reset(seed=0)
    out = [env.step([0, -1, 0]) for _ in range(3)]
    assert [o[3] for o in out] == [False, False, True] and not any(o[2] for o in out)
    with pytest.raises(RuntimeError, match="reset"):
        env.step([0, 0, 0])


def test_next_step_and_same_step_autoreset():
    env = SimpleReturnVectorEnv(1, max_decisions=2)
    env.reset(seed=0)
    env.step(np.zeros((1, 3)))
    _, _, _, trunc, _ = env.step(np.zeros((1, 3)))
    assert trunc[0]
    obs, r, term, trunc, _ = env.step(np.zeros((1, 3)))  # the reset step
    assert r[0] == 0 and not term[0] and not trunc[0] and env.task.elapsed[0] == 0
    same = SimpleReturnVectorEnv(1, max_decisions=2, autoreset_mode="same_step")
    same.reset(seed=0)
    same.step(np.zeros((1, 3)))
    obs, _, _, trunc, info = same.step(np.zeros((1, 3)))
    assert trunc[0] and info["_final_obs"][0] and same.task.elapsed[0] == 0
    assert not np.array_equal(info["final_obs"][0], obs[0])


@pytest.mark.slow
def test_scripted_controller_returns_most_serves_near_target():
    env = SimpleReturnVectorEnv(128, autoreset_mode="same_step")
    r = evaluate_return(ScriptedController().act_return, env, episodes=768, seed=0)
    assert r.hit_rate > 0.95
    assert r.in_rate > 0.9
    assert r.median_error < 0.6
    assert r.mean_reward > 1.5
    rnd = np.random.default_rng(0)
    flail = evaluate_return(lambda o: rnd.uniform(-1, 1, (len(o), 3)), env, 256, seed=0)
    assert flail.hit_rate < 0.3 and flail.mean_reward < 0.3  # flailing hits one serve in five


def test_keep_bodies_carries_the_player_into_the_next_episode():
    env = SimpleReturnVectorEnv(2, max_decisions=3, keep_bodies=True, autoreset_mode="same_step")
    env.reset(seed=0, options={"base_x": [-6.0, -5.0], "arm_angle": 0.0})
    game = env.task.game
    for _ in range(3):
        env.step(np.array([[0.5, 1.0, 1.0], [0.5, 1.0, 1.0]]))
    # the truncated episodes restarted with the bodies as they were: 0.3 s walking at 5 m/s
    assert game.bodies.base_x[:, 0] == pytest.approx([-4.5, -3.5])
    assert game.bodies.theta[:, 0] == pytest.approx(np.radians(42.5))
    assert env.task.elapsed.tolist() == [0, 0]
    fresh = SimpleReturnVectorEnv(2, max_decisions=3, autoreset_mode="same_step")
    fresh.reset(seed=0)
    start = fresh.task.game.bodies.base_x[:, 0].copy()
    for _ in range(3):
        fresh.step(np.array([[0.5, 1.0, 1.0], [0.5, 1.0, 1.0]]))
    assert not np.allclose(fresh.task.game.bodies.base_x[:, 0], start + 1.5)  # drawn anew


def test_incoming_rally_shots_come_from_the_recorded_bank():
    from rallysim.assets import load_shot_bank

    bank = load_shot_bank()
    assert bank.shape == (4096, 6) and np.all(bank[:, 3] < 0)  # all fly toward player 0
    speed = np.linalg.norm(bank[:, 3:], axis=1)
    assert speed.min() > 12 and speed.max() <= 2 * 7 * 1.06 + 1e-6  # SIMPLE shots
    env = SimpleReturnVectorEnv(64, incoming="rally")
    env.reset(seed=0)
    sh = env.task.game.shuttle
    rows = [np.flatnonzero(np.all(np.isclose(bank[:, :3], p), axis=1)) for p in sh.pos]
    assert all(len(r) == 1 for r in rows)
    mixed = SimpleReturnVectorEnv(256, incoming="mixed")
    mixed.reset(seed=0)
    from_bank = np.isin(mixed.task.game.shuttle.pos[:, 0], bank[:, 0])
    assert 0.35 < from_bank.mean() < 0.65
    with pytest.raises(ValueError, match="'rally'"):
        SimpleReturnVectorEnv(2, incoming="lob")
