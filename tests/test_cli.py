"""The command line: demo numbers, render outputs, the keyboard player of `play`."""

from __future__ import annotations

import numpy as np
import pytest

from rallysim.cli import main
from rallysim.render.play import KEY_LEFT, KEY_RIGHT, KEY_SPACE, KEY_UP, KeyboardPlayer


def test_demo_prints_scripted_numbers(capsys):
    assert main(["demo", "--episodes", "256", "--envs", "64"]) == 0
    out = capsys.readouterr().out
    hit = float(out.split("hit rate")[1].split()[0])
    assert hit > 0.9


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


def test_play_moves_the_human_player_by_keyboard():
    from rallysim.policies.registry import resolve
    from rallysim.render import play as play_module

    moves = []
    orig_step = play_module.RallyTask.step

    def spy(self, actions, active=None):
        moves.append(actions[0, 0].copy())
        return orig_step(self, actions, active)

    viewer = FakeViewer([KEY_RIGHT], 5)

    def factory(model, data, key_callback):
        viewer.press = key_callback
        return viewer

    play_module.RallyTask.step = spy
    try:
        play_module.play(resolve("scripted", "rally_low"), lambda o: np.full(len(o), 4.0), human=0,
                         viewer_factory=factory, realtime=False)
    finally:
        play_module.RallyTask.step = orig_step
    assert viewer.synced == 5
    assert moves[0][2] == 0.0 and all(m[2] == 1.0 for m in moves[1:])  # walks after the key


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
