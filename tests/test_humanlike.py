"""HUMAN-LIKE player and RallySim/HumanLikeReturn-v0 (docs/reference.md §10, issue 5): model,
servo, limits, spaces, goals, a scripted swing, determinism, API checks."""

import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from rallysim.core.game import Game
from rallysim.core.humanlike import (
    JOINT_GROUP,
    JOINTS,
    N_ACTIONS,
    HumanLikeBodies,
    humanlike_geometry,
)
from rallysim.envs.humanlike_return_v0 import HumanLikeReturnEnv, HumanLikeReturnVectorEnv
from rallysim.policies.scripted_swing import ScriptedSwing
from tests.conftest import check_seeded_and_batched, humanlike_swing_at_face

# docs/reference.md §10's joint table, degrees, in JOINTS order
SPEC_RANGES = [(-15, 15), (-15, 15), (-90, 90), (-75, 75), (-85, 85), (0, 100), (-90, 90),
               (-25, 25)]


def actions_for(b: HumanLikeBodies, targets=0.0, strength=1.0, move=0.0) -> np.ndarray:
    a = np.zeros((b.n_envs, b.n_players, N_ACTIONS))
    a[..., 0:2] = move
    a[..., 2:10] = targets
    a[..., 10:] = strength
    return a


def run(b: HumanLikeBodies, actions: np.ndarray, steps: int, check=None) -> None:
    b.set_actions(actions)
    for _ in range(steps):
        b.physics_step()
        if check is not None:
            check(b)


# -- the model -----------------------------------------------------------------------------------
def test_model_matches_spec_and_documented_values():
    g = humanlike_geometry()
    assert np.degrees(np.stack([g["joint_lo"], g["joint_hi"]], 1)) == pytest.approx(
        np.array(SPEC_RANGES, float))
    assert g["face_half"] == pytest.approx([0.10, 0.025, 0.115])  # 0.20 x 0.05 x 0.23 box
    assert g["group_max_torque"] == pytest.approx([100, 100, 60, 40, 10])
    mass = g["body_mass"]
    assert mass["spine"] == 8.0 and mass["chest"] == pytest.approx(8.0 + 4.5 + 3.2 + 0.45)
    assert (mass["upper_arm"], mass["lower_arm"]) == (2.0, 1.2)
    assert mass["hand"] == pytest.approx(0.45 + 0.09)  # hand + racket
    b = HumanLikeBodies(1, 1)
    b.reset(np.array([0]), np.array([[-3.0]]), base_y=np.array([[0.5]]))
    face = b.face_centre()[0, 0]
    # T-pose: the face centre 0.19 + 0.28 + 0.26 + 0.52 m to the right of the spine, at
    # shoulder height (hips 0.9 + 0.52)
    assert face == pytest.approx([-3.0, 0.5 - 1.25, 1.42])


# -- the servo and the limits --------------------------------------------------------------------
def test_joint_limits_hold_under_extreme_actions():
    b = HumanLikeBodies(8, 2)  # both sides of the net
    b.reset(np.arange(8), np.full((8, 2), -3.0))
    rng = np.random.default_rng(0)
    worst = {"over": 0.0, "speed": 0.0}

    def check(bb):
        assert np.all(np.isfinite(bb.qpos)) and np.all(np.isfinite(bb.qvel))
        worst["over"] = max(worst["over"], np.max(np.maximum(bb.qpos - bb.hi, bb.lo - bb.qpos)))
        worst["speed"] = max(worst["speed"], np.abs(bb.qvel).max())

    for k in range(210):  # 21 s: random +-1 actions, then bang-bang at full and 10 % strength
        if k < 70:
            a = rng.choice([-1.0, 1.0], (8, 2, N_ACTIONS))
        else:
            a = np.full((8, 2, N_ACTIONS), 1.0 if k % 20 < 10 else -1.0)
            a[..., 10:] = 1.0 if k < 140 else -0.8
        run(b, a, 5, check)
    assert worst["over"] <= 1e-12
    assert worst["speed"] <= 50.0 + 1e-9
    assert np.all(b.hips[..., 0] >= -6.5) and np.all(b.hips[..., 0] <= -0.5)
    assert np.all(np.abs(b.hips[..., 1]) <= 2.8)


