"""The command line: demo numbers, render outputs, the keyboard players of `play`."""

from __future__ import annotations

import contextlib

import mujoco
import numpy as np
import pytest

from rallysim.cli import main
from rallysim.core.tasks.turn_loop import TurnLoop
from rallysim.render.keyboard import (
    KEY_DOWN,
    KEY_F,
    KEY_G,
    KEY_LEFT,
    KEY_RIGHT,
    KEY_SPACE,
    KEY_UP,
    KeyboardGoals,
    KeyboardPlayer,
)


def test_demo_prints_scripted_numbers(capsys):
    assert main(["demo", "--episodes", "256", "--envs", "64"]) == 0
    out = capsys.readouterr().out
    hit = float(out.split("hit rate")[1].split()[0])
    assert hit > 0.9


def number(out: str, label: str) -> float:
    return float(out.split(label)[1].split()[0])


@pytest.mark.parametrize("policy, hit, reward, angle", [
    # AimedSwing: the target velocity, to the numerics
    pytest.param("scripted", 1.0, 1.0, 0.0, marks=pytest.mark.slow),
    # the shipped policy on these 64 seeded serves (32 at a time)
    pytest.param("pretrained", 1.0, 0.890, 3.50, marks=pytest.mark.slow),
    # flailing joints: one lucky touch in 64 (its racket far off the target: reward 0.5)
    ("random", 0.016, 0.008, 53.37),
])
def test_demo_humanlike_prints_the_low_level_tasks_numbers(policy, hit, reward, angle, capsys):
    argv = ["demo", "--player", "humanlike", "--episodes", "64", "--envs", "24", "--policy",
            policy]
    assert main(argv) == 0
    out = capsys.readouterr().out
    assert out.startswith(f"RallySim/HumanLikeReturn-v0, shuttle='paper', policy='{policy}', "
                          "64 episodes")
    assert number(out, "hit rate") == hit
    # the network's float32 sums round a little differently in batches of another size
    assert number(out, "mean episode reward") == pytest.approx(reward, abs=0.002)
    assert number(out, "mean angle error") == pytest.approx(angle, abs=0.05, nan_ok=True)
    assert "with 24 environments" in out  # 64 episodes in rounds of 24, 24 and 16


def test_keyboard_player_actions():
    k = KeyboardPlayer()
    k.press(KEY_RIGHT)
    k.press(KEY_UP)
    a = k.action()
    assert a[2] == 1.0 and a[0] == pytest.approx(-30 / 85) and a[1] == 1.0
    k.press(KEY_LEFT)  # the other way stops first
    assert k.action()[2] == 0.0
    k.press(KEY_SPACE)
    swings = [k.action()[0] for _ in range(4)]
    assert swings[:3] == [1.0, 1.0, 1.0] and swings[3] == pytest.approx(-30 / 85)


class FakeViewer:
    """Stands in for MuJoCo's window: presses keys, counts frames, closes after n syncs."""

    def __init__(self, keys, n):
        self.keys, self.n, self.synced = keys, n, 0

    def is_running(self):
        return self.synced < self.n

    def sync(self):
        if self.synced < len(self.keys):
            self.press(self.keys[self.synced])
        self.synced += 1

    def close(self):
        pass


def test_play_moves_the_human_player_by_keyboard(monkeypatch):
    from rallysim.policies.registry import resolve
    from rallysim.render.play import play

    moves = []
    orig_step = TurnLoop.step

    def spy(self, actions, active=None):
        moves.append(actions[0, 0].copy())
        return orig_step(self, actions, active)

    viewer = FakeViewer([KEY_RIGHT], 5)

    def factory(model, data, key_callback):
        viewer.press = key_callback
        return viewer

    monkeypatch.setattr(TurnLoop, "step", spy)  # play's decisions are the turn loop's
    play(resolve("scripted", "rally_low"), lambda o: np.full(len(o), 4.0), human=0,
         viewer_factory=factory, realtime=False)
    assert viewer.synced == 5
    assert moves[0][2] == 0.0 and all(m[2] == 1.0 for m in moves[1:])  # walks after the key


def test_keyboard_goals():
    k = KeyboardGoals()
    assert k.goal().tolist() == [0.0, 0.0, 0.0]  # the centre goal: 3 m/s at 45 deg
    for key in (KEY_UP, KEY_UP, KEY_LEFT, KEY_G, KEY_F, KEY_F):
        k.press(key)
    assert k.goal().tolist() == [0.5, -0.25, 0.25]
    for _ in range(9):
        k.press(KEY_DOWN)
        k.press(KEY_RIGHT)
    assert k.goal().tolist() == [-1.0, -0.25, -1.0]  # held at the goal's bounds
    k.press(KEY_SPACE)
    assert k.goal().tolist() == [0.0, 0.0, 0.0]


class SceneViewer(FakeViewer):
    """A stand-in that also has the viewer's lock and its own scene (``user_scn``)."""

    def __init__(self, keys, n, model):
        super().__init__(keys, n)
        self.user_scn = mujoco.MjvScene(model, maxgeom=200)

    def lock(self):
        return contextlib.nullcontext()


