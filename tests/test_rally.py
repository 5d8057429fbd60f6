"""simple_rally_v0: PettingZoo APIs, rally rules, turns, competitive scoring
(docs/reference.md §7-8)."""

import numpy as np
import pytest
from pettingzoo.test import api_test, parallel_api_test, parallel_seed_test, seed_test

from rallysim.core.tasks.rally import RallyConfig, RallyTask
from rallysim.core.tasks.turns import TurnTask
from rallysim.envs import simple_rally_turn_v0, simple_rally_v0
from rallysim.policies import ScriptedController


@pytest.mark.slow
def test_pettingzoo_api_and_seed_tests():
    parallel_api_test(simple_rally_v0.parallel_env(), num_cycles=300)
    parallel_seed_test(simple_rally_v0.parallel_env, num_cycles=100)
    api_test(simple_rally_turn_v0.raw_env(), num_cycles=30, verbose_progress=False)
    seed_test(simple_rally_turn_v0.raw_env, num_cycles=20)


def test_start_positions_serve_and_observation_layout():
    env = simple_rally_v0.parallel_env()
    obs, _ = env.reset(seed=0)
    g = env.task.game
    assert g.bodies.mocap[0, 0, 0] == pytest.approx(-2.7)
    assert g.bodies.mocap[0, 1, 0] == pytest.approx(2.44)
    assert g.armed[0].tolist() == [True, False]
    assert g.shuttle.pos[0, 0] > 0 and g.shuttle.vel[0, 0] < 0  # served toward player 0
    o0, o1 = obs["player_0"], obs["player_1"]
    assert o0.shape == (20,) and o0[19] == 1.0 and o1[19] == 0.0
    assert o0[16] == pytest.approx(0.244) and o1[16] == pytest.approx(0.27)  # opponent x / 10
    assert o0[0] == pytest.approx(-0.27) and o1[0] == pytest.approx(-0.244)


def scripted_rally_lengths(shuttle: str, n: int = 64, rallies: int = 200, seed: int = 0):
    task = RallyTask(n, RallyConfig(shuttle=shuttle), seed=seed)
    task.reset(np.arange(n))
    c = ScriptedController()
    rng = np.random.default_rng(seed)
    goals = rng.uniform(2, 6, (n, 2))
    lengths = []
    while len(lengths) < rallies:
        obs = task.observe().reshape(-1, 20)
        _, term, trunc, info = task.step(c(obs, goals.reshape(-1)).reshape(n, 2, 3))
        done = term | trunc
        lengths += info["rally_length"][done].tolist()
        assert np.all(info["rally_length"] <= 50)
        if done.any():
            task.reset(np.flatnonzero(done))
        goals[task.turn_started] = rng.uniform(2, 6, task.turn_started.sum())
    return np.array(lengths)


@pytest.mark.slow
def test_scripted_players_keep_a_rally_going():
    lengths = scripted_rally_lengths("paper")
    assert lengths.mean() >= 10
    assert lengths.max() == 50  # capped rallies stop at exactly 50 hits
    aero = scripted_rally_lengths("aero", rallies=100)
    assert aero.mean() >= 10


def play_parallel(seed: int):
    env = simple_rally_v0.parallel_env()
    env.reset(seed=seed)
    c = ScriptedController()
    total = {"player_0": 0.0, "player_1": 0.0}
    hits = 0
    while env.agents:
        o = env.task.observe()[0]
        a = c(o, np.array([4.0, 4.0]))
        _, rew, term, trunc, info = env.step({"player_0": a[0], "player_1": a[1]})
        hits += info["player_0"]["hit"] + info["player_1"]["hit"]
        for k in total:
            total[k] += rew[k]
    return env, total, hits, term, trunc, info


@pytest.mark.slow
def test_cap_ends_the_rally_at_exactly_50_hits_and_hits_reward_both():
    capped = 0
    for seed in range(6):
        _env, total, hits, term, trunc, info = play_parallel(seed)
        assert hits == info["player_0"]["rally_length"] <= 50
        assert total["player_0"] == pytest.approx(0.2 * hits) == total["player_1"]
        if trunc["player_0"]:
            capped += 1
            assert not term["player_0"] and hits == 50
        else:
            assert term["player_0"] and info["player_0"]["landed"]
    assert capped >= 2