def test_full_strength_servo_reaches_targets_within_its_limits():
    b = HumanLikeBodies(16, 1)
    b.reset(np.arange(16), np.full((16, 1), -3.0))
    rng = np.random.default_rng(1)
    targets = rng.uniform(-1, 1, (16, 1, 8))
    strength = rng.uniform(0.0, 1.0, (16, 1, 5))  # 50-100 % strength

    def within(bb):
        assert np.all(np.abs(bb.torque) <= bb.torque_limit + 1e-9)

    a = actions_for(b, targets)
    a[..., 10:] = strength
    run(b, a, 50, within)  # 1 s
    assert np.abs(b.qpos - b.target).max() < 1e-6
    assert np.abs(b.qvel).max() < 1e-6
    # holding still against gravity takes exactly the gravity torques
    assert b.torque == pytest.approx(b._bias, abs=1e-6)


def test_zero_strength_gives_no_drive_torque():
    # without gravity a limp player at rest stays exactly still whatever its targets
    b = HumanLikeBodies(4, 1)
    b.model.opt.gravity[:] = 0.0
    b.reset(np.arange(4), np.full((4, 1), -3.0), np.full((4, 1, 8), 0.2))
    before = b.qpos.copy()

    def limp(bb):
        assert np.all(bb.torque == 0.0) and np.all(bb.data.qfrc_actuator == 0.0)

    run(b, actions_for(b, np.random.default_rng(2).choice([-1.0, 1.0], (4, 1, 8)), -1.0), 25,
        limp)
    assert np.array_equal(b.qpos, before) and np.all(b.qvel == 0.0)
    # with gravity the arm falls exactly as a passive MuJoCo model does (no drive at all)
    b = HumanLikeBodies(1, 1)
    b.reset(np.array([0]), np.array([[-3.0]]))
    passive = mujoco.MjData(b.model)
    passive.qpos[:], passive.mocap_pos[:] = b.data.qpos, b.data.mocap_pos
    run(b, actions_for(b, 1.0, -1.0), 4, limp)  # 0.08 s: no joint reaches a stop yet
    for _ in range(4):
        mujoco.mj_step(b.model, passive)
    assert np.abs(b.qpos - passive.qpos.reshape(b.qpos.shape)).max() < 1e-12
    assert b.qpos[0, 0, 2] < -0.05  # the arm (upper arm x) did fall


def test_strength_scales_the_torque_limit():
    b = HumanLikeBodies(5, 1)
    b.reset(np.arange(5), np.full((5, 1), -3.0))
    levels = np.linspace(-1, 1, 5)
    a = actions_for(b, 1.0)
    a[..., 10:] = levels[:, None, None]
    b.set_actions(a)
    expected = (levels[:, None] + 1) / 2 * np.array([100, 100, 60, 60, 60, 40, 10, 10])
    assert b.torque_limit[:, 0] == pytest.approx(expected)
    peak = np.zeros_like(b.torque)
    for _ in range(10):
        b.physics_step()
        peak = np.maximum(peak, np.abs(b.torque))
    assert np.all(peak <= b.torque_limit + 1e-9)
    # a swing to the far end of every range saturates the trunk, shoulder swing and elevation,
    # elbow and wrist deviation (the twist and wrist flexion move too little inertia to need it)
    heavy = [0, 1, 2, 3, 5, 7]
    assert peak[1:, 0, heavy] == pytest.approx(b.torque_limit[1:, 0, heavy])
    assert np.all(peak[0] == 0.0)


def test_player_one_mirrors_player_zero():
    b = HumanLikeBodies(2, 2)
    b.reset(np.arange(2), np.full((2, 2), -2.0), base_y=np.full((2, 2), 0.7))
    run(b, actions_for(b, np.linspace(-0.9, 0.9, 8), 0.5, move=0.4), 12)
    own = b.face_centre()
    assert own[:, 0] == pytest.approx(own[:, 1], abs=1e-12)
    world = b.data.site_xpos.reshape(2, 2, 3)
    assert world[:, 1] == pytest.approx(own[:, 1] * [-1, -1, 1], abs=1e-12)
    v0, w0, r0, q0 = (x[:, 0] for x in b.body_states())
    v1, w1, r1, q1 = (x[:, 1] for x in b.body_states())
    for x, y in ((v0, v1), (w0, w1), (r0, r1), (q0, q1)):
        assert x == pytest.approx(y, abs=1e-10)


