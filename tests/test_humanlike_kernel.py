"""HUMAN-LIKE games' compiled steps (``rallysim.core.kernels`` around the bodies' step,
``rallysim.core.humanlike_step``) run every N x P alike: each env of a batch replays a single env
seeded s + i bit for bit (one player and two), over play that hits, lands, saturates the servo
and hits the joints' stops; and the step does what the servo promises (torques within the
limits, the desired speeds reached where nothing saturates)."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from rallysim.core import humanlike_step
from rallysim.core.game import Game
from rallysim.core.humanlike import BRAKE_SHARE, N_ACTIONS, N_JOINTS, HumanLikeBodies
from rallysim.envs.humanlike_return_v0 import HumanLikeReturnEnv, HumanLikeReturnVectorEnv
from rallysim.policies.scripted_swing import ScriptedSwing
from tests.kernels import play, same_bits


def _body_state(b: HumanLikeBodies, env: int) -> list[np.ndarray]:
    """Every array of env ``env``'s players' state after a physics step."""
    return [a[env] for a in (b.qpos, b.qvel, b.torque, b._bias, b._face_pos, b._face_mat,
                             b._mocap, b._side, b.hips, b.hips_velocity, b.base_moved, b._face0,
                             b.target, b.torque_limit)]


def _actions(kind: str, rng: np.random.Generator, obs: np.ndarray,
             swing: ScriptedSwing) -> np.ndarray:
    n = len(obs)
    if kind == "scripted":  # swings that hit, with noise; weak and zero strengths mixed in
        a = swing(obs) + rng.normal(0.0, 0.2, (n, N_ACTIONS))
        a[:, 10:] = np.where(rng.random((n, 5)) < 0.2, rng.choice([-1.0, 0.0], (n, 5)),
                             a[:, 10:])
        return np.clip(a, -1.0, 1.0).astype(np.float32)
    if kind == "extreme":  # full targets and strengths: the stops and the speed ceiling
        return rng.choice([-1.0, 1.0], (n, N_ACTIONS)).astype(np.float32)
    return rng.uniform(-1.0, 1.0, (n, N_ACTIONS)).astype(np.float32)


@pytest.mark.parametrize("kind", ["random", "scripted", "extreme"])
def test_every_env_of_a_batch_replays_a_single_env_seeded_s_plus_i(kind):
    n, decisions = 4, 250
    batch = HumanLikeReturnVectorEnv(n, autoreset_mode="same_step")
    singles = [HumanLikeReturnEnv() for _ in range(n)]
    rng, swing = np.random.default_rng(3), ScriptedSwing()
    seen = {"hit": 0, "shot_speed": 0, "landed": 0, "saturated": 0, "stopped": 0, "episodes": 0}
    obs_b, _ = batch.reset(seed=11)
    for i, single in enumerate(singles):
        obs, _ = single.reset(seed=11 + i)
        assert same_bits(obs, obs_b[i])
    for step in range(decisions):
        a = _actions(kind, rng, obs_b, swing)
        obs_b, r_b, term_b, trunc_b, _ = batch.step(a)
        bodies = batch.task.game.bodies
        for i, single in enumerate(singles):
            obs, r, term, trunc, info = single.step(a[i])
            assert same_bits(np.float64(r), r_b[i]) and (term, trunc) == (term_b[i], trunc_b[i])
            b = single.task.game.bodies
            if not (term or trunc):  # (the batch's env i has been reset already)
                for x, y in zip(_body_state(b, 0), _body_state(bodies, i), strict=True):
                    assert same_bits(x, y), (step, i)
            seen["hit"] += info["hit"]
            ev = single.task.game.events
            if info["hit"]:  # the shot: along the racket's velocity at min(60, 5 |v|) m/s
                racket = ev.hit_velocity[0, 0]
                speed = min(60.0, 5.0 * np.linalg.norm(racket))
                assert single.task.game.shuttle.shot_speed[0] == pytest.approx(speed)
                seen["shot_speed"] += 1
            seen["landed"] += bool(single.task.game.events.landed.any())
            seen["saturated"] += bool(b._side.any())
            seen["stopped"] += bool(np.any((b.qpos == b.lo) | (b.qpos == b.hi)))
            if term or trunc:
                seen["episodes"] += 1
                obs, _ = single.reset()
            assert same_bits(obs, obs_b[i]), (step, i)
    assert seen["episodes"] >= 10 and seen["saturated"] >= 400, seen
    if kind == "scripted":
        assert seen["hit"] >= 5 and seen["landed"] >= 5 and seen["shot_speed"] >= 5, seen
    if kind == "extreme":
        assert seen["stopped"] >= 100, seen


def test_two_player_games_of_a_batch_replay_games_alone():
    n, seed = 3, 21
    batch = Game(n, 2, seed=seed, bodies=HumanLikeBodies(n, 2))
    alone = [Game(1, 2, seed=seed + i, bodies=HumanLikeBodies(1, 2)) for i in range(n)]
    for g in (batch, *alone):
        g.reset(np.arange(g.n_envs))
    rng = np.random.default_rng(2)
    saturated = rallies = 0
    for step in range(300):
        a = rng.uniform(-1, 1, (n, 2, N_ACTIONS))
        if step % 4 == 0:
            a[..., 10:] = rng.choice([-1.0, 1.0], (n, 2, 5))
        batch.step(a)
        for i, g in enumerate(alone):
            g.step(a[i:i + 1])
            for x, y in zip(_body_state(g.bodies, 0), _body_state(batch.bodies, i),
                            strict=True):
                assert same_bits(x, y), (step, i)
            assert same_bits(g.shuttle.motion[:, 0], batch.shuttle.motion[:, i]), (step, i)
        saturated += int(np.count_nonzero(batch.bodies._side.any(axis=-1)))
        ended = np.flatnonzero(~batch.state.in_play)
        if len(ended):
            rallies += len(ended)
            batch.reset(ended)
            for i in ended:
                alone[i].reset(np.array([0]))
    assert saturated > 300 and rallies >= 3, (saturated, rallies)


def test_the_servo_keeps_its_limits_and_reaches_the_speeds_it_wants():
    """Torques stay within +-strength (zero strength: exactly zero); a player with no
    saturated joint and no joint at a stop ends the step at the servo's desired speeds (the
    step's exact solve of M a + bias = tau: nothing else in the step gives that)."""
    n, p = 16, 2
    b = HumanLikeBodies(n, p)
    rng = np.random.default_rng(7)
    b.reset(np.arange(n), rng.uniform(-6, -1, (n, p)), rng.uniform(-1, 1, (n, p, N_JOINTS)))
    reached = 0
    rate = b._constants[0]["max_rate"]
    for k in range(200):
        if k % 5 == 0:  # targets near the pose or anywhere; some players limp
            a = rng.uniform(-1, 1, (n, p, N_ACTIONS))
            near = 2.0 * (b.qpos + rng.uniform(-0.05, 0.05, b.qpos.shape) - b.lo) / (b.hi - b.lo)
            a[..., 2:10] = np.where(rng.random((n, p, 1)) < 0.7, np.clip(near - 1.0, -1, 1),
                                    a[..., 2:10])
            a[..., 10:] = np.where(rng.random((n, p, 1)) < 0.2, -1.0, a[..., 10:])
            b.set_actions(a)
        b._sync()
        q = b.qpos.copy()
        diag = b._mass[b._m_index[..., np.arange(8), np.arange(8)]]
        e = b.target - q
        speed = np.minimum(np.sqrt(2.0 * BRAKE_SHARE * b.torque_limit / diag * np.abs(e)),
                           np.minimum(np.abs(e) / b.dt, rate))
        b.physics_step()
        assert np.all(np.abs(b.torque) <= b.torque_limit)
        assert np.all(b.torque[b.torque_limit == 0.0] == 0.0)
        free = ~b._side.any(axis=-1) & ~np.any((b.qpos == b.lo) | (b.qpos == b.hi), axis=-1)
        want = np.copysign(speed, e)
        np.testing.assert_allclose(b.qvel[free], want[free], rtol=1e-9, atol=1e-9)
        reached += int(free.sum())
        held = b._side != 0
        assert np.all(b.torque[held] == (b._side * b.torque_limit)[held])
    assert reached > 300, reached
    assert humanlike_step.compiled_step().signatures  # one compiled step, already made


