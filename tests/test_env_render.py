"""render_mode on every env view: real frames from rgb_array, clear errors otherwise."""

from __future__ import annotations

import numpy as np
import pytest

from rallysim.envs import simple_rally_v0
from rallysim.envs.simple_return_v0 import SimpleReturnEnv, SimpleReturnVectorEnv
from tests.conftest import gl_problem

render = pytest.importorskip("rallysim.render")


_PROBLEM = gl_problem()
needs_gl = pytest.mark.skipif(_PROBLEM is not None, reason=_PROBLEM or "")


def looks_like_a_scene(frame: np.ndarray) -> None:
    assert frame.shape == (360, 640, 3) and frame.dtype == np.uint8
    assert frame.std() > 20  # not blank
    assert len(np.unique(frame.reshape(-1, 3)[::97], axis=0)) > 8  # several colours
    red = (frame[..., 0] > 180) & (frame[..., 1] < 80) & (frame[..., 2] < 80)
    assert red.sum() > 20  # racket faces and target markers are red


@needs_gl
def test_every_view_renders_rgb_frames():
    env = SimpleReturnEnv(render_mode="rgb_array")
    env.reset(seed=0)
    looks_like_a_scene(env.render())
    vec = SimpleReturnVectorEnv(3, render_mode="rgb_array", render_envs=2)
    vec.reset(seed=0)
    frames = vec.render()
    assert len(frames) == 2 and not np.array_equal(frames[0], frames[1])  # two different serves
    par = simple_rally_v0.parallel_env(render_mode="rgb_array")
    par.reset(seed=0)
    looks_like_a_scene(par.render())
    turn = simple_rally_v0.turn_env(render_mode="rgb_array")
    turn.reset(seed=0)
    turn.step(np.array([3.0]))
    looks_like_a_scene(turn.render())
    slots = simple_rally_v0.SimpleRallyVectorEnv(2, render_mode="rgb_array")
    slots.reset(seed=0)
    looks_like_a_scene(slots.render()[0])
    assert SimpleReturnEnv().render() is None  # no render_mode: nothing drawn


def test_render_mode_errors(monkeypatch):
    with pytest.raises(ValueError, match="rgb_array"):
        SimpleReturnEnv(render_mode="ascii")
    monkeypatch.delenv("DISPLAY", raising=False)
    monkeypatch.delenv("WAYLAND_DISPLAY", raising=False)
    with pytest.raises(ValueError, match="needs a display"):
        simple_rally_v0.parallel_env(render_mode="human")


@needs_gl
def test_vector_trail_restarts_with_each_episode():
    vec = SimpleReturnVectorEnv(1, render_mode="rgb_array", max_decisions=2)
    vec.reset(seed=0)
    for _ in range(2):
        vec.step(np.zeros((1, 3)))
        vec.render()
    trail = vec._views[0]._scene.trail
    assert len(trail.points) == 2
    vec.step(np.zeros((1, 3)))  # next-step autoreset: a new serve
    vec.render()
    assert len(trail.points) == 1