def test_face_frame_and_racket_velocity():
    """The tested point is the shuttle in the face box's frame (across, normal, along the
    handle) about its centre; the racket velocity is the centre's displacement / dt."""
    g = Game(1, 1, bodies=HumanLikeBodies(1, 1))
    b = g.bodies
    b.reset(np.array([0]), np.array([[-3.0]]))
    run(b, actions_for(b, 0.5), 3)  # mid-swing
    rot = b.data.site_xmat.reshape(3, 3)  # columns: across, normal, along the handle
    for offset, expected in ((0.0, [0.0, 0.0, 0.0]), (1.0, [0.0, 0.03, 0.05])):
        g.shuttle.pos[0] = b.face_centre()[0, 0] + offset * (0.03 * rot[:, 1] + 0.05 * rot[:, 2])
        g._refresh()
        assert g._q[0, 0] == pytest.approx(expected, abs=1e-12)
    # a hit's racket velocity (the compiled steps') is the face centre's displacement over
    # the physics step of the hit / dt, in the hitter's own frame
    b.set_actions(humanlike_swing_at_face(g))
    g.events = g._new_events.take()
    for _ in range(5):
        before = b.face_centre()
        g._run(1)
        if g.events.hit[0, 0]:
            break
    assert g.events.hit[0, 0]
    v = g.events.hit_velocity[0, 0]
    assert v == pytest.approx(((b.face_centre() - before) / 0.02)[0, 0], abs=1e-12)
    assert np.linalg.norm(v) > 1.0


def test_body_velocities_match_mujoco():
    b = HumanLikeBodies(2, 2)
    b.reset(np.arange(2), np.full((2, 2), -3.0))
    run(b, actions_for(b, np.random.default_rng(3).uniform(-1, 1, (2, 2, 8)), 1.0, move=0.5), 3)
    vel, ang, _, _ = b.body_states()
    res = np.zeros(6)
    for e in range(2):
        for p in range(2):
            f = np.array([b.forward[e, p], b.forward[e, p], 1.0])
            for k, bid in enumerate(b._body_ids[e, p]):
                mujoco.mj_objectVelocity(b.model, b.data, mujoco.mjtObj.mjOBJ_BODY, int(bid),
                                         res, 0)
                # MuJoCo's is at the body's centre of mass; ours at its origin, plus the hips
                at_origin = res[3:] + np.cross(res[:3], b.data.xpos[bid] - b.data.xipos[bid])
                hips = np.append(b.hips_velocity[e, p], 0.0)
                assert vel[e, p, k] == pytest.approx(at_origin * f + hips, abs=1e-9)
                assert ang[e, p, k] == pytest.approx(res[:3] * f, abs=1e-9)
    assert np.abs(b.hips_velocity) == pytest.approx(2.5)


# -- the task ------------------------------------------------------------------------------------
@pytest.mark.filterwarnings("ignore:.*alternative render modes")  # not registered here
def test_spaces_and_env_checker():
    env = HumanLikeReturnEnv()
    assert env.observation_space.shape == (85,) and env.action_space.shape == (15,)
    assert env.observation_space.dtype == np.float32 and env.action_space.dtype == np.float32
    check_env(env)
    vec = HumanLikeReturnVectorEnv(3)
    assert vec.observation_space.shape == (3, 85) and vec.action_space.shape == (3, 15)
    obs, _ = vec.reset(seed=0)
    rng = np.random.default_rng(0)
    for _ in range(60):
        assert obs.dtype == np.float32 and np.all(np.abs(obs) <= 1.0)
        obs, *_ = vec.step(rng.uniform(-3, 3, (3, 15)))


