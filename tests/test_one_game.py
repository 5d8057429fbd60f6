"""The fused physics steps of one SIMPLE game (``rallysim.core.one_game``), as Python and
compiled by Numba, are the lanes code's, bit for bit: the same env stepped with and without them
gives the same state after every decision, and the same observations and rewards as env 0 of a
batch, over play that hits, misses, touches the net, lands in and out and hits the arm's
stops."""

from __future__ import annotations

import os
import pickle
import subprocess
import sys

import numpy as np
import pytest

from rallysim.core import native, one_game
from rallysim.core.bodies import SimpleBodies
from rallysim.core.game import Game
from rallysim.core.humanlike import HumanLikeBodies
from rallysim.core.one_game import OneSimpleGame
from rallysim.envs.simple_return_v0 import SimpleReturnEnv, SimpleReturnVectorEnv
from rallysim.policies.scripted import ScriptedController
from tests.kernels import NEEDS_COMPILED_SIMPLE, counting, play, same_bits


def _state(env: SimpleReturnEnv) -> list[np.ndarray]:
    """Every array of the game's state and of its last decision's events."""
    return _game_state(env.task.game)


def _game_state(game: Game) -> list[np.ndarray]:
    b, sh, st, d = game.bodies, game.shuttle, game.state, game.bodies.data
    return [d.qpos, d.qvel, d.ctrl, d.mocap_pos, b.base_x, b._theta0, b.base_moved, b.target,
            b.torque_limit, sh.motion, sh.shot_time, sh.shot_speed, game._q, game._gap,
            *vars(st).values(), *vars(game.events).values()]



def _actions(kind: str, rng: np.random.Generator, obs: np.ndarray,
             controller: ScriptedController) -> np.ndarray:
    if kind == "scripted":  # hits and aimed landings
        a = controller.act_return(obs[None])[0]
        return np.clip(a + rng.normal(0.0, 0.3, 3), -1.0, 1.0).astype(np.float32)
    if kind == "extreme":  # full-force swings into the arm's stops, the base at its ends
        return rng.choice([-1.0, 1.0], 3).astype(np.float32)
    return rng.uniform(-1.0, 1.0, 3).astype(np.float32)


NEEDS_COMPILED = NEEDS_COMPILED_SIMPLE
KERNELS = ["python", pytest.param("compiled", marks=NEEDS_COMPILED)]


def _with_kernel(env: SimpleReturnEnv, kernel: str) -> SimpleReturnEnv:
    game = env.task.game
    game._one = OneSimpleGame(game, kernel)
    assert game._one.kernel == kernel
    return env


@pytest.mark.slow
@pytest.mark.parametrize("kernel", KERNELS)
@pytest.mark.parametrize("kind", ["random", "scripted", "extreme"])
def test_fused_steps_replay_the_lanes_code_and_a_batch(kind, kernel):
    fused, lanes = _with_kernel(SimpleReturnEnv(), kernel), SimpleReturnEnv()
    batch = SimpleReturnVectorEnv(2, autoreset_mode="same_step")
    lanes.task.game._one = None
    counts = counting(fused.task.game)
    rng, controller = np.random.default_rng(3), ScriptedController()
    seen = {"hit": 0, "landed_in": 0, "net_touch": 0, "stopped": 0, "episodes": 0}
    obs_f, _ = fused.reset(seed=11)
    obs_l, _ = lanes.reset(seed=11)
    obs_b, _ = batch.reset(seed=11)
    assert same_bits(obs_f, obs_l) and same_bits(obs_f, obs_b[0])
    for step in range(1500):
        a = _actions(kind, rng, obs_f, controller)
        obs_f, r_f, term_f, trunc_f, info_f = fused.step(a)
        obs_l, r_l, term_l, trunc_l, info_l = lanes.step(a)
        obs_b, r_b, term_b, trunc_b, _ = batch.step(np.stack([a, -a]))
        assert same_bits(obs_f, obs_l) and same_bits(r_f, r_l), step
        assert (term_f, trunc_f) == (term_l, trunc_l)
        assert info_f.keys() == info_l.keys()
        for key in info_f:
            assert same_bits(info_f[key], info_l[key]), (step, key)
        for x, y in zip(_state(fused), _state(lanes), strict=True):
            assert same_bits(x, y), step
        # env 0 of a batch seeded alike: the same reward and ends, and the same observation
        # (after an end, the batch's is the next episode's first: compared after the reset)
        assert same_bits(np.float64(r_f), r_b[0])
        assert (term_f, trunc_f) == (term_b[0], trunc_b[0])
        seen["hit"] += info_f["hit"]
        seen["landed_in"] += bool(info_f.get("landed_in", False))
        seen["net_touch"] += info_f["net_touch"]
        seen["stopped"] += abs(fused.task.game.bodies.theta.item()) == fused.task.game.bodies.limit
        if term_f or trunc_f:
            seen["episodes"] += 1
            obs_f, _ = fused.reset()
            obs_l, _ = lanes.reset()
            assert same_bits(obs_f, obs_l)
        assert same_bits(obs_f, obs_b[0]), step
    # the play reached every kind of judged step the fused path hands over
    assert seen["episodes"] >= 20 and seen["hit"] >= 10, seen
    if kind == "scripted":
        assert seen["landed_in"] >= 10, seen
    if kind == "extreme":
        assert seen["stopped"] >= 100, seen
    if kind == "random":
        assert seen["net_touch"] >= 1, seen
    # and the fused path ran every step: most free, those after a landing held
    assert counts["fused"] + counts["held"] == 5 * 1500 and counts["lanes"] == 0, counts
    assert counts["fused"] > 0.7 * 5 * 1500 and counts["held"] > 50, counts


