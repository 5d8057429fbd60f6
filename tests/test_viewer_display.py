"""The live viewer in a real window, seen as a person sees it; ``render_mode="human"``.

An X server (Xvfb; OpenGL from Mesa's software rasteriser) gets ``rallysim play`` for a few
seconds; screenshots of its screen (``xwd | convert``, as a person would take them) must show the
court's lines, both players and the shuttle where the viewer's camera puts them, and the scene
must move between them. ``gymnasium.make(..., render_mode="human")`` must open the same viewer
(not Gymnasium's pygame stand-in), or, without a display, refuse with RallySim's own error.
The display tests are skipped, with the reason, only where Xvfb, xwd, ImageMagick's convert or
Pillow is missing (CI installs them: ``.ci/run``).
"""

from __future__ import annotations

import importlib.util
import os
import select
import shutil
import subprocess
import sys
import time
from collections.abc import Callable, Iterator
from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.envs.registration import load_env_creator

import rallysim  # noqa: F401  (registers the envs)
from rallysim.envs.registration import HUMANLIKE_RETURN_ID, SIMPLE_RETURN_ID

TOOLS = {"Xvfb": "xvfb", "xwd": "x11-apps", "convert": "imagemagick"}
_MISSING = [f"{tool} (apt-get install {package})" for tool, package in TOOLS.items()
            if shutil.which(tool) is None]
if importlib.util.find_spec("PIL") is None:
    _MISSING.append("Pillow (pip install 'rallysim[render]')")
needs_x = pytest.mark.skipif(bool(_MISSING), reason=f"needs {', '.join(_MISSING)}")

# 16:10, the window shape the viewer's camera is fitted to before the window exists, so the
# picture is exactly the "side" camera's (see rallysim.render.viewer.launch_viewer). MuJoCo
# opens its window at two thirds of the screen: 640x400 here.
SCREEN = (960, 600)
WINDOW = (640, 400)
PLAY_SECONDS = 10.0  # counted by play from when its window is up; the shots take about 6
SHOTS, SHOT_GAP = 8, 0.5  # screenshots, seconds apart (the rally advances 0.1 s per 0.1 s)
START_TIMEOUT = 30.0  # for the window to open (imports, GLX set-up on a busy CPU)

Projector = Callable[[np.ndarray], np.ndarray]
Region = tuple[slice, slice]


# -- colours (RGB as the screenshots show them, lit by the scene's lights) ---------------------
def white(img: np.ndarray) -> np.ndarray:
    return img.min(axis=-1) >= 150  # court lines; the green floor's darkest channel is ~40


def green(img: np.ndarray) -> np.ndarray:
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (g > r + 30) & (g > b + 15)  # the court's floor


def blue(img: np.ndarray) -> np.ndarray:
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    return (b > r + 40) & (b > g + 30) & (r < 110)  # player 0's base, not the bluish walls


def orange(img: np.ndarray) -> np.ndarray:
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    # player 1's base; the red racket faces and target discs have g below half of r
    return (r > 100) & (g > 0.55 * r) & (g < 0.8 * r) & (b < 0.45 * r)


def yellow(img: np.ndarray) -> np.ndarray:
    r, g, b = img[..., 0], img[..., 1], img[..., 2]
    # the shuttle; its trail's dots, translucent, take in the background and stay below this
    return (r > 235) & (g > 205) & (b < 120)


# -- the display, the windows and the screenshots ----------------------------------------------
@pytest.fixture
def display() -> Iterator[str]:
    """A fresh Xvfb on a free display number (Xvfb picks it: ``-displayfd``)."""
    read, write = os.pipe()
    server = subprocess.Popen(
        ["Xvfb", "-displayfd", str(write), "-screen", "0", f"{SCREEN[0]}x{SCREEN[1]}x24",
         "-nolisten", "tcp", "-br"],  # -br: a black root window around the viewer's
        pass_fds=(write,), stdout=subprocess.DEVNULL, stderr=subprocess.PIPE)
    os.close(write)
    try:
        ready, _, _ = select.select([read], [], [], 10.0)
        number = os.read(read, 32).decode().strip() if ready else ""
        if not number:
            server.kill()
            pytest.fail(f"Xvfb did not start: {server.communicate()[1].decode()[-500:]}")
        yield f":{number}"
    finally:
        os.close(read)
        server.terminate()
        try:
            server.wait(5)
        except subprocess.TimeoutExpired:
            server.kill()
            server.wait()