def test_target_velocity_sampling_ranges():
    env = HumanLikeReturnVectorEnv(100)
    v = np.concatenate([env.reset(seed=s)[1]["target_velocity"] for s in (0, 100, 200, 300)])
    speed = np.linalg.norm(v, axis=1)
    elev = np.degrees(np.arcsin(v[:, 2] / speed))
    azim = np.degrees(np.arctan2(v[:, 1], v[:, 0]))
    for x, lo, hi in ((speed, 1.5, 4.5), (elev, 40.0, 50.0), (azim, -30.0, 30.0)):
        assert lo <= x.min() < lo + 0.05 * (hi - lo)  # spans the whole range ...
        assert hi - 0.05 * (hi - lo) < x.max() <= hi
        assert abs(np.median(x) - (lo + hi) / 2) < 0.1 * (hi - lo)  # ... uniformly
    obs = env.task.observe()
    assert obs[:, 82:85] == pytest.approx(v[300:] / 5.0, abs=1e-6)


def test_serve_follows_spec():
    env = HumanLikeReturnVectorEnv(100)
    env.reset(seed=1)
    sh = env.task.game.shuttle
    assert np.linalg.norm(sh.vel, axis=1) == pytest.approx(15.0)
    d = sh.vel * (3.0 / -sh.vel[:, :1])  # the direction scaled to x = -3
    assert d[:, 0] == pytest.approx(-3.0)
    assert np.all(np.abs(d[:, 1]) <= 0.5) and np.all((d[:, 2] >= 2.0) & (d[:, 2] <= 3.0))
    assert np.all((sh.pos[:, 0] >= 1.0) & (sh.pos[:, 0] <= 6.0))
    assert np.all(np.abs(sh.pos[:, 1]) <= 1.0)
    assert np.all((sh.pos[:, 2] >= 1.0) & (sh.pos[:, 2] <= 1.5))


def scripted_episodes(env, controller, decisions=60):
    """Run every environment of ``env`` (same-step autoreset) for its first episode."""
    obs, info = env.reset(seed=0)
    n = env.num_envs
    done, hit = np.zeros(n, bool), np.zeros(n, bool)
    reward, velocity = np.zeros(n), np.full((n, 3), np.nan)
    for _ in range(decisions):
        obs, r, term, trunc, inf = env.step(controller(obs))
        live = ~done
        reward[live] += r[live]
        new = inf["hit"] & live
        hit |= new
        velocity[new] = inf["racket_velocity"][new]
        done |= term | trunc
        if done.all():
            break
    return hit, reward, velocity, info["target_velocity"]


def test_scripted_swing_hits_most_serves_and_rewards_follow_the_rule():
    env = HumanLikeReturnVectorEnv(20, autoreset_mode="same_step")
    hit, reward, v, target = scripted_episodes(env, ScriptedSwing())
    assert hit.sum() >= 16  # of 20 seeded serves (it hits all 20 of these)
    d = np.linalg.norm(v[hit] - target[hit], axis=1)
    assert reward[hit] == pytest.approx(0.5 * (1.0 + np.exp(-1.5 * d)))
    assert np.all(reward[~hit] == 0.0)
    assert np.all(np.linalg.norm(v[hit], axis=1) > 1.0)  # a swing, not a parked racket
    # Replayed with the target set to the velocity it hit with: d = 0, the full reward 1.0.
    env2 = HumanLikeReturnVectorEnv(20, autoreset_mode="same_step")
    targets = np.where(hit[:, None], v, target)
    orig_reset = env2.reset
    env2.reset = lambda seed=None: orig_reset(seed=seed, options={"target_velocity": targets})
    hit2, reward2, v2, _ = scripted_episodes(env2, ScriptedSwing())
    assert np.array_equal(hit, hit2) and np.array_equal(v[hit], v2[hit])
    assert reward2[hit] == pytest.approx(1.0, abs=1e-12)


