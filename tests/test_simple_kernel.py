"""The compiled physics steps (``rallysim.core.kernels``) of SIMPLE games: a batch's env i
replays a single env seeded s + i; the judging's numbers are as the rules say; each player
kind runs its own compiled steps, and nothing else runs them."""

from __future__ import annotations

import copy
import pickle

import numpy as np
import pytest

from rallysim.core import native
from rallysim.core.court import Court
from rallysim.core.game import PHYSICS_DT, Game
from rallysim.core.humanlike import HumanLikeBodies
from rallysim.core.kernels import simple
from rallysim.core.kernels.humanlike import HumanLikeKernel
from rallysim.core.kernels.simple import SimpleKernel
from rallysim.core.shuttle import RADIUS
from rallysim.core.simple_obs import POSITION_CENTRE, POSITION_SCALE, player_observations
from rallysim.core.tasks.simple_return import OBS_CENTRE, OBS_SCALE
from rallysim.envs.simple_return_v0 import SimpleReturnEnv, SimpleReturnVectorEnv
from tests.kernels import play, same_bits


def test_a_batchs_env_i_replays_a_single_env_seeded_s_plus_i():
    batch = SimpleReturnVectorEnv(3, autoreset_mode="same_step")
    singles = [SimpleReturnEnv() for _ in range(3)]
    obs_b, _ = batch.reset(seed=20)
    for i, env in enumerate(singles):
        assert same_bits(env.reset(seed=20 + i)[0], obs_b[i])
    rng = np.random.default_rng(1)
    for step in range(300):
        a = rng.uniform(-1, 1, (3, 3)).astype(np.float32)
        obs_b, r_b, term_b, trunc_b, _ = batch.step(a)
        for i, env in enumerate(singles):
            o, r, term, trunc, _ = env.step(a[i])
            assert same_bits(np.float64(r), r_b[i]) and (term, trunc) == (term_b[i], trunc_b[i])
            if term or trunc:
                o, _ = env.reset()
            assert same_bits(o, obs_b[i]), (step, i)


def _one_shuttle(shuttle: str = "paper", p: int = 1, **kw) -> Game:
    """One game whose shuttle is placed by hand (its arm down and still, nobody armed)."""
    g = Game(1, p, shuttle=shuttle, seed=0, **kw)
    g.reset(np.array([0]))
    g.state.armed[:] = False
    return g


def _place(g: Game, pos: tuple, vel: tuple) -> None:
    g.shuttle.pos[0], g.shuttle.vel[0] = pos, vel
    g._refresh()


def test_a_landing_is_interpolated_judged_and_stops_play():
    g = _one_shuttle()
    _place(g, (2.0, 1.0, 0.05), (3.0, 0.5, -4.0))
    p0, v = g.shuttle.pos[0].copy(), g.shuttle.vel[0].copy()
    g._physics_step()
    # the paper flight's step, then the point where the centre crossed z = 0
    v_new = v.copy()
    v_new[2] -= 9.81 * PHYSICS_DT
    v_new *= 1.0 - 1.5 * PHYSICS_DT
    p1 = p0 + v_new * PHYSICS_DT
    t = (0.0 - p0[2]) / (p1[2] - p0[2])
    ev = g.events
    assert ev.landed[0] and not g.in_play[0] and not g.armed.any()
    np.testing.assert_allclose(ev.land_point[0], [*(p0[:2] + t * (p1[:2] - p0[:2])), 0.0],
                               atol=1e-12)
    assert ev.land_side[0] == 1 and ev.land_in[0]  # 2 m beyond the net, in the paper zone
    assert (g.shuttle.vel[0] == 0.0).all()
    held = g.shuttle.pos[0].copy()
    g._physics_step()  # out of play: held where it landed
    assert (g.shuttle.pos[0] == held).all() and not g.events.landed[1:].any()


def test_landing_out_sides_and_the_full_court():
    court = Court.from_mjcf()
    for shuttle, x, y, side, inside in (("paper", -7.0, 0.0, 0, False),
                                        ("paper", 0.2, 0.0, 1, False),  # before the zone
                                        ("aero", 0.2, 0.0, 1, True),  # the full half court
                                        ("aero", 3.0, court.half_width + 0.1, 1, False)):
        g = _one_shuttle(shuttle)
        _place(g, (x, y, 0.01), (0.0, 0.0, -1.0))
        g._physics_step()
        assert g.events.landed[0] and g.events.land_side[0] == side, shuttle
        assert g.events.land_in[0] == inside, (shuttle, x, y)


