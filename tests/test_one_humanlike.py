"""One HUMAN-LIKE player's compiled steps (``rallysim.core.one_humanlike``) are the Python
code's, bit for bit: the same env stepped compiled and as Python gives the same state after
every decision, and the same observations and rewards as env 0 of a batch, over play that
hits, misses, lands, saturates the servo and hits the joints' stops."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from rallysim.core import native, one_humanlike
from rallysim.core.game import Game
from rallysim.core.humanlike import N_ACTIONS, HumanLikeBodies
from rallysim.core.one_humanlike import OneHumanLikeGame
from rallysim.envs.humanlike_return_v0 import HumanLikeReturnEnv, HumanLikeReturnVectorEnv
from rallysim.policies.scripted_swing import ScriptedSwing
from tests.kernels import NEEDS_COMPILED_HUMANLIKE, counting, play, same_bits

NEEDS_COMPILED = NEEDS_COMPILED_HUMANLIKE


def _with_kernel(env: HumanLikeReturnEnv, kernel: str) -> HumanLikeReturnEnv:
    bodies = env.task.game.bodies
    bodies.kernel_asked = kernel
    assert bodies.kernel == ("python" if kernel == "python" else "compiled")
    return env


def _state(env: HumanLikeReturnEnv) -> list[np.ndarray]:
    """Every array of the game's and the bodies' state and of the last decision's events."""
    game = env.task.game
    b, sh, st = game.bodies, game.shuttle, game.state
    return [b.data.qpos, b.data.qvel, b.data.ctrl, b.data.qfrc_bias, b.data.M,
            b.data.site_xpos, b.data.site_xmat, b.data.mocap_pos, b._side, b.hips,
            b.hips_velocity, b.base_moved, b._face0, b.target, b.torque_limit, sh.motion,
            sh.shot_time, sh.shot_speed, game._q, game._gap, *vars(st).values(),
            *vars(game.events).values()]



def _actions(kind: str, rng: np.random.Generator, obs: np.ndarray,
             swing: ScriptedSwing) -> np.ndarray:
    if kind == "scripted":  # swings that hit, with noise; weak and zero strengths mixed in
        a = swing(obs[None])[0] + rng.normal(0.0, 0.2, N_ACTIONS)
        a[10:] = np.where(rng.random(5) < 0.2, rng.choice([-1.0, 0.0]), a[10:])
        return np.clip(a, -1.0, 1.0).astype(np.float32)
    if kind == "extreme":  # full targets and strengths: the stops and the speed ceiling
        return rng.choice([-1.0, 1.0], N_ACTIONS).astype(np.float32)
    return rng.uniform(-1.0, 1.0, N_ACTIONS).astype(np.float32)



@pytest.mark.slow
@NEEDS_COMPILED
@pytest.mark.parametrize("kind", ["random", "scripted", "extreme"])
def test_compiled_steps_replay_python_and_a_batch(kind):
    fused = _with_kernel(HumanLikeReturnEnv(), "compiled")
    python = _with_kernel(HumanLikeReturnEnv(), "python")
    batch = HumanLikeReturnVectorEnv(2, autoreset_mode="same_step")
    counts = counting(fused.task.game)
    rng, swing = np.random.default_rng(3), ScriptedSwing()
    seen = {"hit": 0, "landed": 0, "saturated": 0, "stopped": 0, "episodes": 0}
    obs_f, _ = fused.reset(seed=11)
    obs_p, _ = python.reset(seed=11)
    obs_b, _ = batch.reset(seed=11)
    assert same_bits(obs_f, obs_p) and same_bits(obs_f, obs_b[0])
    decisions = 600
    for step in range(decisions):
        a = _actions(kind, rng, obs_f, swing)
        obs_f, r_f, term_f, trunc_f, info_f = fused.step(a)
        obs_p, r_p, term_p, trunc_p, info_p = python.step(a)
        obs_b, r_b, term_b, trunc_b, _ = batch.step(np.stack([a, -a]))
        assert same_bits(obs_f, obs_p) and same_bits(r_f, r_p), step
        assert (term_f, trunc_f) == (term_p, trunc_p)
        assert info_f.keys() == info_p.keys()
        for key in info_f:
            assert same_bits(info_f[key], info_p[key]), (step, key)
        for x, y in zip(_state(fused), _state(python), strict=True):
            assert same_bits(x, y), step
        assert same_bits(np.float64(r_f), r_b[0])
        assert (term_f, trunc_f) == (term_b[0], trunc_b[0])
        b = fused.task.game.bodies
        seen["hit"] += info_f["hit"]
        seen["landed"] += bool(fused.task.game.events.landed.any())
        seen["saturated"] += bool(b._side.any())
        seen["stopped"] += bool(np.any((b.qpos == b.lo) | (b.qpos == b.hi)))
        if term_f or trunc_f:
            seen["episodes"] += 1
            obs_f, _ = fused.reset()
            obs_p, _ = python.reset()
            assert same_bits(obs_f, obs_p)
        assert same_bits(obs_f, obs_b[0]), step
    assert seen["episodes"] >= 15 and seen["saturated"] >= 300, seen
    if kind == "scripted":
        assert seen["hit"] >= 5 and seen["landed"] >= 5, seen
    if kind == "extreme":
        assert seen["stopped"] >= 100, seen
    # the fused path ran most steps (the lanes code: those after a landing)
    assert counts["fused"] + counts["lanes"] == 5 * decisions
    assert counts["fused"] > 0.9 * 5 * decisions, counts