def test_hit_info_on_a_crafted_hit():
    env = HumanLikeReturnEnv()
    env.reset(seed=0, options={"hips_position": [-3.0, 0.0], "target_velocity": [2, 0, 2]})
    g = env.task.game
    face = env.task.bodies.face_centre()[0, 0]
    g.shuttle.pos[0] = face + np.array([0.0, 0.0, 0.05])  # resting on the racket
    g.shuttle.vel[0] = 0.0
    g._refresh()
    a = np.zeros(15)
    a[2:10] = [0, 0, 0.3, 0, 0, -1, 0, 0]  # raise the arm
    a[10:] = 1.0
    _, r, _, _, info = env.step(a)
    assert info["hit"]
    v = info["racket_velocity"]
    assert v[2] > 1.0  # rising
    d = np.linalg.norm(v - [2, 0, 2])
    assert info["velocity_error"] == pytest.approx(d)
    assert r == pytest.approx(0.5 * (1 + np.exp(-1.5 * d)))
    cos = v @ [2, 0, 2] / np.linalg.norm(v) / np.sqrt(8)
    assert info["angle_error"] == pytest.approx(np.degrees(np.arccos(cos)))
    assert info["speed_error"] == pytest.approx(np.linalg.norm(v) / np.sqrt(8) - 1)


def test_same_seed_same_trajectory_and_vector_matches_single():
    actions = np.random.default_rng(0).uniform(-1, 1, (25, 3, 15))
    check_seeded_and_batched(HumanLikeReturnEnv, HumanLikeReturnVectorEnv, actions)


def test_bad_input_raises_and_leaves_state_untouched():
    env = HumanLikeReturnVectorEnv(2, seed=0)
    env.reset(seed=0)
    g = env.task.game
    before = (g.shuttle.pos.copy(), env.task.bodies.qpos.copy(), env.task.elapsed.copy())
    for bad, word in [(np.full((2, 15), np.nan), "NaN"), (np.zeros((2, 3)), "shape"),
                      (np.zeros(15), "shape"), ("swing", "real numbers")]:
        with pytest.raises(ValueError, match=word):
            env.step(bad)
    assert np.array_equal(before[0], g.shuttle.pos)
    assert np.array_equal(before[1], env.task.bodies.qpos)
    assert np.array_equal(before[2], env.task.elapsed)
    single = HumanLikeReturnEnv()
    with pytest.raises(ValueError, match="target_velocity"):
        single.reset(options={"goal": 1})
    with pytest.raises(ValueError, match=r"\[-5, 5\]"):
        single.reset(options={"target_velocity": [9.0, 0.0, 0.0]})
    with pytest.raises(ValueError, match="finite"):
        single.reset(options={"hips_position": [np.nan, 0.0]})
    with pytest.raises(ValueError, match="'paper', 'paper-alg1', 'aero'"):
        HumanLikeReturnEnv(shuttle="wind")
    single.reset(seed=0)
    with pytest.raises(ValueError, match="inf"):
        single.step(np.full(15, np.inf))


def test_clipping_truncation_and_autoreset_info():
    a, b = HumanLikeReturnEnv(), HumanLikeReturnEnv()
    a.reset(seed=3)
    b.reset(seed=3)
    assert np.array_equal(a.step(np.full(15, 4.0))[0], b.step(np.ones(15))[0])
    env = HumanLikeReturnEnv(max_decisions=3)
    env.reset(seed=0)
    out = [env.step(np.zeros(15)) for _ in range(3)]
    assert [o[3] for o in out] == [False, False, True] and not any(o[2] for o in out)
    with pytest.raises(RuntimeError, match="reset"):
        env.step(np.zeros(15))
    vec = HumanLikeReturnVectorEnv(2, max_decisions=1)
    vec.reset(seed=0)
    _, _, _, trunc, _ = vec.step(np.zeros((2, 15)))
    assert trunc.all()
    _, r, _, _, info = vec.step(np.zeros((2, 15)))  # the reset step
    assert np.all(r == 0) and np.all(np.isnan(info["racket_velocity"]))
    assert not info["_racket_velocity"].any()
    assert info["target_velocity"] == pytest.approx(vec.task.goal)


def test_joint_and_group_tables_agree():
    assert len(JOINTS) == 8 and N_ACTIONS == 15
    assert np.bincount(JOINT_GROUP).tolist() == [1, 1, 3, 1, 2]