def screenshot(display: str, path: Path) -> np.ndarray:
    """The whole screen, as ``xwd -root | convert xwd:- png:PATH``; (H, W, 3) uint8."""
    from PIL import Image

    subprocess.run(f"xwd -root -silent -display {display} | convert xwd:- png:{path}",
                   shell=True, check=True, timeout=20)
    with Image.open(path) as picture:
        return np.asarray(picture.convert("RGB"))


def wait_for_window(display: str, process: subprocess.Popen, path: Path) -> None:
    """Until the window is up: drawn (not black) from corner to corner."""
    deadline = time.monotonic() + START_TIMEOUT
    bottom, right = WINDOW[1] - 1, WINDOW[0] - 1
    while True:
        assert process.poll() is None, f"ended early: {process.communicate()[1][-2000:]}"
        shot = screenshot(display, path)
        if shot[[0, 0, bottom, bottom], [0, right, 0, right]].max(axis=-1).all():
            return
        assert time.monotonic() < deadline, "the viewer's window did not open in time"
        time.sleep(0.25)


def x_env(display: str) -> dict[str, str]:
    """The environment of a process that must open its window on ``display``, even when the
    test runs inside a Wayland desktop (where GLFW would otherwise pick Wayland)."""
    env = {k: v for k, v in os.environ.items() if k != "WAYLAND_DISPLAY"}
    env.update(DISPLAY=display, PYGLFW_LIBRARY_VARIANT="x11")
    return env


def finish(process: subprocess.Popen, seconds: float) -> None:
    """``process`` must end by itself, cleanly: no crash while tearing the window down."""
    _, err = process.communicate(timeout=seconds)
    assert process.returncode == 0, f"exited with {process.returncode}: {err[-2000:]}"


def stop(process: subprocess.Popen) -> None:
    if process.poll() is None:  # a failed check: do not leave the window behind
        process.kill()
        process.communicate()


# -- what a screenshot must show ----------------------------------------------------------------
def projector() -> Projector:
    """World points -> (column, row) in the viewer's window: the "side" camera's projection at
    the window's size (the viewer's free camera starts on that view)."""
    from rallysim.render.scene import SceneRenderer

    return SceneRenderer(2, *WINDOW, "side", offscreen=False).project


def box_region(project: Projector, lo: tuple[float, float, float],
               hi: tuple[float, float, float], margin: int = 2) -> Region:
    """Rows and columns of the window that a world box's picture lies in."""
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    px = project(corners)
    c0, r0 = np.floor(px.min(axis=0)).astype(int) - margin
    c1, r1 = np.ceil(px.max(axis=0)).astype(int) + margin
    return slice(max(r0, 0), min(r1, WINDOW[1])), slice(max(c0, 0), min(c1, WINDOW[0]))


def densest(mask: np.ndarray, side: int) -> tuple[int, tuple[float, float]]:
    """The most ``mask`` pixels in any ``side`` x ``side`` square, and that square's centre
    (column, row)."""
    s = np.pad(mask.astype(np.int32).cumsum(0).cumsum(1), ((1, 0), (1, 0)))
    sums = s[side:, side:] - s[:-side, side:] - s[side:, :-side] + s[:-side, :-side]
    row, col = np.unravel_index(int(sums.argmax()), sums.shape)
    return int(sums[row, col]), (col + side / 2, row + side / 2)


def window_of(shot: np.ndarray) -> np.ndarray:
    """The window, top left (no window manager), with nothing else on the (black) screen."""
    lit = np.argwhere(shot.max(axis=-1) > 0)
    assert lit.min(axis=0).tolist() == [0, 0]
    assert (lit.max(axis=0) + 1).tolist() == [WINDOW[1], WINDOW[0]]
    return shot[:WINDOW[1], :WINDOW[0]].astype(np.int32)


