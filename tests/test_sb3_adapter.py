"""``rallysim.sb3.make_vec_env``: SB3's VecEnv over a registered id's batched vector env."""

from __future__ import annotations

import subprocess
import sys

import gymnasium as gym
import numpy as np
import pytest

pytest.importorskip("stable_baselines3")

from stable_baselines3.common.env_util import make_vec_env as sb3_make_vec_env
from stable_baselines3.common.vec_env import DummyVecEnv, VecMonitor, VecNormalize

from rallysim.core.simple_obs import normalise_depth
from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv
from rallysim.sb3 import NativeVecEnv, make_vec_env, native_ids

ID = "RallySim/SimpleReturn-v0"


def test_first_observations_are_the_native_env_s():
    vec = make_vec_env(ID, 8, seed=3)
    assert isinstance(vec, NativeVecEnv) and vec.num_envs == 8
    assert isinstance(vec.venv.unwrapped, SimpleReturnVectorEnv)
    obs = vec.reset()
    assert obs.shape == (8, 17) and obs.dtype == np.float32
    native, _ = SimpleReturnVectorEnv(8, seed=3).reset()
    np.testing.assert_array_equal(obs, native)
    # environment i of the batch is a single environment seeded 3 + i
    single = gym.make(ID)
    for i in (0, 5):
        np.testing.assert_array_equal(obs[i], single.reset(seed=3 + i)[0])
    # another seed, other serves and goals
    assert not np.array_equal(make_vec_env(ID, 8, seed=4).reset(), obs)


def test_replays_sb3_s_own_make_vec_env_step_for_step():
    """Same seed, same actions: the batched env and SB3's one-env-per-object DummyVecEnv
    (with its Monitor) give the same observations, rewards, ends and episode infos."""
    n, steps = 6, 150
    fast = make_vec_env(ID, n, seed=11)
    slow = sb3_make_vec_env(ID, n_envs=n, seed=11)
    obs_f, obs_s = fast.reset(), slow.reset()
    np.testing.assert_array_equal(obs_f, obs_s)
    rng = np.random.default_rng(0)
    episodes = 0
    for _ in range(steps):
        actions = rng.uniform(-1, 1, (n, 3)).astype(np.float32)
        obs_f, rew_f, done_f, info_f = fast.step(actions)
        obs_s, rew_s, done_s, info_s = slow.step(actions)
        np.testing.assert_array_equal(obs_f, obs_s)
        np.testing.assert_array_equal(rew_f, rew_s)
        np.testing.assert_array_equal(done_f, done_s)
        for e in np.flatnonzero(done_f):
            f, s = info_f[e], info_s[e]
            np.testing.assert_array_equal(f["terminal_observation"], s["terminal_observation"])
            assert not np.array_equal(f["terminal_observation"], obs_f[e])  # already reset
            assert f["TimeLimit.truncated"] is s["TimeLimit.truncated"] is False
            assert f["episode"]["l"] == s["episode"]["l"] >= 10
            assert f["episode"]["r"] == pytest.approx(s["episode"]["r"], abs=1e-5)
            # the final info's scalars: the landing the single env reports on its last step
            assert f["landing_error"] == pytest.approx(s["landing_error"], abs=1e-12)
            assert f["landed_in"] == s["landed_in"]
            episodes += 1
    assert episodes >= 2 * n  # serves land within about 2 s (20 decisions)
    assert rew_f.dtype == np.float32


def test_time_limit_truncation_is_flagged_with_the_terminal_observation():
    vec = make_vec_env(ID, 4, seed=0, env_kwargs={"max_decisions": 3})
    first = vec.reset()
    zero = np.zeros((4, 3), np.float32)
    for _ in range(2):
        _, _, dones, infos = vec.step(zero)
        assert not dones.any() and infos == [{}] * 4
    obs, _, dones, infos = vec.step(zero)
    assert dones.all()
    for e in range(4):
        assert infos[e]["TimeLimit.truncated"] is True
        assert infos[e]["episode"]["l"] == 3
        # the serve is still in the air: the last observation is not the new episode's first
        assert infos[e]["terminal_observation"].shape == (17,)
        assert not np.array_equal(infos[e]["terminal_observation"], obs[e])
    assert not np.array_equal(obs, first)  # new serves and goals for the new episodes


