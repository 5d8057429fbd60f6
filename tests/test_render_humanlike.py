"""Rendering HUMAN-LIKE players: the whole pose is copied, the racket head is drawn where the
simulator has it, the target velocity's arrow is where the camera model says, and the env views'
render_mode works. Skipped as a whole only where no OpenGL backend can be created."""

from __future__ import annotations

import contextlib
import itertools
import warnings

import mujoco
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env

from rallysim.core.game import Game
from rallysim.core.humanlike import HumanLikeBodies, humanlike_geometry
from rallysim.envs.humanlike_return_v0 import HumanLikeReturnEnv, HumanLikeReturnVectorEnv
from rallysim.render import SceneRenderer
from rallysim.render.players import ARROW_SECONDS
from tests.conftest import gl_problem

BODIES = ("hips", "spine", "chest", "upper_arm", "lower_arm", "hand")


_PROBLEM = gl_problem()
pytestmark = pytest.mark.skipif(_PROBLEM is not None, reason=_PROBLEM or "")


# -- helpers ------------------------------------------------------------------------------------
def red(img: np.ndarray) -> np.ndarray:
    """The target arrow's colour: nothing else in a HUMAN-LIKE scene is saturated red."""
    return (img[..., 0] > 150) & (img[..., 1] < 40) & (img[..., 2] < 40)


def centroid(mask: np.ndarray) -> np.ndarray:
    """(column, row) centre of a mask in the pixel convention of ``SceneRenderer.project``."""
    rows, cols = np.nonzero(mask)
    return np.array([cols.mean() + 0.5, rows.mean() + 0.5])


def racket_head_mask(view: SceneRenderer, player: int = 0) -> np.ndarray:
    """Pixels where player ``player``'s racket head is drawn: the frame with it minus the frame
    with its geom moved to a hidden geom group."""
    gid = mujoco.mj_name2id(view.model, mujoco.mjtObj.mjOBJ_GEOM, f"p{player}_racket_head")
    group = int(view.model.geom_group[gid])
    shown = view.render_current()
    view.model.geom_group[gid] = 5  # MuJoCo draws groups 0-2 by default
    try:
        hidden = view.render_current()
    finally:
        view.model.geom_group[gid] = group
    return np.any(shown != hidden, axis=2)


def posed_game(n_players: int, hips: np.ndarray, pose_deg: np.ndarray) -> Game:
    """One environment with HUMAN-LIKE players at own-frame ``hips`` (P, 2) in joint angles
    ``pose_deg`` (P, 8)."""
    bodies = HumanLikeBodies(1, n_players)
    game = Game(1, n_players, seed=0, bodies=bodies)
    game.reset(np.array([0]), base_x=hips[None, :, 0], theta=0.0)
    bodies.reset(np.array([0]), hips[None, :, 0], np.radians(pose_deg)[None],
                 base_y=hips[None, :, 1])
    game.shuttle.pos[0] = (3.0, 0.0, -1.0)  # out of the way, under the floor
    return game