def check_court(img: np.ndarray, project: Projector, what: str) -> None:
    """White court lines and the green floor where the camera puts them: the near side line
    (away from the net post at x = 0) and the near halves of both short service lines, which
    nothing stands in front of (white within 2 pixels), and the floor between them."""
    line_points = [(x, -3.03, 0.002) for x in (-5, -4, -3, -2, -1, 1, 2, 3, 4, 5)]
    line_points += [(x, y, 0.002) for x in (-1.98, 1.98) for y in (-2.6, -2.0, -1.4)]
    line_px = np.rint(project(np.array(line_points))).astype(int)
    assert ((line_px >= 2) & (line_px < np.array(WINDOW) - 2)).all()  # all inside the window
    is_white = white(img)
    on_line = np.array([is_white[r - 2:r + 3, c - 2:c + 3].any() for c, r in line_px])
    assert on_line.all(), f"{what}: no court line at {np.array(line_points)[~on_line]}"
    floor = [(x, -2.2, 0.0) for x in (-5, -3.5, -1, 1, 3.5, 5)]
    floor_px = np.rint(project(np.array(floor))).astype(int)
    assert all(green(img)[r, c] for c, r in floor_px), f"{what}: no green court floor"


def half(project: Projector, player: int) -> Region:
    """Where player ``player``'s base can be: anywhere along its half of the court."""
    sign = 1.0 if player else -1.0
    return box_region(project, (sign * 0.2, -0.3, 0.3), (sign * 6.8, 0.3, 0.7))


def shuttle_in(img: np.ndarray, project: Projector) -> tuple[float, float] | None:
    """Where the shuttle is, over the court up to the top of the picture (None: not seen).
    Its sphere, 0.2 m across (about 8 pixels here), is a compact bright yellow disc."""
    flight = box_region(project, (-7.5, -0.5, 0.0), (7.5, 0.5, 12.0))
    count, (col, row) = densest(yellow(img[flight]), 9)
    return (col + flight[1].start, row + flight[0].start) if count >= 20 else None


# -- the tests ----------------------------------------------------------------------------------
@pytest.mark.slow  # Xvfb
@needs_x
def test_play_window_shows_court_players_and_shuttle(display: str, tmp_path: Path) -> None:
    env = x_env(display)
    command = [sys.executable, "-m", "rallysim.cli", "play", "--human", "none", "--seed", "0",
               "--seconds", str(PLAY_SECONDS)]
    play = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        wait_for_window(display, play, tmp_path / "shot.png")
        shots = []
        for i in range(SHOTS):
            time.sleep(SHOT_GAP)
            assert play.poll() is None, "play closed before the screenshots were taken"
            shots.append(screenshot(display, tmp_path / f"shot{i}.png"))
        project = projector()
        shuttle_at = []
        for k, shot in enumerate(shots):
            img = window_of(shot)
            check_court(img, project, f"shot {k}")
            mine, theirs = half(project, 0), half(project, 1)
            assert blue(img[mine]).sum() >= 40, f"shot {k}: player 0 (blue) not in its half"
            assert orange(img[theirs]).sum() >= 40, f"shot {k}: player 1 (orange) not in its half"
            assert blue(img[theirs]).sum() < 5 and orange(img[mine]).sum() < 5  # not swapped
            at = shuttle_in(img, project)
            if at is not None:
                shuttle_at.append(at)
        # A shot may catch the shuttle above the picture's top (a high lift) or behind a
        # racket: most must show it, at different places (the viewer follows the rally).
        assert len(shuttle_at) >= SHOTS * 3 // 4, f"shuttle seen in {len(shuttle_at)} of {SHOTS}"
        spread = np.ptp(np.array(shuttle_at), axis=0).max()
        assert spread > 10, "the shuttle did not move: the window is not following the rally"
        finish(play, PLAY_SECONDS + 20)  # closed by itself after --seconds
    finally:
        stop(play)