def test_env_kwargs_reach_the_env():
    vec = make_vec_env(ID, 3, seed=1, env_kwargs={"target_depth_range": (5.0, 5.0),
                                                  "shuttle": "aero"})
    obs = vec.reset()
    np.testing.assert_allclose(obs[:, 16], normalise_depth(5.0))
    assert vec.venv.unwrapped.task.game.flight.name == "aero"
    assert vec.get_attr("num_envs", [0, 2]) == [3, 3]


def test_unseeded_batches_differ():
    assert not np.array_equal(make_vec_env(ID, 4).reset(), make_vec_env(ID, 4).reset())


BATCHED_IDS = ["RallySim/HumanLikeRallyTurn-v0", "RallySim/HumanLikeReturn-v0",
               "RallySim/SimpleRallyTurn-v0", "RallySim/SimpleRallyTurn-v1",
               "RallySim/SimpleReturn-v0", "RallySim/SimpleReturn-v1"]


def test_every_batched_id_builds():
    ids = native_ids()
    # exactly these six (docs/using-with.md lists them); CartPole-v1 has a vector entry
    # point, but not a RallySim batched env
    assert ids == BATCHED_IDS
    for env_id in ids:
        vec = make_vec_env(env_id, 2, seed=0)
        assert vec.reset().shape == (2, *vec.observation_space.shape), env_id
    turn = make_vec_env("RallySim/SimpleRallyTurn-v0", 2, seed=0)
    assert (turn.action_space.low[0], turn.action_space.high[0]) == (2.0, 6.0)


def test_an_unknown_id_s_error_lists_every_batched_id():
    with pytest.raises(ValueError, match="unknown environment id") as err:
        make_vec_env("RallySim/NoSuch-v0", 2)
    assert all(env_id in str(err.value) for env_id in BATCHED_IDS)


@pytest.mark.parametrize(("args", "kwargs", "match"), [
    (("RallySim/NoSuch-v0", 4), {}, r"unknown environment id 'RallySim/NoSuch-v0'.*"
                                    r"RallySim/SimpleReturn-v0"),
    (("RallySim/SimpleReturn-v7", 4), {}, r"unknown environment id"),
    (("Pendulum-v1", 4), {}, r"'Pendulum-v1' has no native vector entry point.*"
                             r"stable_baselines3\.common\.env_util\.make_vec_env"),
    (("CartPole-v1", 4), {}, r"not a RallySim batched env.*stable_baselines3"),
    ((ID, 0), {}, r"n_envs must be an integer >= 1, got 0"),
    ((ID, -2), {}, r"n_envs must be an integer >= 1"),
    ((ID, 2.0), {}, r"n_envs must be an integer >= 1, got 2\.0"),
    ((ID, True), {}, r"n_envs must be an integer >= 1"),
    ((ID, 2), {"seed": -1}, r"seed must be None or an integer"),
    ((ID, 2), {"seed": 1.5}, r"seed must be None or an integer"),
    ((ID, 2), {"env_kwargs": {"num_envs": 8}}, r"may not set \['num_envs'\]"),
    ((ID, 2), {"env_kwargs": {"autoreset_mode": "next_step"}}, r"autoreset is always"),
    ((ID, 2), {"env_kwargs": {"seed": 3}}, r"may not set \['seed'\]"),
    ((ID, 2), {"env_kwargs": {"bogus": 1}},
     r"unexpected keyword argument 'bogus'; valid arguments: .*shuttle"),
    ((ID, 2), {"env_kwargs": [("shuttle", "aero")]}, r"env_kwargs must be a dict, got list"),
    ((None, 2), {}, r"env_id must be a registered id string, got NoneType"),
])
def test_bad_inputs_say_what_is_wrong(args, kwargs, match):
    with pytest.raises(ValueError, match=match):
        make_vec_env(*args, **kwargs)