def _replay_alike(env: SimpleReturnEnv, copy: SimpleReturnEnv, rng: np.random.Generator,
                  decisions: int) -> None:
    """Step both with the same random actions: the same observations, rewards and ends."""
    for _ in range(decisions):
        a = rng.uniform(-1, 1, 3).astype(np.float32)
        one, two = env.step(a), copy.step(a)
        assert same_bits(one[0], two[0]) and one[1:4] == two[1:4]
        if one[2] or one[3]:
            assert same_bits(env.reset()[0], copy.reset()[0])


@pytest.mark.parametrize("kernel", KERNELS)
def test_a_copy_mid_episode_keeps_replaying(kernel):
    env = _with_kernel(SimpleReturnEnv(incoming="mixed"), kernel)
    rng = np.random.default_rng(0)
    env.reset(seed=4)
    for _ in range(7):
        env.step(rng.uniform(-1, 1, 3).astype(np.float32))
    copy = pickle.loads(pickle.dumps(env))
    assert copy.task.game._one.kernel == kernel  # and its own MuJoCo data's address
    assert copy.task.game.bodies.data._address != env.task.game.bodies.data._address
    _replay_alike(env, copy, rng, 300)


def test_fused_steps_only_where_they_fit():
    assert isinstance(Game(1, 1)._one, OneSimpleGame)
    assert isinstance(SimpleReturnVectorEnv(1).task.game._one, OneSimpleGame)
    assert Game(2, 1)._one is None  # a batch: array lanes
    assert Game(1, 2)._one is None  # two players
    assert Game(1, 1, shuttle="aero")._one is None  # another flight model
    assert Game(1, 1, shuttle="paper-alg1")._one is None
    # another player model: its own fused steps (tests/test_one_humanlike.py)
    assert not isinstance(Game(1, 1, bodies=HumanLikeBodies(1, 1))._one, OneSimpleGame)

    class Bodies(SimpleBodies):  # a player model built on SIMPLE's may change its motion
        pass

    assert Game(1, 1, bodies=Bodies(1, 1))._one is None


def test_the_kernel_chosen(monkeypatch):
    auto = "python" if one_game.compiled_free_steps() is None else "compiled"
    assert OneSimpleGame(Game(1, 1), "auto").kernel == auto
    assert OneSimpleGame(Game(1, 1), "python").kernel == "python"
    monkeypatch.setattr(native, "KERNEL", "python")  # the default, where none is given
    assert Game(1, 1)._one.asked == "python"
    with pytest.raises(ValueError, match=r"unknown kernel 'numba' \(native.KERNEL or "
                                         r"RALLYSIM_KERNEL\); valid: 'auto', 'python'"):
        OneSimpleGame(Game(1, 1), "numba")


def test_the_kernel_variable_sets_the_default():
    code = "from rallysim.core import native; print(native.KERNEL)"
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         env={**os.environ, "RALLYSIM_KERNEL": "python"}, check=True)
    assert out.stdout.strip() == "python"


def _nothing_compiles(monkeypatch, why: str) -> None:
    """As where the compiled kernel cannot be had ("another machine")."""
    for name, value in (("tried", True), ("function", None), ("why_not", why)):
        monkeypatch.setattr(one_game.Compiled, name, value)