@NEEDS_COMPILED
def test_a_copy_mid_episode_keeps_replaying_and_runs_python_where_nothing_compiles(
        monkeypatch):
    env = _with_kernel(HumanLikeReturnEnv(), "auto")
    rng = np.random.default_rng(0)
    env.reset(seed=4)
    for _ in range(7):
        env.step(rng.uniform(-1, 1, N_ACTIONS).astype(np.float32))
    data = pickle.dumps(env)
    copy = pickle.loads(data)
    assert copy.task.game.bodies.kernel == "compiled"
    actions = rng.uniform(-1, 1, (300, N_ACTIONS)).astype(np.float32)
    played = [play(env, a) for a in actions]
    for a, (obs, rest) in zip(actions, played, strict=True):
        again, again_rest = play(copy, a)
        assert same_bits(obs, again) and rest == again_rest
    # "another machine": nothing compiles; the copy runs the Python code, alike
    for name, value in (("tried", True), ("function", None), ("why_not", "a test")):
        monkeypatch.setattr(one_humanlike.Compiled, name, value)
    copy = pickle.loads(data)
    assert copy.task.game.bodies.kernel == "python"
    for a, (obs, rest) in zip(actions, played, strict=True):
        again, again_rest = play(copy, a)
        assert same_bits(obs, again) and rest == again_rest
    with pytest.raises(RuntimeError, match="compiled kernel cannot run here: a test"):
        HumanLikeBodies(1, 1, kernel="compiled")



def test_fused_steps_only_where_they_fit():
    assert isinstance(Game(1, 1, bodies=HumanLikeBodies(1, 1))._one, OneHumanLikeGame)
    assert Game(2, 1, bodies=HumanLikeBodies(2, 1))._one is None  # a batch: array lanes
    assert Game(1, 2, bodies=HumanLikeBodies(1, 2))._one is None  # two players
    assert Game(1, 1, shuttle="aero", bodies=HumanLikeBodies(1, 1))._one is None
    assert HumanLikeBodies(2, 1, kernel="auto").kernel == "python"  # a batch's array code
    assert len(HumanLikeBodies(1, 1)._constants) == one_humanlike.N_CONSTANTS

    class Bodies(HumanLikeBodies):  # a player model built on HUMAN-LIKE's may change its motion
        pass

    assert Game(1, 1, bodies=Bodies(1, 1))._one is None
    assert Bodies(1, 1, kernel="auto").kernel == "python"
    with pytest.raises(ValueError, match=r"unknown kernel 'numba' \(native.KERNEL or "):
        HumanLikeBodies(1, 1, kernel="numba")


def test_the_kernel_default_is_native_kernel(monkeypatch):
    monkeypatch.setattr(native, "KERNEL", "python")
    assert HumanLikeReturnEnv().task.game.bodies.kernel == "python"


@NEEDS_COMPILED
def test_the_dry_run_compiled_what_a_game_passes():
    env = _with_kernel(HumanLikeReturnEnv(), "compiled")
    rng = np.random.default_rng(1)
    env.reset(seed=1)
    for _ in range(100):
        play(env, rng.uniform(-1, 1, N_ACTIONS).astype(np.float32))
    steps = one_humanlike.Compiled.function
    # one signature each: the game's arrays are of the types the dry run compiled for
    assert len(steps.free_steps.signatures) == 1 and len(steps.physics_step.signatures) == 1