def test_the_net_rearms_two_players_and_blocks_an_aero_shuttle():
    court = Court.from_mjcf()
    g = _one_shuttle(p=2)
    _place(g, (-0.3, 0.0, 1.0), (10.0, 0.0, 0.0))
    g._physics_step()
    assert g.events.net_touch[0] and g.net_touched[0] and g.armed.all()
    assert g.shuttle.vel[0, 0] > 0  # the paper net only notes the touch
    g = _one_shuttle("aero")
    _place(g, (-0.3, 0.2, 1.0), (10.0, 0.0, 0.0))
    g._physics_step()
    assert g.events.net_touch[0] and not g.armed.any()  # (one player: nobody re-armed)
    face = court.net_half_thickness + RADIUS
    assert g.shuttle.pos[0, 0] == -face and g.shuttle.vel[0, 0] == 0.0
    g._physics_step()  # resting against the net: it only falls
    assert g.shuttle.pos[0, 0] == -face and not g.events.net_touch[1:].any()


def test_a_hit_sends_the_shuttle_at_twice_the_face_velocity_and_passes_the_turn():
    g = _one_shuttle(p=2)
    b = g.bodies
    b.theta[0, 0], b.omega[0, 0] = 0.3, 6.0
    b.target[0, 0], b.torque_limit[0, 0], b._neg_limit[0, 0] = 0.3 + 6.0 * PHYSICS_DT, 0.0, -0.0
    g.state.armed[0, 0] = True
    # the shuttle just ahead of the face centre's path, in player 0's frame
    s, c = np.sin(0.33), np.cos(0.33)
    centre = (b.base_x[0, 0] + b.face_offset * s, 0.0, b.pivot_z + b.face_offset * c)
    _place(g, (centre[0] + 0.05, 0.0, centre[2]), (0.0, 0.0, 0.0))
    g._physics_step()
    ev = g.events
    assert ev.hit[0, 0] and not ev.hit[0, 1] and g.hits[0] == 1 and g.last_hitter[0] == 0
    assert g.armed[0].tolist() == [False, True] and g.has_hit[0].tolist() == [True, False]
    w = b.omega[0, 0]
    assert ev.hit_speed[0, 0] == pytest.approx(b.face_offset * abs(w), rel=1e-12)
    racket = ev.hit_velocity[0, 0]
    assert racket[1] == 0.0 and np.hypot(racket[0], racket[2]) == pytest.approx(
        ev.hit_speed[0, 0], rel=1e-12)
    np.testing.assert_array_equal(g.shuttle.vel[0], 2.0 * racket)  # player 0: world = own
    assert g.shuttle.shot_speed[0] == pytest.approx(2.0 * ev.hit_speed[0, 0], rel=1e-12)


def test_the_hit_cap_ends_the_judging_of_a_rally():
    g = _one_shuttle(max_hits=1)
    g.state.hits[0] = 1
    _place(g, (2.0, 0.0, 0.01), (0.0, 0.0, -1.0))
    g._physics_step()  # below the floor, but the rally reached its cap: nothing counts
    assert not g.events.landed[0] and g.in_play[0]


def test_each_kind_of_player_runs_its_compiled_steps_for_every_batch_and_flight():
    for n, p in ((1, 1), (3, 1), (1, 2), (64, 2)):
        for shuttle in ("paper", "paper-alg1", "aero"):
            assert isinstance(Game(n, p, shuttle=shuttle)._kernel, SimpleKernel)
    assert isinstance(Game(1, 1, bodies=HumanLikeBodies(1, 1))._kernel, HumanLikeKernel)

    class Bodies:  # not a kind the compiled steps know
        n_envs, n_players = 1, 1

    with pytest.raises(TypeError, match="SimpleBodies or HumanLikeBodies"):
        Game(1, 1, bodies=Bodies())


def test_where_the_compiled_steps_cannot_be_had_the_first_step_says_why(monkeypatch):
    kernel = native.Kernel(lambda: (_ for _ in ()).throw(native.Unavailable("a test")))
    monkeypatch.setattr(SimpleKernel, "compiled", kernel)
    g = Game(2, 1)
    for _ in range(2):  # (the reason is kept)
        with pytest.raises(RuntimeError, match="compiled steps cannot run here: a test"):
            g.reset(np.arange(2))


def test_a_copy_mid_episode_keeps_replaying():
    env = SimpleReturnEnv(incoming="mixed")
    rng = np.random.default_rng(0)
    env.reset(seed=4)
    for _ in range(7):
        env.step(rng.uniform(-1, 1, 3).astype(np.float32))
    for twin in (pickle.loads(pickle.dumps(env)), copy.deepcopy(env)):
        assert twin.task.game.bodies.data._address != env.task.game.bodies.data._address
    twin = pickle.loads(pickle.dumps(env))
    for _ in range(300):
        a = rng.uniform(-1, 1, 3).astype(np.float32)
        one, two = play(env, a), play(twin, a)
        assert same_bits(one[0], two[0]) and one[1] == two[1]


