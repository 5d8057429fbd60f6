"""Rendering: frames show the scene where the camera model says it is, the marker sits on the
goal, the trail is drawn, videos and strips decode. Skipped as a whole only where no OpenGL
backend can be created (no Mesa libraries or PyOpenGL)."""

from __future__ import annotations

import itertools
import os

import numpy as np
import pytest

from rallysim.core.game import Game
from rallysim.envs.simple_return_v0 import SimpleReturnEnv
from rallysim.policies.scripted import ScriptedController
from rallysim.render import SceneRenderer, write_strip, write_video
from rallysim.render.backend import select_backend
from rallysim.render.model import MARKER_HALF_HEIGHT
from rallysim.render.record import record_low_level
from tests.conftest import gl_problem

_PROBLEM = gl_problem()
pytestmark = pytest.mark.skipif(_PROBLEM is not None, reason=_PROBLEM or "")


# -- helpers ------------------------------------------------------------------------------------
def yellow(img: np.ndarray) -> np.ndarray:
    """The shuttle's colour (and its trail's): nothing else in the scene is bright yellow."""
    return (img[..., 0] > 180) & (img[..., 1] > 150) & (img[..., 2] < 120)


def red(img: np.ndarray) -> np.ndarray:
    """The marker's colour; the racket face is orange-red, with G and B near 50."""
    return (img[..., 0] > 150) & (img[..., 1] < 30) & (img[..., 2] < 30)


def centroid(mask: np.ndarray) -> np.ndarray:
    """(column, row) centre of a mask in the pixel convention of ``SceneRenderer.project``."""
    rows, cols = np.nonzero(mask)
    return np.array([cols.mean() + 0.5, rows.mean() + 0.5])


@pytest.fixture(scope="module")
def side640():
    with SceneRenderer(1, 640, 360, "side", trail_length=0) as view:
        yield view