@pytest.mark.slow  # Xvfb
@needs_x
def test_play_humanlike_window_shows_both_3d_players(display: str, tmp_path: Path) -> None:
    """``rallysim play --player humanlike``: the 3-D rally in the window, from the HUMAN-LIKE
    view (``"three_quarter_close"``): the court, player 0 (blue shirt) in its half and player
    1 (orange shirt) in the other, the target arrows; it ends by itself after --seconds."""
    from rallysim.render.scene import SceneRenderer

    env = x_env(display)
    seconds = 6.0
    command = [sys.executable, "-m", "rallysim.cli", "play", "--player", "humanlike",
               "--human", "0", "--seed", "1", "--seconds", str(seconds)]
    play = subprocess.Popen(command, env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE,
                            text=True)
    try:
        wait_for_window(display, play, tmp_path / "shot.png")
        time.sleep(SHOT_GAP)
        img = window_of(screenshot(display, tmp_path / "humanlike.png"))
        project = SceneRenderer(2, *WINDOW, "three_quarter_close", player="humanlike",
                                offscreen=False).project
        assert green(img).mean() > 0.15, "no court"
        mine = box_region(project, (-6.5, -2.8, 0.3), (-0.5, 2.8, 1.8))
        theirs = box_region(project, (0.5, -2.8, 0.3), (6.5, 2.8, 1.8))
        assert blue(img[mine]).sum() >= 100, "player 0 (blue) not in its half"
        assert orange(img[theirs]).sum() >= 40, "player 1 (orange) not in its half"
        r, g, b = img[..., 0], img[..., 1], img[..., 2]
        assert ((r > 150) & (g < 40) & (b < 40)).sum() >= 10, "no target arrow"
        finish(play, seconds + 20)
    finally:
        stop(play)


ENV_SCRIPT = """
import sys, time
import gymnasium as gym
import numpy as np
import rallysim

env = gym.make(sys.argv[1], render_mode="human")
wrappers = []
layer = env
while isinstance(layer, gym.Wrapper):
    wrappers.append(type(layer).__name__)
    layer = layer.env
print(env.unwrapped.render_mode, *wrappers, flush=True)
env.reset(seed=0)
end = time.monotonic() + float(sys.argv[2])
while time.monotonic() < end:
    _, _, terminated, truncated, _ = env.step(np.zeros(env.action_space.shape, np.float32))
    if terminated or truncated:
        env.reset()
    time.sleep(0.1)
env.close()
"""


@pytest.mark.slow  # Xvfb
@needs_x
def test_gym_make_human_opens_rallysims_viewer(display: str, tmp_path: Path) -> None:
    """``render_mode="human"`` through ``gymnasium.make`` is the env's own mode, drawn in the
    viewer ``rallysim play`` uses, on the same view."""
    env = x_env(display)
    seconds = 4.0
    run = subprocess.Popen([sys.executable, "-c", ENV_SCRIPT, SIMPLE_RETURN_ID, str(seconds)],
                           env=env, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    try:
        wrappers = run.stdout.readline().split()  # type: ignore[union-attr]
        assert wrappers, f"gymnasium.make failed: {run.communicate()[1][-2000:]}"
        assert wrappers[0] == "human" and "HumanRendering" not in wrappers  # no pygame window
        wait_for_window(display, run, tmp_path / "shot.png")
        time.sleep(SHOT_GAP)
        img = window_of(screenshot(display, tmp_path / "env.png"))
        project = projector()
        check_court(img, project, "human mode")
        assert blue(img[half(project, 0)]).sum() >= 40, "the player (blue) not in its half"
        finish(run, seconds + 20)
    finally:
        stop(run)


@pytest.mark.parametrize("env_id", [SIMPLE_RETURN_ID, HUMANLIKE_RETURN_ID])
def test_human_mode_without_display_is_rallysims_error(env_id: str, monkeypatch) -> None:
    """Listed in the metadata, so ``gymnasium.make`` hands "human" to the env (it would
    otherwise wrap the env in its own pygame window, which fails only at reset), and the env
    says why it cannot, at once."""
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    creator = load_env_creator(gym.spec(env_id).entry_point)  # what gymnasium.make reads
    assert creator.metadata["render_modes"] == ["rgb_array", "human"]
    with pytest.raises(ValueError, match=r"^render_mode='human' needs a display") as err:
        gym.make(env_id, render_mode="human")
    assert "\n" not in str(err.value)