def _numpy_observation(game, goal):
    """The low-level observation restated in NumPy from docs/reference.md §6: the oracle of the
    compiled one."""
    b, m = game.bodies, game.shuttle.motion
    theta, omega, f = b.theta[:, 0], b.omega[:, 0], b.forward[:, 0]
    fo, zero = b.face_offset, np.zeros_like(theta)
    raw = np.stack([b.base_x[:, 0], zero, np.full_like(theta, b.base_z),
                    np.cos(0.5 * theta), zero, np.sin(0.5 * theta), zero,
                    fo * omega * np.cos(theta), zero, -fo * omega * np.sin(theta),
                    f * m[0], f * m[1], m[2], f * m[3], f * m[4], m[5], goal], axis=1)
    return np.clip((raw - OBS_CENTRE) / OBS_SCALE, -1.0, 1.0).astype(np.float32)


def test_the_compiled_observation_is_numpys():
    """States well outside the observation's ranges, signed zeros and non-finite numbers: the
    compiled observation gives NumPy's bits of the same formula (clipped as np.clip clips, NaN
    kept)."""
    env = SimpleReturnVectorEnv(3)
    env.reset(seed=0)
    task, game = env.task, env.task.game
    b, sh = game.bodies, game.shuttle
    rng = np.random.default_rng(0)
    special = [0.0, -0.0, np.nan, np.inf, -np.inf, 1e300, -1.0, 1.0]
    clipped = {"low": 0, "high": 0, "nan": 0}
    for _ in range(1000):
        values = rng.normal(0.0, 10.0 ** rng.integers(-2, 3), (3, 10))
        # (not the arm angle: the C library's sine and cosine are NumPy's only where NumPy's
        # AVX-512 code is off, docs/numerics.md)
        values[:, rng.integers(1, 10)] = special[rng.integers(len(special))]
        b.theta[:, 0], b.omega[:, 0], b.base_x[:, 0] = values[:, :3].T
        sh.motion[:, :] = 10.0 * values[:, 3:9].T
        task.goal[:] = values[:, 9]
        with np.errstate(invalid="ignore", over="ignore"):  # inf * 0 and the like: NaN
            expected = _numpy_observation(game, task.goal)
        got = task.observe()
        assert same_bits(got, expected), values
        clipped["low"] += int((got == -1.0).sum())
        clipped["high"] += int((got == 1.0).sum())
        clipped["nan"] += int(np.isnan(got).sum())
    assert min(clipped.values()) > 100, clipped


def test_the_rally_and_the_task_share_the_observation():
    """A two-player game's observations are each player's own-frame view, by the same code as
    the low-level task's: player 1 sees the shuttle's x and y turned."""
    g = Game(2, 2, seed=3)
    g.reset(np.arange(2))
    g.step(np.full((2, 2, 3), 0.3), np.ones(2, bool))
    obs = player_observations(g)
    assert obs.shape == (2, 2, 16) and obs.dtype == np.float32
    m = g.shuttle.motion
    pos = (m[:3].T - POSITION_CENTRE) / POSITION_SCALE
    turned = (m[:3].T * [-1.0, -1.0, 1.0] - POSITION_CENTRE) / POSITION_SCALE
    assert same_bits(obs[:, 0, 10:13], np.clip(pos, -1, 1).astype(np.float32))
    assert same_bits(obs[:, 1, 10:13], np.clip(turned, -1, 1).astype(np.float32))
    assert same_bits(obs[:, :, 0], np.clip((g.bodies.base_x - 0.0) / 10.0, -1, 1
                                           ).astype(np.float32))
    with pytest.raises(TypeError, match="SIMPLE players"):
        player_observations(Game(1, 1, bodies=HumanLikeBodies(1, 1)))


def test_one_compiled_signature_serves_every_game():
    env = SimpleReturnEnv()
    env.reset(seed=1)
    for _ in range(50):
        play(env, np.zeros(3, np.float32))
    for n, p in ((3, 2), (2, 1)):
        g = Game(n, p, shuttle="aero", max_hits=2)
        g.reset(np.arange(n))
        g.step(np.zeros((n, p, 3)), np.ones(n, bool))
    # one signature each: every game's arrays are of the same types
    steps, observation = simple.Compiled.get()
    assert len(steps.steps.signatures) == 1
    assert len(observation.signatures) == 1


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_actions_are_held_in_their_own_arithmetic(dtype):
    """SIMPLE players' actions become the drive's target, its torque limits and the base's
    step as NumPy's expressions over arrays of the actions' type give them (a policy's float32
    actions keep float32 arithmetic: the seeded rallies over MLP low levels depend on it)."""
    g = Game(4, 2)
    a = np.random.default_rng(3).uniform(-1, 1, (4, 2, 3)).astype(dtype)
    b = g.bodies
    b.set_actions(a)
    torque = (a[..., 1] + 1.0) * (0.5 * b.max_torque)
    assert same_bits(b.target, (a[..., 0] * b.max_target_angle).astype(np.float64))
    assert same_bits(b.torque_limit, torque.astype(np.float64))
    assert same_bits(b._neg_limit, (-torque).astype(np.float64))
    assert same_bits(b._base_step, (a[..., 2] * (b.max_base_speed * b.dt)).astype(np.float64))
    if dtype == np.float32:  # float32 and float64 arithmetic differ here, so this tells them apart
        wide = (a[..., 1].astype(np.float64) + 1.0) * (0.5 * b.max_torque)
        assert not same_bits(b.torque_limit, wide)
    with pytest.raises(ValueError, match="3 actions"):
        b.set_actions(np.zeros((4, 2, 2)))


