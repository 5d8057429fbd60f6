"""Gymnasium conventions in full: the normalised ``SimpleRallyTurn-v1``, the registered
HUMAN-LIKE turn id, ``RecordVideo`` over an env's frames, and TorchRL's ``GymWrapper`` over a
native vector env."""

from __future__ import annotations

import copy
import pickle
import warnings

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

import rallysim  # noqa: F401  (registers the envs)
from rallysim.envs.humanlike_rally_turn_v0 import HumanLikeRallyTurnEnv, HumanLikeRallyTurnVectorEnv
from rallysim.envs.registration import HUMANLIKE_RALLY_TURN_ID, SIMPLE_RALLY_TURN_V1_ID
from rallysim.envs.simple_rally_turn_v0 import SimpleRallyTurnEnv, SimpleRallyTurnVectorEnv
from rallysim.envs.simple_rally_turn_v1 import SimpleRallyTurnV1Env, SimpleRallyTurnV1VectorEnv
from rallysim.envs.simple_rally_v0 import SimpleRallyVectorEnv
from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv
from tests.conftest import check_seeded_and_batched, gl_problem

V0_ID = "RallySim/SimpleRallyTurn-v0"


def play(env, seed: int, actions, held: list | None = None) -> list[tuple]:
    """(observation, reward, terminated, truncated, info) of a seeded episode, the reset first;
    stops at the episode's end. ``held`` (a turn env's) collects the goals held after each
    step: the observations do not show them, and the scripted low level may play the same
    swing for goals a rounding error apart."""
    obs, info = env.reset(seed=seed)
    out = [(obs, 0.0, False, False, info)]
    for a in actions:
        out.append(env.step(a))
        if held is not None:
            held.append(env.unwrapped.vec.turns.goals.copy())
        if out[-1][2] or out[-1][3]:
            break
    return out


def assert_same(a: list[tuple], b: list[tuple]) -> None:
    """Two played episodes equal bit for bit (observations, rewards, ends, info)."""
    assert len(a) == len(b)
    for x, y in zip(a, b, strict=True):
        assert np.array_equal(x[0], y[0]) and x[0].dtype == y[0].dtype
        assert np.array_equal(x[1], y[1]) and np.array_equal(x[2], y[2])
        assert np.array_equal(x[3], y[3])
        assert x[4].keys() == y[4].keys()
        for key in x[4]:
            assert np.array_equal(x[4][key], y[4][key]), key


# -- RallySim/SimpleRallyTurn-v1 ---------------------------------------------------------------