def test_the_compiled_kernel_refused_where_it_cannot_run(monkeypatch):
    _nothing_compiles(monkeypatch, "Numba is not installed")
    assert OneSimpleGame(Game(1, 1), "auto").kernel == "python"  # falls back
    with pytest.raises(RuntimeError, match="compiled kernel cannot run here: Numba is not "):
        OneSimpleGame(Game(1, 1), "compiled")


@NEEDS_COMPILED
def test_a_copy_taken_where_nothing_compiles_runs_python_alike(monkeypatch):
    env = SimpleReturnEnv()
    env.task.game._one = OneSimpleGame(env.task.game, "auto")
    assert env.task.game._one.kernel == "compiled"
    rng = np.random.default_rng(5)
    env.reset(seed=2)
    for _ in range(5):
        play(env, rng.uniform(-1, 1, 3).astype(np.float32))
    data = pickle.dumps(env)
    actions = rng.uniform(-1, 1, (400, 3)).astype(np.float32)
    played = [play(env, a) for a in actions]  # compiled, here
    # "another machine": nothing compiles; the copy's steps run as Python, counted
    _nothing_compiles(monkeypatch, "a test")
    calls = []
    python_steps = one_game.PYTHON_FREE_STEPS
    monkeypatch.setattr(one_game, "PYTHON_FREE_STEPS",
                        lambda *args: calls.append(1) or python_steps(*args))
    copy = pickle.loads(data)
    assert copy.task.game._one.kernel == "python"
    for a, (obs, rest) in zip(actions, played, strict=True):
        again, again_rest = play(copy, a)
        assert same_bits(obs, again) and rest == again_rest
    assert len(calls) > 300



def test_where_the_compiled_kernel_cannot_be_had_it_says_why(monkeypatch):
    for name, value in (("tried", False), ("function", None), ("why_not", "")):
        monkeypatch.setattr(one_game.Compiled, name, value)
    monkeypatch.setattr(one_game.mujoco, "mj_versionString", lambda: "0.0.0")
    assert one_game.compiled_free_steps() is None
    assert one_game.Compiled.why_not.startswith("no libmujoco.so of MuJoCo 0.0.0 beside")
    monkeypatch.setattr(one_game.Compiled, "tried", False)
    monkeypatch.setattr(one_game, "_compile", lambda: 1 / 0)  # a Numba that cannot compile it
    assert one_game.compiled_free_steps() is None
    assert one_game.Compiled.why_not == "compiling failed: ZeroDivisionError: division by zero"
    assert OneSimpleGame(Game(1, 1), "auto").kernel == "python"


@NEEDS_COMPILED
def test_the_compiled_observation_is_the_lanes_codes():
    """States well outside the observation's ranges, signed zeros and non-finite numbers: the
    compiled observation gives the lanes code's bits (clipped as np.clip clips, NaN kept)."""
    env = SimpleReturnEnv()
    env.reset(seed=0)
    task, game = env.task, env.task.game
    b, sh = game.bodies, game.shuttle
    python, compiled = OneSimpleGame(game, "python"), OneSimpleGame(game, "compiled")
    rng = np.random.default_rng(0)
    special = [0.0, -0.0, np.nan, np.inf, -np.inf, 1e300, -1.0, 1.0]
    clipped = {"low": 0, "high": 0, "nan": 0}
    for _ in range(3000):
        values = rng.normal(0.0, 10.0 ** rng.integers(-2, 3), 10)
        # (not the arm angle: the probe holds sine and cosine to NumPy's on finite angles)
        values[rng.integers(1, 10)] = special[rng.integers(len(special))]
        b.theta[0, 0], b.omega[0, 0], b.base_x[0, 0] = values[:3]
        sh.motion[:, 0] = 10.0 * values[3:9]
        task.goal[0] = values[9]
        game._one = python
        with np.errstate(invalid="ignore"):  # NumPy's sine of inf warns; it is NaN
            expected = task.observe()
        game._one = compiled
        got = task.observe()
        assert same_bits(got, expected), values
        clipped["low"] += int((got == -1.0).sum())
        clipped["high"] += int((got == 1.0).sum())
        clipped["nan"] += int(np.isnan(got).sum())
    assert min(clipped.values()) > 300, clipped