def distance_to_segment(points: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    ab = b - a
    t = np.clip(((points - a) @ ab) / (ab @ ab), 0.0, 1.0)
    return np.linalg.norm(points - (a + t[:, None] * ab), axis=1)


@pytest.fixture(scope="module")
def close640():
    with SceneRenderer(1, 640, 360, player="humanlike", trail_length=0) as view:
        yield view


# -- frames -------------------------------------------------------------------------------------
def test_frame_is_a_scene_with_a_player_not_blank(close640):
    env = HumanLikeReturnEnv()
    env.reset(seed=1)
    img = close640.render(env.task.game, 0, target_velocity=env.task.goal[0])
    assert close640.camera == "three_quarter_close"  # HUMAN-LIKE's default
    assert img.shape == (360, 640, 3) and img.dtype == np.uint8
    assert img.std() > 25.0
    assert len(np.unique((img // 32).reshape(-1, 3), axis=0)) >= 12
    green = (img[..., 1] > img[..., 0] + 30) & (img[..., 1] > img[..., 2] + 10)
    assert green.mean() > 0.10  # the court
    shirt = (img[..., 2] > 110) & (img[..., 2] > img[..., 0] + 60)
    assert shirt.sum() > 150  # the player's blue shirt
    skin = (img[..., 0] > 150) & (img[..., 1] > 100) & (img[..., 2] > 70) & \
           (img[..., 0] > img[..., 2] + 40)
    assert skin.sum() > 20  # head and right arm
    assert red(img).sum() > 10  # the target arrow


def test_the_whole_pose_is_copied_for_both_players():
    """Every body of both players sits where the simulator's own kinematics put it (player 1
    turned 180 degrees about z), for random poses within the joint limits."""
    geo = humanlike_geometry()
    rng = np.random.default_rng(0)
    with SceneRenderer(2, 64, 64, player="humanlike") as view:
        for _ in range(3):
            pose = np.degrees(rng.uniform(geo["joint_lo"], geo["joint_hi"], (2, 8)))
            hips = np.column_stack([rng.uniform(-6.0, -1.0, 2), rng.uniform(-2.5, 2.5, 2)])
            game = posed_game(2, hips, pose)
            view.set_state(game, 0)
            sim = game.bodies
            sim.face_centre()  # brings the simulator's kinematics up to date
            for p in range(2):
                for name in BODIES:
                    mine, theirs = view.data.body(f"p{p}_{name}"), sim.data.body(f"e0p{p}_{name}")
                    assert mine.xpos == pytest.approx(theirs.xpos, abs=1e-9)
                    assert mine.xquat == pytest.approx(theirs.xquat, abs=1e-9)
                face = view.data.site(f"p{p}_face").xpos
                own = face * np.array([sim.forward[0, p], sim.forward[0, p], 1.0])
                assert own == pytest.approx(sim.face_centre()[0, p], abs=1e-9)


@pytest.mark.parametrize("camera", ["three_quarter_close", "side"])
def test_racket_head_is_drawn_at_the_projected_face_centre(camera):
    """The racket head's pixels are centred on the camera projection of the simulator's face
    centre, for several poses and hips positions."""
    cases = (  # hips (x, y), joint angles (deg)
        ((-3.0, 0.0), (0, 0, 0, 0, 0, 0, 0, 0)),  # T-pose
        ((-5.0, -1.5), (10, 10, 45, 30, 40, 70, 20, 0)),  # arm raised, elbow bent
        ((-2.0, 1.5), (-10, -10, 20, 60, -30, 20, -40, 10)),
    )
    with SceneRenderer(1, 640, 360, camera, player="humanlike", trail_length=0) as view:
        for hips, pose in cases:
            game = posed_game(1, np.array([hips]), np.array([pose], float))
            view.set_state(game, 0)
            head = racket_head_mask(view)
            assert head.sum() >= 8, (camera, hips)
            expected = view.project(game.bodies.face_centre()[0, 0])  # own frame = world
            assert np.abs(centroid(head) - expected).max() < 1.5, (camera, hips, pose)


def test_target_arrow_points_from_the_racket_head_along_the_velocity(close640):
    env = HumanLikeReturnEnv()
    env.reset(seed=0, options={"hips_position": (-3.0, 0.0)})
    game = env.task.game
    assert red(close640.render(game, 0)).sum() == 0  # no target, no arrow
    face = game.bodies.face_centre()[0, 0]
    for velocity in ((3.0, -1.5, 3.2), (1.5, 1.0, 2.5)):
        img = close640.render(game, 0, target_velocity=velocity)
        start, end = close640.rig.arrow(0)
        assert start == pytest.approx(face, abs=1e-9)
        assert end - start == pytest.approx(ARROW_SECONDS * np.array(velocity))
        a, b = close640.project(np.array([start, end]))
        rows, cols = np.nonzero(red(img))
        pixels = np.column_stack([cols + 0.5, rows + 0.5])
        assert len(pixels) > 20
        # every red pixel lies along the projected arrow ...
        assert distance_to_segment(pixels, a, b).max() < 4.0, velocity
        # ... which is drawn from the racket head to its tip
        assert np.linalg.norm(pixels - b, axis=1).min() < 3.0  # the tip is a pixel wide
        assert np.linalg.norm(pixels - a, axis=1).min() < 3.0
        along = ((pixels - a) @ (b - a)) / ((b - a) @ (b - a))
        assert along.max() > 0.9 and along.min() < 0.15


def test_each_player_gets_its_own_arrow_in_its_own_frame():
    hips = np.array([[-3.0, 0.0], [-3.0, 0.0]])
    game = posed_game(2, hips, np.zeros((2, 8)))
    with SceneRenderer(2, 640, 360, "side", player="humanlike", trail_length=0) as view:
        img = view.render(game, 0, target_velocity=[None, (3.0, 0.0, 3.0)])
        assert view.rig.arrow(0) is None
        start, end = view.rig.arrow(1)
        # player 1's own +x (toward the net) is the world's -x
        assert end - start == pytest.approx(ARROW_SECONDS * np.array([-3.0, 0.0, 3.0]))
        a, b = view.project(np.array([start, end]))
        rows, cols = np.nonzero(red(img))
        pixels = np.column_stack([cols + 0.5, rows + 0.5])
        assert len(pixels) > 10 and distance_to_segment(pixels, a, b).max() < 3.0
        assert np.linalg.norm(pixels - b, axis=1).min() < 4.5  # far away: a thin tip
        assert red(img)[:, :320].sum() == 0  # player 0's side (x < 0 in view) has none
        both = view.render(game, 0, target_velocity=np.array([[3.0, 0.0, 3.0]] * 2))
        assert red(both)[:, :320].sum() > 10


def test_wrong_kinds_of_game_and_target_are_refused(close640):
    env = HumanLikeReturnEnv()
    env.reset(seed=0)
    with pytest.raises(ValueError, match="target_velocity, not target_depth"):
        close640.render(env.task.game, 0, 4.0)
    with pytest.raises(ValueError, match="3 components"):
        close640.render(env.task.game, 0, target_velocity=[(1.0, 2.0)])
    with pytest.raises(TypeError, match="player='simple'"):
        close640.render(Game(1, 1, seed=0), 0)
    with SceneRenderer(1, 32, 32) as simple:
        with pytest.raises(TypeError, match="player='humanlike'"):
            simple.render(env.task.game, 0)
        with pytest.raises(ValueError, match="target_depth, not target_velocity"):
            simple.render(Game(1, 1, seed=0), 0, target_velocity=(1.0, 0.0, 1.0))
    with pytest.raises(ValueError, match="unknown player kind"):
        SceneRenderer(1, 32, 32, player="robot")


# -- env views ----------------------------------------------------------------------------------
def test_env_views_render_rgb_frames():
    env = HumanLikeReturnEnv(render_mode="rgb_array")
    env.reset(seed=0)
    frame = env.render()
    assert frame.shape == (360, 640, 3) and frame.dtype == np.uint8 and frame.std() > 20
    assert red(frame).sum() > 10  # the target arrow
    env.step(np.zeros(15, np.float32))
    assert not np.array_equal(env.render(), frame)  # the serve moved
    with warnings.catch_warnings():
        warnings.filterwarnings("ignore", ".*alternative render modes")  # not made by spec
        check_env(env)
    env.close()
    assert HumanLikeReturnEnv().render() is None  # no render_mode: nothing drawn

    vec = HumanLikeReturnVectorEnv(3, render_mode="rgb_array", render_envs=2)
    vec.reset(seed=0)
    frames = vec.render()
    assert len(frames) == 2 and not np.array_equal(frames[0], frames[1])  # two serves
    vec.close()
    assert HumanLikeReturnVectorEnv(2).render() is None
    with pytest.raises(ValueError, match="rgb_array"):
        HumanLikeReturnEnv(render_mode="ascii")


def test_human_mode_sends_the_arrow_to_the_viewer(monkeypatch):
    """With a display, ``"human"`` opens MuJoCo's passive viewer; the per-frame arrow goes to
    the viewer's own scene (a stand-in viewer here: this machine has no display)."""
    import mujoco.viewer

    class FakeViewer:
        def __init__(self, model: mujoco.MjModel, data: mujoco.MjData, **options) -> None:
            self.user_scn = mujoco.MjvScene(model, maxgeom=100)
            self.cam, self.viewport = mujoco.MjvCamera(), None
            self.synced = 0

        def lock(self) -> contextlib.AbstractContextManager:
            return contextlib.nullcontext()

        def sync(self) -> None:
            self.synced += 1

        def close(self) -> None:
            pass

    monkeypatch.setenv("DISPLAY", ":99")
    monkeypatch.setattr(mujoco.viewer, "launch_passive", FakeViewer)
    env = HumanLikeReturnEnv(render_mode="human")
    env.reset(seed=0)
    viewer = env._view._viewer
    assert viewer.synced == 1 and viewer.user_scn.ngeom == 1
    assert viewer.user_scn.geoms[0].type == mujoco.mjtGeom.mjGEOM_ARROW
    env.step(np.zeros(15, np.float32))
    assert viewer.synced == 2 and viewer.user_scn.ngeom == 1  # replaced, not piled up
    env.close()


# -- recorded rallies ---------------------------------------------------------------------------
def player_mask(view: SceneRenderer, player: int) -> np.ndarray:
    """Pixels where player ``player``'s body is drawn: the frame with it minus the frame with
    its geoms moved to a hidden geom group."""
    m = view.model
    geoms = [g for g in range(m.ngeom) if (m.geom(g).name or "").startswith(f"p{player}_")]
    groups = m.geom_group[geoms].copy()
    shown = view.render_current()
    m.geom_group[geoms] = 5
    try:
        hidden = view.render_current()
    finally:
        m.geom_group[geoms] = groups
    return np.any(shown != hidden, axis=2)


@pytest.mark.slow
@pytest.mark.numerics
def test_record_rally_draws_the_seeded_3d_rally(monkeypatch):
    """``rallysim render --player humanlike``'s recorder with the shipped pretrained levels:
    the rally ``RallySim/HumanLikeRallyTurn-v0`` plays reset with the same seed and a cap of
    12 hits (seed 6: to the cap, in 172 decisions), a frame before each decision and one at the
    end, both players drawn where the game has them, and the goals' arrows."""
    from rallysim.core.tasks.rally import RallyConfig
    from rallysim.core.tasks.turn_loop import TurnLoop
    from rallysim.envs.humanlike_rally_turn_v0 import HumanLikeRallyTurnEnv
    from rallysim.eval.humanlike_eval import rally_goals
    from rallysim.render.record import record_rally

    env = HumanLikeRallyTurnEnv(low_level="pretrained", max_hits=12)
    obs, _ = env.reset(seed=6)
    high = rally_goals("pretrained")
    done, decisions = False, 0
    while not done:
        obs, _, term, trunc, info = env.step(high(obs[None])[0])
        decisions, done = decisions + info["decisions"], term or trunc
    assert (info["rally_length"], decisions) == (12, 172)

    lengths = []
    real = TurnLoop.step

    def step(loop, actions, active=None):
        out = real(loop, actions, active)
        lengths.append(int(out[3]["rally_length"][0]))
        return out

    monkeypatch.setattr(TurnLoop, "step", step)
    with SceneRenderer(2, 320, 180, player="humanlike") as view:
        frames = record_rally(1, rally_goals("pretrained"), "pretrained", 6,
                              RallyConfig(max_hits=12), renderer=view, player="humanlike")
        assert view.camera == "three_quarter_close"
        chest = [view.project(view.data.body(f"p{p}_chest").xpos) for p in range(2)]
        last = view.render_current()  # the state the recorder left: the rally's end
        bodies = [player_mask(view, p) for p in range(2)]
    assert len(frames) == decisions + 1 == len(lengths) + 1 and lengths[-1] == 12
    assert all(f.shape == (180, 320, 3) and f.dtype == np.uint8 for f in frames)
    assert np.array_equal(frames[-1][50:], last[50:])  # below the HUD, the same picture
    # both bodies drawn where the game has them: around the projection of the chest (the
    # arm and racket reach out to one side, the far player is smaller)
    assert bodies[0].sum() >= 200 and bodies[1].sum() >= 100
    for p in range(2):
        assert np.abs(centroid(bodies[p]) - chest[p]).max() < 10, p
    assert sum(red(f).sum() > 5 for f in frames) > 0.9 * len(frames)  # the goals' arrows
    assert all(np.any(a != b) for a, b in itertools.pairwise(frames))  # every decision moves