def mirrored(task: RallyTask) -> None:
    """Swap the two players' roles in rally 0 and mirror the shuttle through the net."""
    b, g = task.game.bodies, task.game
    b.base_x[0] = b.base_x[0, ::-1].copy()
    b.theta[0] = b.theta[0, ::-1].copy()
    b.omega[0] = b.omega[0, ::-1].copy()
    g.armed[0] = g.armed[0, ::-1].copy()
    for arr in (g.shuttle.pos, g.shuttle.vel):
        arr[0, :2] *= -1


def test_mirror_symmetry_of_observations():
    task = RallyTask(1, seed=0)
    task.reset(np.array([0]))
    c = ScriptedController()
    for _ in range(7):  # somewhere mid-flight, arms moving
        o = task.observe()[0]
        task.step(c(o, np.array([3.0, 5.0]))[None])
    task.game.bodies.base_x[0] = [-2.1, -4.3]
    task.game.bodies.theta[0] = [0.4, -0.9]
    task.game.shuttle.pos[0, 1] = 0.3  # off the centre line, to check y mirrors too
    before = task.observe()[0]
    mirrored(task)
    after = task.observe()[0]
    assert np.array_equal(after[1], before[0]) and np.array_equal(after[0], before[1])


def test_turn_step_spans_exactly_until_the_next_turn():
    env = simple_rally_turn_v0.raw_env(low_level="scripted")
    env.reset(seed=3)
    # replay the same rally at the physics rate to find when each hit happens
    task = RallyTask(1, seed=3)
    task.reset(np.array([0]))
    c = ScriptedController()
    hit_decisions = []
    for k in range(1, 400):
        o = task.observe()[0]
        _, term, trunc, info = task.step(c(o, np.array([4.0, 4.0]))[None])
        if info["hit"][0].any():
            hit_decisions.append(k)
        if term[0] or trunc[0]:
            break
    spans = []
    while not any(env.terminations.values()) and not any(env.truncations.values()):
        agent = env.agent_selection
        env.step(np.array([4.0]))
        spans.append((agent, env.infos[agent]["decisions"], env.rewards[agent]))
    # each span ends at the decision of the next hit: cumulative spans = hit decisions
    ends = np.cumsum([s[1] for s in spans])
    assert ends[: len(hit_decisions)].tolist() == hit_decisions[: len(ends)]
    assert [s[0] for s in spans[:4]] == ["player_0", "player_1", "player_0", "player_1"]
    assert all(s[2] == pytest.approx(0.2) for s in spans[:-1])


def test_turn_goals_are_clipped_and_nan_rejected():
    t = TurnTask(2, "scripted", seed=0)
    t.reset(np.arange(2))
    t.step(np.array([9.0, -3.0]))
    assert t.goals[:, 0].tolist() == [6.0, 2.0]
    with pytest.raises(ValueError, match="finite"):
        t.step(np.array([np.nan, 4.0]))
    with pytest.raises(ValueError, match="low_level"):
        TurnTask(1, "genius")


def test_parallel_bad_input():
    env = simple_rally_v0.parallel_env()
    env.reset(seed=0)
    ok = np.zeros(3)
    with pytest.raises(ValueError, match="unknown agent"):
        env.step({"player_0": ok, "player_1": ok, "player_2": ok})
    with pytest.raises(ValueError, match="missing"):
        env.step({"player_0": ok})
    with pytest.raises(ValueError, match="NaN"):
        env.step({"player_0": np.array([np.nan, 0, 0]), "player_1": ok})
    with pytest.raises(ValueError, match="shape"):
        env.step({"player_0": np.zeros(4), "player_1": ok})
    env.task.game.shuttle.pos[0, 2] = 0.001  # make it land now
    env.task.game.shuttle.vel[0] = [0, 0, -5]
    env.task.game._refresh()
    env.step({"player_0": ok, "player_1": ok})
    with pytest.raises(ValueError, match="done"):
        env.step({"player_0": ok, "player_1": ok})
    with pytest.raises(ValueError, match="competitive"):
        simple_rally_v0.parallel_env(mode="friendly")


def land(task: RallyTask, x: float, hitter: int | None) -> dict:
    """Make rally 0's shuttle land at world ``x`` this decision, last hit by ``hitter``."""
    g = task.game
    g.armed[0] = False
    if hitter is not None:
        g.last_hitter[0] = hitter
    g.shuttle.pos[0] = [x, 0.0, 0.01]
    g.shuttle.vel[0] = [0.0, 0.0, -5.0]
    g._refresh()
    rewards, term, _trunc, info = task.step(np.zeros((1, 2, 3)))
    return {"rewards": rewards[0], "term": term[0], "info": info}