@pytest.mark.parametrize(("kwargs", "named"), [
    ({"monitor_dir": "logs"}, "monitor_dir"),
    ({"monitor_kwargs": {"info_keywords": ("hit",)}}, "monitor_kwargs"),
    ({"wrapper_class": gym.wrappers.ClipAction}, "wrapper_class"),
    ({"wrapper_kwargs": {"x": 1}}, "wrapper_kwargs"),
    ({"vec_env_cls": DummyVecEnv}, "vec_env_cls"),
    ({"vec_env_kwargs": {"start_method": "fork"}}, "vec_env_kwargs"),
    ({"start_index": 4}, "start_index"),
    ({"start_index": True}, "start_index"),
    ({"monitor_dir": "logs", "vec_env_cls": DummyVecEnv}, "monitor_dir, vec_env_cls"),
])
def test_sb3_s_per_env_arguments_are_refused_with_the_reason(kwargs, named):
    """SB3's make_vec_env arguments that act on per-environment objects: a ValueError that
    names them and says what to do (not a TypeError for an unexpected keyword)."""
    with pytest.raises(ValueError, match=rf"cannot apply {named}: it builds one batched env.*"
                                         r"per-environment wrapper.*VecMonitor.*VecNormalize"):
        make_vec_env(ID, 2, **kwargs)


def test_sb3_s_defaults_for_those_arguments_are_accepted():
    """SB3's signature, SB3's order and defaults: a call written for SB3 that leaves them at
    their defaults (positionally too) builds the batched env, the same as without them."""
    args = (ID, 2, 5, 0, None, None, {"shuttle": "aero"}, None, {}, None, {})
    vec = make_vec_env(*args)
    assert vec.venv.unwrapped.task.game.flight.name == "aero"
    np.testing.assert_array_equal(vec.reset(),
                                  make_vec_env(ID, 2, seed=5, env_kwargs={"shuttle": "aero"})
                                  .reset())
    make_vec_env(ID, 2, start_index=np.int64(0), monitor_kwargs={}, wrapper_kwargs=None)


def test_sb3_s_vec_env_wrappers_apply_to_the_result(tmp_path):
    """What the refusal suggests works: VecMonitor (with its file) and VecNormalize."""
    env = VecNormalize(VecMonitor(make_vec_env(ID, 4, seed=0), str(tmp_path / "run")))
    env.reset()
    for _ in range(40):
        env.step(np.zeros((4, 3), np.float32))
    rows = (tmp_path / "run.monitor.csv").read_text().splitlines()
    assert len(rows) > 2 and rows[1] == "r,l,t"  # header, columns, then episodes


def test_env_s_own_checks_still_apply():
    with pytest.raises(ValueError, match="unknown shuttle"):
        make_vec_env(ID, 2, env_kwargs={"shuttle": "feather"})


def test_missing_sb3_names_the_extra():
    code = ("import sys; sys.modules['stable_baselines3'] = None\n"
            "try:\n    import rallysim.sb3\nexcept ModuleNotFoundError as e:\n    print(e)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    assert "rallysim.sb3 needs Stable-Baselines3" in out and "rallysim[train]" in out


@pytest.mark.parametrize(("missing", "translated"), [
    ("stable_baselines3", True), ("stable_baselines3.common.vec_env", True), ("torch", True),
    # SB3 imports it: its own error, not "install SB3"
    pytest.param("cloudpickle", False, marks=pytest.mark.slow),
])
def test_only_missing_sb3_or_torch_is_translated(missing, translated):
    code = (f"import sys; sys.modules[{missing!r}] = None\n"
            "try:\n    import rallysim.sb3\n"
            "except ModuleNotFoundError as e:\n    print(e.name, '|', e)")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout
    name, _, message = out.partition(" | ")
    assert name.partition(".")[0] == missing.partition(".")[0]  # the error keeps its name
    assert ("rallysim.sb3 needs Stable-Baselines3" in message) is translated, message