# -- frames -------------------------------------------------------------------------------------
def test_frame_is_a_scene_not_blank(side640):
    env = SimpleReturnEnv()
    env.reset(seed=1)
    img = side640.render(env.task.game, 0, target_depth=4.0)
    assert img.shape == (360, 640, 3) and img.dtype == np.uint8
    assert img.std() > 25.0
    colours = np.unique((img // 32).reshape(-1, 3), axis=0)  # 8 levels per channel
    assert len(colours) >= 12
    green = (img[..., 1] > img[..., 0] + 30) & (img[..., 1] > img[..., 2] + 10)
    assert green.mean() > 0.10  # the court covers a good part of the side view
    assert yellow(img).sum() >= 20  # the shuttle
    assert red(img).sum() >= 50  # the marker


@pytest.mark.parametrize("camera", ["side", "three_quarter"])
def test_shuttle_pixels_follow_the_projected_flight(camera):
    """Over a real serve and return, the shuttle's yellow blob is centred on the camera
    projection of its 3-D position within a pixel, and it travels across the image."""
    env = SimpleReturnEnv()
    controller = ScriptedController()
    obs, _ = env.reset(seed=3)
    game = env.task.game
    errors, pixels = [], []
    with SceneRenderer(1, 640, 360, camera, trail_length=0) as view:
        for _ in range(40):
            img = view.render(game, 0)
            pos = game.shuttle.pos[0]
            expected = view.project(pos)
            blob = yellow(img)
            # whole-blob frames only: in view, above the floor, not behind the near post
            inside = 10 < expected[0] < 630 and 10 < expected[1] < 350
            if inside and pos[2] > 0.15 and abs(pos[0]) > 0.3 and blob.sum() >= 20:
                errors.append(np.abs(centroid(blob) - expected).max())
                pixels.append(expected)
            obs, _, term, trunc, _ = env.step(controller.act_return(obs[None])[0])
            if term or trunc:
                break
    assert len(errors) >= 15
    assert max(errors) < 1.0, errors
    travel = np.ptp(np.array(pixels), axis=0)
    assert travel.max() > 200  # it really flew across the picture


def test_marker_sits_on_the_goal_and_moves_with_it(side640):
    env = SimpleReturnEnv()
    env.reset(seed=2, options={"base_x": -5.0, "arm_angle": 0.0})
    game = env.task.game
    centres = {}
    for depth in (2.5, 5.5):
        img = side640.render(game, 0, target_depth=depth)
        expected = side640.project(np.array([depth, 0.0, 0.0]))
        col, row = expected.astype(int)
        assert red(img)[row - 1:row + 2, col - 1:col + 2].all(), img[row, col]
        blob = red(img)
        assert blob.sum() > 50
        centres[depth] = (centroid(blob), expected)
    (c0, e0), (c1, e1) = centres[2.5], centres[5.5]
    assert np.abs(c0 - e0).max() < 2.0 and np.abs(c1 - e1).max() < 2.0
    moved = c1 - c0  # 3 m deeper: to the right in the side view, by the projected distance
    assert moved[0] > 60 and abs(moved[0] - (e1 - e0)[0]) < 2.0
    # no target, no marker
    assert red(side640.render(game, 0, target_depth=None)).sum() == 0


def test_each_rally_player_gets_its_own_marker():
    game = Game(1, 2, seed=0)
    game.reset(np.array([0]), base_x=np.array([[-2.7, -2.44]]))
    with SceneRenderer(2, 640, 360, "side", trail_length=0) as view:
        img = view.render(game, 0, target_depth=[None, 4.0])
        # player 1's depth is measured in its own frame: world x = -4
        col, row = view.project(np.array([-4.0, 0.0, MARKER_HALF_HEIGHT])).astype(int)
        assert red(img)[row, col]
        assert red(img)[:, 320:].sum() == 0  # player 0's side (x > 0 in view) has none
        with pytest.raises(ValueError, match="2 target depths"):
            view.render(game, 0, target_depth=[1.0, 2.0, 3.0])


def test_arm_angle_and_base_position_are_drawn_where_the_game_has_them(side640):
    """The racket face (orange-red) is centred on the projection of the face the side camera
    sees (the face box's side toward it, y = -0.2) computed by the simulator's own kinematics,
    for several arm angles and base positions."""
    env = SimpleReturnEnv()
    for base_x, angle in ((-5.0, 0.0), (-3.0, 1.2), (-2.0, -1.2)):
        env.reset(seed=0, options={"base_x": base_x, "arm_angle": angle})
        game = env.task.game
        img = side640.render(game, 0)
        face = game.bodies.face_centre()[0, 0] - [0.0, game.bodies.face_half[1], 0.0]
        expected = side640.project(face)
        orange = (img[..., 0] > 120) & (img[..., 1] > 35) & (img[..., 1] < 90) & \
                 (img[..., 2] < 70)
        assert orange.sum() > 30
        assert np.abs(centroid(orange) - expected).max() < 3.0, (base_x, angle)


# -- trail --------------------------------------------------------------------------------------
def test_trail_is_drawn_behind_the_moving_shuttle_and_resets():
    env = SimpleReturnEnv()
    env.reset(seed=3)
    game = env.task.game
    with SceneRenderer(1, 640, 360, trail_length=15) as on, \
            SceneRenderer(1, 640, 360, trail_length=0) as off:
        past = []
        for _ in range(6):  # the serve in flight, no hit yet
            img_on, img_off = on.render(game, 0), off.render(game, 0)
            past.append(game.shuttle.pos[0].copy())
            env.step(np.zeros(3))
        img_on, img_off = on.render(game, 0), off.render(game, 0)
        changed = np.any(img_on != img_off, axis=2)
        assert changed.sum() > 100
        # the trail is yellow at the shuttle's earlier (projected) positions
        for pos in past[-4:]:
            col, row = on.project(pos).astype(int)
            assert yellow(img_on)[row - 1:row + 2, col - 1:col + 2].any()
            assert not yellow(img_off)[row - 1:row + 2, col - 1:col + 2].any()
        # every changed pixel lies near the flight path (the polyline of the shuttle's
        # positions, which the trail draws)
        points = [*past, game.shuttle.pos[0]]
        path = on.project(np.concatenate([np.linspace(a, b, 50)
                                          for a, b in itertools.pairwise(points)]))
        rows, cols = np.nonzero(changed)
        dist = np.min(np.hypot(cols[:, None] + 0.5 - path[None, :, 0],
                               rows[:, None] + 0.5 - path[None, :, 1]), axis=1)
        assert dist.max() < 8.0
        on.reset_trail()
        assert np.array_equal(on.render(game, 0), img_off)


# -- HUD ----------------------------------------------------------------------------------------
def test_hud_text_is_burned_in_top_left(side640):
    env = SimpleReturnEnv()
    env.reset(seed=1)
    game = env.task.game
    plain = side640.render(game, 0)
    a = side640.render(game, 0, hud_text="rally 12   score 3:1")
    b = side640.render(game, 0, hud_text="rally 13   score 3:2")
    diff = np.any(a != plain, axis=2)
    rows, cols = np.nonzero(diff)
    assert rows.max() < 60 and cols.max() < 320  # a box in the top-left corner only
    white = (a[:60, :320] > 200).all(axis=2).sum()
    assert white > 100  # glyph strokes, white on a dark box
    box = a[6:10, 6:12].astype(int)  # the padding of the box: darkened, not black
    assert (box.mean() < 0.6 * plain[6:10, 6:12].mean()) and box.mean() > 5
    assert np.any(a != b)


# -- recording and files ------------------------------------------------------------------------
def test_record_low_level_renders_every_decision():
    frames = record_low_level(1, "scripted", seed=5, width=160, height=96)
    env = SimpleReturnEnv()
    controller = ScriptedController()
    obs, _ = env.reset(seed=5)
    decisions, done = 0, False
    while not done:
        obs, _, term, trunc, _ = env.step(controller.act_return(obs[None])[0])
        decisions, done = decisions + 1, term or trunc
    assert len(frames) == decisions + 1  # the reset frame, then one per decision
    assert all(f.shape == (96, 160, 3) and f.dtype == np.uint8 for f in frames)
    assert len(record_low_level(1, "random", seed=5, width=96, height=64)) >= 2
    with pytest.raises(ValueError, match="unknown policy"):
        record_low_level(1, "greedy")


def test_videos_and_strip_decode(tmp_path):
    import imageio.v3 as iio
    from PIL import Image

    frames = record_low_level(1, "scripted", seed=0, width=160, height=90)[:12]
    assert len(frames) == 12
    assert all(np.any(a != b) for a, b in itertools.pairwise(frames))

    mp4 = write_video(frames, tmp_path / "ep.mp4", fps=10)
    decoded = list(iio.imiter(mp4, plugin="FFMPEG"))
    assert len(decoded) == 12
    assert decoded[0].shape == (90, 160, 3)
    assert np.abs(decoded[5].astype(int) - frames[5]).mean() < 8.0  # lossy, but the same

    gif = write_video(frames, tmp_path / "ep.gif", fps=10)
    with Image.open(gif) as im:
        assert im.n_frames == 12
        assert im.info["duration"] == 100
    assert len(list(iio.imiter(gif))) == 12

    sheet = write_strip(frames[:6], tmp_path / "strip.png", columns=3, gap=4)
    assert sheet.shape == (2 * 90 + 4, 3 * 160 + 2 * 4, 3)
    assert np.array_equal(iio.imread(tmp_path / "strip.png")[..., :3], sheet)
    assert np.array_equal(sheet[94:184, 164:324], frames[4])  # row 1, column 1

    with pytest.raises(ValueError, match="unknown video format"):
        write_video(frames, tmp_path / "ep.avi")


def test_backend_choice_respects_the_user(monkeypatch):
    monkeypatch.setenv("MUJOCO_GL", "egl")
    assert select_backend() == "egl"
    assert os.environ["MUJOCO_GL"] == "egl"