def test_play_humanlike_keys_choose_the_players_goal(monkeypatch):
    """HUMAN-LIKE play: the keys set player 0's goal, which its learned low level gets from the
    next decision on; the computer's high level never sets it; both goals are drawn."""
    from rallysim.policies.registry import resolve
    from rallysim.render.play import play

    low = resolve("pretrained", "rally_low", "humanlike")
    seen = []  # the goals (2, 3) each decision's low level acted on

    def recording_low(obs, goals):
        seen.append(goals.copy())
        return low(obs, goals)

    asked = []

    def high(obs):
        asked.append(len(obs))
        return np.full((len(obs), 3), -0.9)

    keys = [KEY_UP, KEY_UP, KEY_LEFT, KEY_G, None, KEY_SPACE]
    holder = {}

    def factory(model, data, key_callback):
        viewer = SceneViewer(keys, 8, model)
        viewer.press = lambda key: key is None or key_callback(key)
        holder["viewer"] = viewer
        return viewer

    play(recording_low, high, human=0, viewer_factory=factory, realtime=False,
         player="humanlike", seed=1)
    mine = [g[0].tolist() for g in seen]
    assert len(mine) == 8
    assert mine[:7] == [[0, 0, 0], [0.25, 0, 0], [0.5, 0, 0], [0.5, 0, 0.25],
                        [0.5, 0.25, 0.25], [0.5, 0.25, 0.25], [0, 0, 0]]
    assert all(g[1].tolist() == [0, 0, 0] for g in seen)  # player 1's turn has not come yet
    assert asked == []  # the serve came to player 0, whose goals are the keyboard's
    # the goals are drawn in the viewer's own scene: an arrow per player from its racket head
    scn = holder["viewer"].user_scn
    arrows = [scn.geoms[i] for i in range(scn.ngeom)
              if scn.geoms[i].type == mujoco.mjtGeom.mjGEOM_ARROW]
    assert len(arrows) == 2


def test_render_writes_video_gif_and_strip(tmp_path):
    pytest.importorskip("imageio")
    import imageio.v3 as iio

    from tests.test_env_render import needs_gl  # noqa: F401  (skips without OpenGL)

    code = main(["render", "--env", "low", "--episodes", "1", "--seed", "3", "--policy",
                 "scripted", "--size", "160x96", "--stills", "4", "--out", str(tmp_path)])
    assert code == 0
    mp4 = iio.imread(tmp_path / "low_scripted.mp4")
    strip = iio.imread(tmp_path / "low_scripted_strip.png")
    assert mp4.shape[1:3] == (96, 160) and 8 <= len(mp4) <= 200
    assert strip.shape[0] < strip.shape[1]  # one row of 4 stills
    assert (tmp_path / "low_scripted.gif").stat().st_size > 1000


def test_training_commands_name_the_missing_extra(monkeypatch, capsys):
    import importlib.util

    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name == "stable_baselines3" else real(name, *a))
    assert main(["reproduce", "--budget", "smoke"]) == 2
    assert main(["train", "low"]) == 2
    assert "missing: stable_baselines3" in capsys.readouterr().err


@pytest.mark.parametrize("argv", [["reproduce", "--cap", "0"], ["reproduce", "--cap", "100001"],
                                  ["reproduce", "--seeds", "0"], ["evaluate", "--cap", "x"]])
def test_bad_cap_and_seeds_are_one_line_errors(argv, capsys):
    assert main(argv) == 2  # returned, not a SystemExit: main reports every user error
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1  # no usage block before the message
    assert lines[0].startswith(f"rallysim {argv[0]}: error: argument {argv[1]}: ")


@pytest.mark.numerics  # (the seeded episodes' lengths)
@pytest.mark.parametrize("env, frames", [("rally", 751), ("low", 36)])
def test_render_humanlike_writes_the_3d_rally_and_return(env, frames, tmp_path, capsys):
    """--player humanlike with the shipped pretrained levels: seed 3's rally (to the cap of 50
    hits, in 750 decisions, as RallySim/HumanLikeRallyTurn-v0 plays it), or seed 3's episode of
    RallySim/HumanLikeReturn-v0 (35 decisions); a frame before each decision and the last."""
    pytest.importorskip("imageio")
    import imageio.v3 as iio

    from tests.test_env_render import needs_gl  # noqa: F401  (skips without OpenGL)

    code = main(["render", "--player", "humanlike", "--env", env, "--episodes", "1", "--seed",
                 "3", "--size", "160x96", "--stills", "4", "--out", str(tmp_path)])
    assert code == 0
    stem = tmp_path / f"humanlike_{env}_pretrained"
    mp4 = iio.imread(stem.with_suffix(".mp4"))
    assert mp4.shape == (frames, 96, 160, 3)
    assert f"({frames} frames)" in capsys.readouterr().out
    assert stem.with_name(stem.name + "_strip.png").stat().st_size > 1000


@pytest.mark.parametrize("argv, header", [
    ([], "evaluate: HRL, Random High-level and Monolithic with the shipped policies, 2 rallies "
         "each from each of 1 evaluation seed, capped at 50 hits; then the low level on 16 "
         "fresh serves; [95 % intervals]"),
    (["--player", "humanlike"], "evaluate: HUMAN-LIKE low level pretrained on 16 fresh serves, "
     "then its 3-D rally for pretrained goals, 2 rallies from each of 1 evaluation seed; "
     "[95 % intervals]"),
])
def test_evaluate_says_first_what_it_measures(argv, header, capsys):
    """The first line names the policies, the rallies and seeds, the cap and the serves; the
    results follow with their intervals."""
    assert main(["evaluate", *argv, "--rallies", "2", "--episodes", "16"]) == 0
    lines = capsys.readouterr().out.splitlines()
    assert lines[0] == header
    assert any("mean rally" in line and " [" in line for line in lines[1:])
    # and where the rallies were lost, for either kind of player
    assert any("lost before hit 2" in line and "miss rate per later hit" in line
               for line in lines[1:])