def _fresh_kernel(monkeypatch) -> native.Kernel:
    kernel = native.Kernel(lambda: one_humanlike._compile())
    monkeypatch.setattr(one_humanlike, "Compiled", kernel)
    return kernel


@pytest.mark.slow
@NEEDS_COMPILED
def test_the_probe_refuses_row_sums_or_a_solve_unlike_numpys(monkeypatch):
    def sequential(p, out):  # the same terms, added left to right
        for i in range(8):
            total = 0.0
            for j in range(8):
                total += p[i, j]
            out[i] = total

    def unstarted(p, out):  # NumPy's pairwise order without the reduction's +0.0 start
        for i in range(8):
            out[i] = (((p[i, 0] + p[i, 1]) + (p[i, 2] + p[i, 3]))
                      + ((p[i, 4] + p[i, 5]) + (p[i, 6] + p[i, 7])))

    for wrong in (sequential, unstarted):
        kernel = _fresh_kernel(monkeypatch)
        monkeypatch.setattr(one_humanlike, "row_sums8", wrong)
        assert kernel.get() is None
        assert kernel.why_not == "the compiled row sums differ from NumPy's on this machine"
        monkeypatch.undo()

    solve_with = one_humanlike._solve_with

    def transposed(dgesv):  # A handed over in C order: LAPACK solves A^T u = r
        import numba

        solve = numba.njit(solve_with(dgesv))

        def solve_t(A, r, u):
            solve(A.T.copy(), r, u)

        return solve_t

    kernel = _fresh_kernel(monkeypatch)
    monkeypatch.setattr(one_humanlike, "_solve_with", transposed)
    assert kernel.get() is None
    assert kernel.why_not == "the compiled solve differs from NumPy's on this machine"
    assert HumanLikeBodies(1, 1, kernel="auto").kernel == "python"


@NEEDS_COMPILED
def test_without_numpys_dgesv_it_says_why(monkeypatch):
    kernel = _fresh_kernel(monkeypatch)
    monkeypatch.setattr(native, "DGESV_NAMES", ("no_such_dgesv_",))
    assert kernel.get() is None
    assert kernel.why_not == "NumPy's LAPACK has no 64-bit-integer dgesv (no_such_dgesv_)"


@pytest.mark.slow
@NEEDS_COMPILED
def test_a_shaped_game_replays_python_and_a_batch():
    """The approach counts of ``Game(shaping=True)`` (the HUMAN-LIKE task does not shape):
    compiled, as Python and as env 0 of a batch seeded alike."""
    games = [Game(1, 1, seed=5, shaping=True, bodies=HumanLikeBodies(1, 1, kernel=kernel))
             for kernel in ("compiled", "python")]
    batch = Game(2, 1, seed=5, shaping=True, bodies=HumanLikeBodies(2, 1))
    assert [g.kernel for g in games] == ["compiled", "python"]
    for g in (*games, batch):
        g.reset(np.arange(g.n_envs))
    rng = np.random.default_rng(5)
    good = bad = rallies = 0
    for step in range(400):
        a = rng.uniform(-1, 1, (1, 1, N_ACTIONS))
        if step % 3 == 0:  # the hips stay put: steps that do not close in
            a[..., :2] = 0.0
        events = [g.step(a) for g in games]
        batch_events = batch.step(np.concatenate([a, -a]))
        for g in (games[1], batch):
            for x, y in ((games[0]._gap, g._gap[:1]), (games[0]._q[:, :1], g._q[:1, :1]),
                         (games[0].shuttle.motion, g.shuttle.motion[:, :1]),
                         (events[0].approach_good, events[1].approach_good),
                         (events[0].approach_good, batch_events.approach_good[:1]),
                         (events[0].approach_bad, batch_events.approach_bad[:1])):
                assert same_bits(x, y), step
        good += int(events[0].approach_good.sum())
        bad += int(events[0].approach_bad.sum())
        if not games[0].state.in_play.item():
            rallies += 1
            for g in (*games, batch):
                g.reset(np.array([0]))
    assert good > 50 and bad > 50 and rallies >= 5, (good, bad, rallies)