def test_v1_spaces_and_env_checker_without_warnings():
    env = gym.make(SIMPLE_RALLY_TURN_V1_ID)
    assert isinstance(env.unwrapped, SimpleRallyTurnV1Env)
    assert env.action_space == gym.spaces.Box(-1.0, 1.0, (1,), np.float32)
    assert env.observation_space == gym.spaces.Box(-1.0, 1.0, (20,), np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error")  # any warning fails the test
        # "human" needs a display; rgb_array frames are tested in test_env_render
        check_env(env.unwrapped, skip_render_check=True)
        env.reset(seed=0)  # through gym.make's passive checker too
        env.step(env.action_space.sample())
    # the check does catch what v1 fixes: v0's goal-in-metres Box is warned about
    with pytest.warns(UserWarning, match="symmetric and normalized"):
        check_env(SimpleRallyTurnEnv(), skip_render_check=True)
    # and Gymnasium points v0's users to v1 (the ids are versions of one env)
    with pytest.warns(DeprecationWarning, match="upgrading to version `v1`"):
        gym.make(V0_ID)
    vec = gym.make_vec(SIMPLE_RALLY_TURN_V1_ID, num_envs=3)
    assert isinstance(vec, SimpleRallyTurnV1VectorEnv) and vec.num_envs == 3
    assert vec.single_action_space == env.action_space
    assert vec.action_space == gym.spaces.Box(-1.0, 1.0, (3, 1), np.float32)
    assert vec.observation_space.shape == (3, 20)


def test_v1_action_a_plays_the_v0_episode_of_goal_4_plus_2a():
    # float32, as a policy's actions are; ends of the range included
    actions = np.random.default_rng(1).uniform(-1, 1, (10, 1)).astype(np.float32)
    actions[[2, 5]] = [[-1.0], [1.0]]
    goals = 4.0 + 2.0 * actions.astype(np.float64)
    assert goals[2, 0] == 2.0 and goals[5, 0] == 6.0
    held1, held0 = [], []
    v1 = play(SimpleRallyTurnV1Env(), 3, actions, held1)
    v0 = play(SimpleRallyTurnEnv(), 3, goals, held0)
    assert len(v1) == 11  # ten turns played (the rally went on)
    assert_same(v1, v0)
    assert np.array_equal(held1, held0)  # the goals themselves, exactly 4 + 2a
    assert held1[5][0].tolist() == [goals[4, 0], 6.0]  # player 1 acted at turn 6 (a = 1)
    assert sum(step[1] for step in v1) == pytest.approx(0.2 * 10)  # a hit per turn
    # the comparison sees the goal: 0.5 m more and the episode is another one
    other = play(SimpleRallyTurnEnv(), 3, goals + 0.5)
    assert not all(np.array_equal(x[0], y[0]) for x, y in zip(v1, other, strict=False))
    # the vector envs likewise, row by row (next-step autoreset included)
    batch = np.random.default_rng(2).uniform(-1, 1, (8, 3, 1)).astype(np.float32)
    vec1, vec0 = SimpleRallyTurnV1VectorEnv(3), SimpleRallyTurnVectorEnv(3)
    assert np.array_equal(vec1.reset(seed=9)[0], vec0.reset(seed=9)[0])
    for a in batch:
        out1, out0 = vec1.step(a), vec0.step(4.0 + 2.0 * a.astype(np.float64))
        for x, y in zip(out1[:4], out0[:4], strict=True):
            assert np.array_equal(x, y)
        assert all(np.array_equal(out1[4][k], out0[4][k]) for k in out0[4])


def test_v1_vector_env_i_seeded_s_plus_i_replays_the_single_env():
    actions = np.random.default_rng(3).uniform(-1, 1, (6, 3, 1)).astype(np.float32)
    check_seeded_and_batched(SimpleRallyTurnV1Env, SimpleRallyTurnV1VectorEnv, actions)
    # and gym.make / gym.make_vec build the same envs
    vec = gym.make_vec(SIMPLE_RALLY_TURN_V1_ID, num_envs=2)
    obs, _ = vec.reset(seed=20)
    single = gym.make(SIMPLE_RALLY_TURN_V1_ID)
    assert np.array_equal(single.reset(seed=21)[0], obs[1])
    for a in actions[:4, :2]:
        obs, reward, *_ = vec.step(a)
        step = single.step(a[1])
        assert np.array_equal(step[0], obs[1]) and step[1] == reward[1]


def test_v1_clips_out_of_range_actions_and_refuses_nan():
    def first_steps(env, action):
        return play(env, 4, [action, np.zeros(1, np.float32)])

    for big, edge in ((5.0, 1.0), (-7.5, -1.0)):
        assert_same(first_steps(SimpleRallyTurnV1Env(), np.array([big])),
                    first_steps(SimpleRallyTurnV1Env(), np.array([edge], np.float32)))
    # the clipped edges are v0's goals 6 m and 2 m
    assert_same(first_steps(SimpleRallyTurnV1Env(), np.array([9.0])),
                first_steps(SimpleRallyTurnEnv(), np.array([6.0])))
    # a scalar action is the one-element action, as v0 takes a scalar goal
    assert_same(first_steps(SimpleRallyTurnV1Env(), 0.25),
                first_steps(SimpleRallyTurnV1Env(), np.array([0.25])))

    env, twin = SimpleRallyTurnV1Env(), SimpleRallyTurnV1Env()
    env.reset(seed=6)
    twin.reset(seed=6)
    for bad in (np.array([np.nan]), np.array([np.inf]), np.zeros(2), "0.5"):
        with pytest.raises(ValueError, match="actions"):
            env.step(bad)
    assert_same([env.step(np.array([0.3]))], [twin.step(np.array([0.3]))])  # nothing moved

    vec, vtwin = SimpleRallyTurnV1VectorEnv(2), SimpleRallyTurnV1VectorEnv(2)
    vec.reset(seed=6)
    vtwin.reset(seed=6)
    with pytest.raises(ValueError, match="NaN"):
        vec.step(np.array([[0.0], [np.nan]]))
    a, clipped = np.array([[3.0], [-2.0]]), np.array([[1.0], [-1.0]])
    for x, y in zip(vec.step(a)[:4], vtwin.step(clipped)[:4], strict=True):
        assert np.array_equal(x, y)


@pytest.mark.parametrize("how", ["deepcopy", "pickle"])
def test_v1_copies_mid_episode_step_like_their_original(how):
    def twin(env):
        return copy.deepcopy(env) if how == "deepcopy" else pickle.loads(pickle.dumps(env))

    actions = np.random.default_rng(5).uniform(-1, 1, (6, 2, 1)).astype(np.float32)
    env = SimpleRallyTurnV1Env()
    env.reset(seed=8)
    env.step(actions[0, 0])
    copied = twin(env)
    assert_same([copied.step(a) for a in actions[1:, 0]], [env.step(a) for a in actions[1:, 0]])
    vec = SimpleRallyTurnV1VectorEnv(2)
    vec.reset(seed=8)
    vec.step(actions[0])
    vcopy = twin(vec)
    for a in actions[1:]:
        for x, y in zip(vcopy.step(a)[:4], vec.step(a)[:4], strict=True):
            assert np.array_equal(x, y)


# -- RallySim/HumanLikeRallyTurn-v0 ------------------------------------------------------------

@pytest.mark.slow
def test_humanlike_turn_id_is_the_classes_episode_for_episode():
    env = gym.make(HUMANLIKE_RALLY_TURN_ID)
    assert isinstance(env.unwrapped, HumanLikeRallyTurnEnv)
    # the 3-D goal is already normalised: no v1 needed
    assert env.action_space == gym.spaces.Box(-1.0, 1.0, (3,), np.float32)
    assert env.observation_space == gym.spaces.Box(-1.0, 1.0, (86,), np.float32)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check_env(env.unwrapped, skip_render_check=True)
    actions = np.random.default_rng(7).uniform(-1, 1, (3, 2, 3)).astype(np.float32)
    made = play(env, 2, actions[:, 0])
    direct = play(HumanLikeRallyTurnEnv(), 2, actions[:, 0])
    assert len(made) == 4 and made[1][4]["decisions"] > 0
    assert_same(made, direct)

    vec = gym.make_vec(HUMANLIKE_RALLY_TURN_ID, num_envs=2)
    assert isinstance(vec, HumanLikeRallyTurnVectorEnv) and vec.action_space.shape == (2, 3)
    direct_vec = HumanLikeRallyTurnVectorEnv(2)
    obs, _ = vec.reset(seed=2)
    assert np.array_equal(obs, direct_vec.reset(seed=2)[0])
    assert np.array_equal(obs[0], made[0][0])  # env 0 seeded 2 is the single env seeded 2
    for k, a in enumerate(actions):
        out, out_direct = vec.step(a), direct_vec.step(a)
        for x, y in zip(out[:4], out_direct[:4], strict=True):
            assert np.array_equal(x, y)
        assert np.array_equal(out[0][0], made[k + 1][0]) and out[1][0] == made[k + 1][1]


# -- RecordVideo ------------------------------------------------------------------------------

def test_record_video_writes_every_frame_of_an_episode(tmp_path):
    pytest.importorskip("moviepy", reason="RecordVideo needs moviepy (the render extra)")
    iio = pytest.importorskip("imageio.v2", reason="reading the video back needs imageio")
    if (problem := gl_problem()) is not None:
        pytest.skip(problem)
    from gymnasium.wrappers import RecordVideo

    env = RecordVideo(gym.make("RallySim/SimpleReturn-v0", render_mode="rgb_array"),
                      str(tmp_path / "videos"), disable_logger=True)
    action = np.zeros(3, np.float32)  # the player stands still: the serve just lands
    env.reset(seed=12)
    steps = 0
    while True:
        steps += 1
        if any(env.step(action)[2:4]):
            break
    env.close()  # writes the recording
    # the same episode drawn directly, for the frames' contents
    direct = gym.make("RallySim/SimpleReturn-v0", render_mode="rgb_array")
    direct.reset(seed=12)
    expected = [direct.render()]
    for _ in range(steps):
        direct.step(action)
        expected.append(direct.render())

    videos = list((tmp_path / "videos").glob("*.mp4"))
    assert [v.name for v in videos] == ["rl-video-episode-0.mp4"]
    assert videos[0].stat().st_size > 1000
    reader = iio.get_reader(videos[0], "ffmpeg")
    assert reader.get_meta_data()["fps"] == 10  # the env's render_fps: game time
    frames = [np.asarray(f) for f in reader]
    reader.close()
    assert 10 < steps < 40 and len(frames) == steps + 1  # the reset's frame and one per step
    for got, want in zip(frames, expected, strict=True):
        assert got.shape == want.shape == (360, 640, 3)
        assert np.abs(got.astype(float) - want).mean() < 3.0  # lossy (H.264), but close
    # consecutive frames differ only by the shuttle and the HUD, so check order and content:
    # each decoded frame is nearer (fewer clearly different pixels) to its own frame than to
    # the frames before and after it
    def changed(got: np.ndarray, want: np.ndarray) -> int:
        return int((np.abs(got.astype(np.int16) - want).max(axis=2) > 40).sum())

    for k, got in enumerate(frames):
        own = changed(got, expected[k])
        assert all(own < changed(got, expected[j]) for j in (k - 1, k + 1) if 0 <= j <= steps)


# -- TorchRL --------------------------------------------------------------------------------

def test_torchrl_rollout_matches_the_vector_env_stepped_directly():
    torch = pytest.importorskip("torch", reason="TorchRL needs torch")
    torchrl_gym = pytest.importorskip("torchrl.envs.libs.gym", reason="torchrl not installed")
    from gymnasium.vector import AutoresetMode

    assert gym.make_vec("RallySim/SimpleReturn-v0", num_envs=4).autoreset_mode == (
        AutoresetMode.NEXT_STEP)  # Gymnasium's default, which TorchRL refuses
    # TorchRL steps vector envs that reset in the same step (or not at all). A time limit of
    # 18 decisions: env 0's serve lands after 17, the others are cut at 18. (Never all four at
    # once: TorchRL then calls a full reset() and drops the same-step resets' episodes.)
    kwargs = {"autoreset_mode": "same_step", "max_decisions": 18}
    vec = gym.make_vec("RallySim/SimpleReturn-v0", num_envs=4, **kwargs)
    assert vec.autoreset_mode == AutoresetMode.SAME_STEP == vec.metadata["autoreset_mode"]
    env = torchrl_gym.GymWrapper(vec)
    assert tuple(env.batch_size) == (4,)
    steps = 24
    actions = np.random.default_rng(0).uniform(-1, 1, (steps, 4, 3)).astype(np.float32)
    queue = iter(actions)

    def policy(td):
        td["action"] = torch.from_numpy(next(queue))
        return td

    roll = env.rollout(steps, policy=policy, auto_reset=False, tensordict=env.reset(seed=5),
                       break_when_any_done=False)
    assert tuple(roll.batch_size) == (4, steps)
    assert roll["observation"].shape == (4, steps, 17) and roll["action"].shape == (4, steps, 3)

    direct = SimpleReturnVectorEnv(4, **kwargs)
    obs, _ = direct.reset(seed=5)
    nxt = roll["next"]
    for k in range(steps):
        # after an end, TorchRL carries on with the env's own same-step reset
        assert np.array_equal(roll["observation"][:, k].numpy(), obs)
        assert np.array_equal(roll["action"][:, k].numpy(), actions[k])
        obs, reward, term, trunc, info = direct.step(actions[k])
        done = term | trunc
        # at an end TorchRL's next observation is the episode's last, not the new first
        last = np.where(done[:, None], info["final_obs"], obs) if done.any() else obs
        assert np.array_equal(nxt["observation"][:, k].numpy(), last)
        assert np.array_equal(nxt["reward"][:, k, 0].numpy(), reward.astype(np.float32))
        assert np.array_equal(nxt["terminated"][:, k, 0].numpy(), term)
        assert np.array_equal(nxt["truncated"][:, k, 0].numpy(), trunc)
        assert np.array_equal(nxt["done"][:, k, 0].numpy(), done)
    terminated = nxt["terminated"][..., 0].numpy()
    truncated = nxt["truncated"][..., 0].numpy()
    assert np.argwhere(terminated).tolist() == [[0, 16]]
    assert np.argwhere(truncated).tolist() == [[1, 17], [2, 17], [3, 17]]


@pytest.mark.parametrize(("render_envs", "shape"), [(1, (360, 640, 3)), (4, (720, 1280, 3))])
def test_sb3_vec_env_renders_the_envs_the_batch_draws(tmp_path, render_envs, shape):
    pytest.importorskip("stable_baselines3", reason="rallysim.sb3 needs Stable-Baselines3")
    if (problem := gl_problem()) is not None:
        pytest.skip(problem)
    from stable_baselines3.common.vec_env import VecVideoRecorder

    from rallysim.sb3 import make_vec_env

    venv = make_vec_env("RallySim/SimpleReturn-v0", 4, seed=0,
                        env_kwargs={"render_mode": "rgb_array", "render_envs": render_envs})
    venv.reset()
    frames = venv.venv.render()
    image = venv.render()
    assert image.shape == shape  # SB3 tiles the drawn frames: 1 alone, 4 as a 2 x 2 grid
    np.testing.assert_array_equal(image[:360, :640], frames[0])
    assert image.std() > 20  # a court, not a blank image
    recorder = VecVideoRecorder(venv, str(tmp_path), lambda step: step == 0, video_length=5)
    recorder.reset()
    for _ in range(5):
        recorder.step(np.zeros((4, 3), np.float32))
    recorder.close()
    videos = list(tmp_path.glob("*.mp4"))
    assert len(videos) == 1 and videos[0].stat().st_size > 1000


def _refused(cls: type) -> str:
    try:
        cls(2, autoreset_mode="sometimes")
    except ValueError as error:
        return str(error)  # (the traceback, and the half-built env with it, go here)
    return "accepted"


def test_a_refused_vector_env_is_collected_quietly():
    """A constructor refused before its renderers exist must not raise again when Gymnasium's
    ``VectorEnv.__del__`` closes the half-built object."""
    import gc
    import sys

    seen = []
    previous, sys.unraisablehook = sys.unraisablehook, seen.append
    try:
        refusals = [_refused(cls) for cls in (SimpleRallyVectorEnv, SimpleRallyTurnVectorEnv,
                                              HumanLikeRallyTurnVectorEnv, SimpleReturnVectorEnv)]
        gc.collect()
    finally:
        sys.unraisablehook = previous
    assert all(r.startswith("unknown autoreset_mode 'sometimes'") for r in refusals)
    assert [str(s.exc_value) for s in seen] == []


@pytest.mark.parametrize("env_id", sorted(k for k in gym.registry if k.startswith("RallySim/")))
@pytest.mark.parametrize("vector", [False, True])
def test_a_misspelt_keyword_lists_the_valid_ones(env_id, vector):
    """``gym.make(id, shuttel="aero")`` names the misspelt keyword and every valid one, in
    Python's own wording (what TorchRL's retry looks for), for every registered id and view."""
    make = (lambda **kw: gym.make_vec(env_id, num_envs=2, **kw)) if vector else (
        lambda **kw: gym.make(env_id, **kw))
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)  # (v0 ids: "out of date")
        with pytest.raises(TypeError, match=r"unexpected keyword argument 'shuttel'; "
                                            r"valid arguments: .*\bshuttle\b.*\bmax_decisions\b"):
            make(shuttel="aero")