def test_competitive_scoring_sequence():
    task = RallyTask(1, RallyConfig(mode="competitive", points_to_win=3, win_by=2, max_points=5),
                     seed=0)
    task.reset(np.array([0]))
    r = land(task, -3.0, hitter=1)  # in on player 0's side: point to player 1
    assert r["info"]["point_winner"][0] == 1 and r["rewards"].tolist() == [-1.0, 1.0]
    assert task.score[0].tolist() == [0, 1] and task.server[0] == 1
    assert task.game.armed[0].tolist() == [True, False]  # player 1 serves to player 0
    r = land(task, 7.5, hitter=1)  # player 1 hits it out: point to player 0, who serves
    assert task.score[0].tolist() == [1, 1] and task.server[0] == 0
    assert task.game.armed[0].tolist() == [False, True] and task.game.shuttle.pos[0, 0] < 0
    land(task, 3.0, hitter=0)  # in on player 1's side
    assert task.score[0].tolist() == [2, 1] and not task.turn_started[0, 0]
    r = land(task, 3.0, hitter=0)  # 3-1: game to 3, won by 2
    assert r["term"] and task.score[0].tolist() == [3, 1]


def test_competitive_win_by_two_and_cap():
    task = RallyTask(1, RallyConfig(mode="competitive", points_to_win=3, win_by=2, max_points=4),
                     seed=0)
    task.reset(np.array([0]))
    seq = [0, 1, 0, 1]  # 1-0, 1-1, 2-1, 2-2
    for winner in seq:
        r = land(task, 3.0 if winner == 0 else -3.0, hitter=winner)
        assert not r["term"]
    r = land(task, 3.0, hitter=0)  # 3-2: not by two, play on
    assert not r["term"]
    r = land(task, 3.0, hitter=0)  # 4-2 ... and 4 is the cap anyway
    assert r["term"] and task.score[0].tolist() == [4, 2]


def test_competitive_turn_env_rewards_are_zero_sum():
    env = simple_rally_turn_v0.raw_env(low_level="random", mode="competitive", points_to_win=2,
                                   max_points=3)
    env.reset(seed=0)
    totals = {"player_0": 0.0, "player_1": 0.0}
    for agent in env.agent_iter(max_iter=500):
        _, reward, term, trunc, _ = env.last()
        totals[agent] += reward
        env.step(None if term or trunc else np.array([4.0]))
    assert totals["player_0"] == -totals["player_1"] and abs(totals["player_0"]) >= 1


def test_vector_views():
    vec = simple_rally_v0.SimpleRallyVectorEnv(3, seed=0)
    obs, _ = vec.reset(seed=0)
    assert obs.shape == (6, 20) and vec.num_envs == 6
    obs, r, term, trunc, _ = vec.step(np.zeros((6, 3)))
    assert r.shape == (6,) and np.array_equal(term[0::2], term[1::2])
    assert np.array_equal(trunc[0::2], trunc[1::2])
    turn = simple_rally_turn_v0.SimpleRallyTurnVectorEnv(4, seed=0)
    obs, _ = turn.reset(seed=0)
    assert obs.shape == (4, 20) and np.all(obs[:, 19] == 1.0)  # the turn player is armed
    obs, r, term, _trunc, info = turn.step(np.full((4, 1), 4.0))
    assert np.all(info["decisions"] >= 1) and np.all(np.isclose(r, 0.0) | np.isclose(r, 0.2))
    import gymnasium as gym

    single = gym.make("RallySim/SimpleRallyTurn-v0")
    obs, _ = single.reset(seed=0)
    assert obs.shape == (20,)


def test_random_low_level_is_reseeded_by_reset():
    """``low_level="random"`` restarts its stream with ``reset(seed)``: the same seed replays
    the same turn episode (it did not before: the low level kept drawing where it was)."""

    def episode(env) -> list[float]:
        env.reset(seed=21)
        out = []
        for goal in (3.0, 5.0, 4.0, 2.5):
            agent = env.agent_selection
            if env.terminations[agent] or env.truncations[agent]:
                break
            env.step(np.array([goal]))
            out += [float(v) for a in env.agents for v in env.observe(a)]
        return out

    env = simple_rally_turn_v0.raw_env(low_level="random")
    first = episode(env)
    assert episode(env) == first and len(first) >= 1