@NEEDS_COMPILED
def test_the_compiled_observation_with_other_maps():
    """A zero scale gives the lanes code's inf and NaN; maps of the wrong length are refused
    (the compiled code does not check its indices)."""
    from rallysim.core.lanes import SCALARS
    from rallysim.core.simple_obs import raw_observation_lanes
    from rallysim.core.tasks.simple_return import OBS_CENTRE, OBS_SCALE

    env = SimpleReturnEnv()
    env.reset(seed=3)
    game = env.task.game
    one = OneSimpleGame(game, "compiled")
    scale = OBS_SCALE.copy()
    scale[[0, 1, 7, 16]] = 0.0  # x / 0 and 0 / 0
    scale.flags.writeable = False  # (as the task's: the signature the dry run compiled)
    extra = np.array([0.25])
    with np.errstate(divide="ignore", invalid="ignore"):
        lanes = SCALARS.observations([*raw_observation_lanes(game), 0.25], (1, 1), OBS_CENTRE,
                                     scale)[:, 0]
        got = one.observation(game, extra, OBS_CENTRE, scale)
    assert same_bits(got, lanes) and np.isnan(got).sum() >= 1 and np.isinf(got).sum() == 0
    with pytest.raises(ValueError, match="one entry per value"):
        one.observation(game, np.zeros(2), OBS_CENTRE, OBS_SCALE)


@pytest.mark.parametrize("kernel", KERNELS)
def test_held_and_frozen_steps_replay_the_lanes_code(kernel):
    """One game stepped on after its landings (whole decisions out of play) and now and then
    frozen by ``active``: the fused steps give the lanes code's state."""
    fused, lanes = Game(1, 1, seed=5, shaping=True), Game(1, 1, seed=5, shaping=True)
    fused._one, lanes._one = OneSimpleGame(fused, kernel), None
    counts = counting(fused)
    rng = np.random.default_rng(5)
    for game in (fused, lanes):
        game.reset(np.array([0]))
    landed = frozen = 0
    for step in range(600):
        a = rng.uniform(-1, 1, (1, 1, 3))
        active = np.array([rng.uniform() > 0.2])
        fused.step(a, active)
        lanes.step(a, active)
        for x, y in zip(_game_state(fused), _game_state(lanes), strict=True):
            assert same_bits(x, y), step
        frozen += not active[0]
        landed += fused.events.landed.item()
        if step % 40 == 39:
            for game in (fused, lanes):
                game.reset(np.array([0]))
    assert landed >= 5 and frozen >= 60 and counts["held"] >= 500 and counts["lanes"] == 0, (
        landed, frozen, counts)


@pytest.mark.parametrize("kernel", KERNELS)
def test_kept_bodies_and_reachable_goals_replay_a_batch(kernel):
    single = _with_kernel(SimpleReturnEnv(keep_bodies=True, goals="reachable"), kernel)
    batch = SimpleReturnVectorEnv(2, keep_bodies=True, goals="reachable",
                                  autoreset_mode="same_step")
    obs, _ = single.reset(seed=6)
    obs_b, _ = batch.reset(seed=6)
    assert same_bits(obs, obs_b[0])
    rng = np.random.default_rng(6)
    episodes = 0
    for step in range(400):
        a = rng.uniform(-1, 1, 3).astype(np.float32)
        obs, r, term, trunc, _ = single.step(a)
        obs_b, r_b, term_b, trunc_b, _ = batch.step(np.stack([a, a]))
        assert same_bits(np.float64(r), r_b[0]) and (term, trunc) == (term_b[0], trunc_b[0])
        if term or trunc:
            episodes += 1
            obs, _ = single.reset()
        assert same_bits(obs, obs_b[0]), step
    assert episodes >= 10


@NEEDS_COMPILED
def test_the_dry_run_compiled_what_a_game_passes():
    env = _with_kernel(SimpleReturnEnv(), "compiled")
    env.reset(seed=1)
    for _ in range(50):
        play(env, np.zeros(3, np.float32))
    # one signature each: the game's arrays are of the types the dry run compiled for
    assert len(one_game.Compiled.function.free_steps.signatures) == 1
    assert len(one_game.Compiled.function.observation.signatures) == 1


@pytest.mark.parametrize("kernel", KERNELS)
def test_fused_steps_without_shaping(kernel):
    fused, lanes = _with_kernel(SimpleReturnEnv(), kernel), SimpleReturnEnv()
    lanes.task.game._one = None
    for env in (fused, lanes):
        env.task.game.shaping = False
        env.reset(seed=8)
    rng = np.random.default_rng(8)
    for step in range(500):
        a = rng.uniform(-1, 1, 3).astype(np.float32)
        one, two = fused.step(a), lanes.step(a)
        assert same_bits(one[0], two[0]) and one[1:4] == two[1:4], step
        for x, y in zip(_state(fused), _state(lanes), strict=True):
            assert same_bits(x, y), step
        assert fused.task.game.events.approach_bad.item() == 0  # nothing counted
        if one[2] or one[3]:
            fused.reset()
            lanes.reset()