def test_a_copy_mid_episode_keeps_replaying():
    env = HumanLikeReturnEnv()
    rng = np.random.default_rng(0)
    env.reset(seed=4)
    for _ in range(7):
        env.step(rng.uniform(-1, 1, N_ACTIONS).astype(np.float32))
    copy = pickle.loads(pickle.dumps(env))
    for a in rng.uniform(-1, 1, (300, N_ACTIONS)).astype(np.float32):
        (obs, rest), (again, again_rest) = play(env, a), play(copy, a)
        assert same_bits(obs, again) and rest == again_rest


def _approach_counts(trace):
    """The approach shaping's counts (``simple_return._outcome``) on arrays: steps that closed
    in on the shuttle before the first hit, and the other live steps before it."""
    todo = trace.live & ~trace.has_hit[..., 0]
    closer = todo & trace.moved[..., 0] & (trace.gap[1:, :, 0] < trace.gap[:-1, :, 0])
    good = np.count_nonzero(closer, axis=0)
    return good, np.count_nonzero(todo, axis=0) - good


@pytest.mark.slow
def test_traced_games_replay_a_batch():
    """Each physics step's trace (``Game.trace``): each game alone as the env of a batch
    seeded alike, through steps that close in on the shuttle and steps that do not."""
    games = [Game(1, 1, seed=5 + i, bodies=HumanLikeBodies(1, 1)) for i in range(2)]
    batch = Game(2, 1, seed=5, bodies=HumanLikeBodies(2, 1))
    for g in (*games, batch):
        g.reset(np.arange(g.n_envs))
    rng = np.random.default_rng(5)
    good = bad = rallies = 0
    for step in range(400):
        a = rng.uniform(-1, 1, (1, 1, N_ACTIONS))
        if step % 3 == 0:  # the hips stay put: steps that do not close in
            a[..., :2] = 0.0
        for g, x in zip(games, (a, -a), strict=True):
            g.step(x)
        batch.step(np.concatenate([a, -a]))
        counts = _approach_counts(batch.trace)
        for i, g in enumerate(games):
            for x, y in ((g._gap, batch._gap[i:i + 1]), (g._q[:, :1], batch._q[i:i + 1, :1]),
                         (g.shuttle.motion, batch.shuttle.motion[:, i:i + 1]),
                         (g.trace.gap, batch.trace.gap[:, i:i + 1]),
                         (g.trace.moved, batch.trace.moved[:, i:i + 1]),
                         (g.trace.live, batch.trace.live[:, i:i + 1]),
                         (g.trace.has_hit, batch.trace.has_hit[:, i:i + 1])):
                assert same_bits(x, y), (step, i)
        good += int(counts[0].sum())
        bad += int(counts[1].sum())
        ended = np.flatnonzero(~batch.state.in_play)
        rallies += len(ended)
        for i in ended:
            games[i].reset(np.array([0]))
        if len(ended):
            batch.reset(ended)
    assert good > 50 and bad > 50 and rallies >= 5, (good, bad, rallies)


def test_the_step_constants_are_named_and_checked():
    """The step's constants are a named record: a missing name or a number where a joint's
    row belongs is refused rather than filled in."""
    from rallysim.core import humanlike_step as hs
    b = HumanLikeBodies(2, 1)
    k = b._constants[0]
    assert k["dt"] == b.dt and k["rounds"] == 8 and k["hips_height"] == b.hips_height
    assert np.array_equal(k["lo"], b.lo) and np.array_equal(k["hi"], b.hi)
    values = {name: k[name] for name in hs.CONSTANTS_DTYPE.names}
    assert hs.body_constants(**values).tobytes() == b._constants.tobytes()
    with pytest.raises(ValueError, match="lo must have shape"):
        hs.body_constants(**{**values, "lo": 0.0})
    with pytest.raises(ValueError, match="constants are"):
        hs.body_constants(**{k: v for k, v in values.items() if k != "dt"})