def test_a_games_inputs_are_checked_before_anything_changes():
    g = Game(3, 1, seed=0)
    g.reset(np.arange(3))
    g.step(np.full((1, 1, 3), 0.7))  # one action for every game, as NumPy broadcasts
    assert same_bits(g.bodies.target, np.full((3, 1), 0.7 * g.bodies.max_target_angle))
    with pytest.raises(ValueError):
        g.step(np.full((5, 1, 3), 0.7))
    base_x = g.bodies.base_x.copy()
    with pytest.raises(IndexError):
        g.reset(np.array([1, 5]))
    assert same_bits(g.bodies.base_x, base_x)
    with pytest.raises(IndexError, match="receivers"):
        g.reset(np.array([0]), receiver=1)
    h = Game(2, 1, seed=0, bodies=HumanLikeBodies(2, 1))
    hips = h.bodies.hips.copy()
    with pytest.raises(IndexError, match="games"):
        h.reset(np.array([0, -1]))
    assert same_bits(h.bodies.hips, hips)
    two = Game(2, 2, seed=0)
    two.reset(np.arange(2), receiver=-1)  # an index: the last player
    assert two.armed.tolist() == [[False, True], [False, True]]
    with pytest.raises(ValueError, match="out"):
        simple.observations(g, np.zeros((3, 1, 0)), OBS_CENTRE[:16], OBS_SCALE[:16],
                            rows=np.array([0]))


def test_the_shaping_is_counted_from_the_trace():
    """The low-level task's approach shaping (``_outcome``): the trace's steps before the
    player's hit in which its base closed in on the shuttle, and the other live ones."""
    from rallysim.core.tasks.simple_return import SHAPING_BAD, SHAPING_GOOD, ReturnTask

    task = ReturnTask(16, seed=2)
    task.reset(np.arange(16))
    rng = np.random.default_rng(2)
    seen = set()
    for _ in range(200):
        _, term, trunc, info = task.step(rng.uniform(-1, 1, (16, 3)))
        t = task.game.trace
        todo = t.live & ~t.has_hit[..., 0]
        good = np.count_nonzero(todo & t.moved[..., 0] & (t.gap[1:, :, 0] < t.gap[:-1, :, 0]),
                                axis=0)
        bad = np.count_nonzero(todo, axis=0) - good
        assert same_bits(info["reward_shaping"], SHAPING_GOOD * good + SHAPING_BAD * bad)
        seen.update(zip(good.tolist(), bad.tolist(), strict=True))
        done = np.flatnonzero(term | trunc)
        if len(done):
            task.reset(done)
    assert len(seen) >= 6  # mixes of closing and not closing in


def test_a_reset_elsewhere_leaves_a_games_next_decision_alone():
    """A reset refreshes only the games it restarts: an aero shuttle stopped by the net in a
    decision's last physics step leaves its game's base-to-shuttle distance as the steps left
    it, and the next decision starts from there whether or not another game of the batch was
    reset in between (env i of a batch replays a single env)."""
    from rallysim.core.tasks.simple_return import ReturnTask

    def run(n: int) -> tuple[float, float]:
        task = ReturnTask(n, shuttle="aero", seed=0)
        task.reset(np.arange(n))
        g = task.game
        g.shuttle.pos[0], g.shuttle.vel[0] = [0.72, 0.0, 1.0], [-8.0, 0.0, 0.0]
        g._refresh()
        a = np.zeros((n, 3))
        a[:, 2] = 0.5
        _, _, _, info = task.step(a)
        assert info["net_touch"][0]
        # the distance the steps left: from before the net put the shuttle back
        assert g._gap[0, 0] != abs(g.shuttle.pos[0, 0] - g.bodies.base_x[0, 0])
        if n > 1:
            task.reset(np.arange(1, n))
        _, _, _, info = task.step(a)
        return float(info["reward_shaping"][0]), float(g._gap[0, 0])

    assert run(1) == run(2) == run(3)
