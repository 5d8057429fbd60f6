"""render_mode on every env view: real frames from rgb_array, clear errors otherwise."""

from __future__ import annotations

import numpy as np
import pytest

from rallysim.envs import simple_rally_turn_v0, simple_rally_v0
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
    turn = simple_rally_turn_v0.raw_env(render_mode="rgb_array")
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


# -- envs and render: a one-way dependency ------------------------------------------------------
# What the env views import of rallysim.render (through EnvView's default factories) and what
# that in turn imports: none of it may import rallysim.envs, at module level or in a function,
# or envs -> render -> envs would be a cycle. The recorders and the live player play envs; the
# package re-exports the recorders only on first access (its __getattr__), which envs never use.
DRAWING_MODULES = ("__init__", "backend", "hud", "model", "players", "scene", "trail", "video",
                   "viewer", "keyboard")


def imported_names(path) -> list[tuple[str, str]]:
    """(module imported, enclosing function or "") of every import statement in a file."""
    import ast

    tree = ast.parse(path.read_text())
    out = []

    def visit(node, where: str) -> None:
        for child in ast.iter_child_nodes(node):
            if isinstance(child, ast.FunctionDef | ast.AsyncFunctionDef):
                visit(child, child.name)
                continue
            if isinstance(child, ast.Import):
                out.extend((a.name, where) for a in child.names)
            elif isinstance(child, ast.ImportFrom) and child.module:
                out.extend((f"{child.module}.{a.name}", where) for a in child.names)
            visit(child, where)

    visit(tree, "")
    return out


def test_drawing_modules_never_import_envs():
    from pathlib import Path

    import rallysim.render

    folder = Path(rallysim.render.__file__).parent
    for name in DRAWING_MODULES:
        for module, where in imported_names(folder / f"{name}.py"):
            if (name, where) == ("__init__", "__getattr__"):
                assert module == "rallysim.render.record"  # the recorders, on first access
                continue
            assert not module.startswith("rallysim.envs"), (name, where, module)
            assert module.split(".")[:3] != ["rallysim", "render", "record"], (name, module)
            assert module.split(".")[:3] != ["rallysim", "render", "play"], (name, module)


@pytest.mark.slow  # fresh interpreters
def test_importing_render_loads_no_env_module_and_envs_load_no_render_module():
    import ast
    import subprocess
    import sys

    code = ("import sys, rallysim; before = set(sys.modules); "
            "import rallysim.render, rallysim.render.scene, rallysim.render.viewer; "
            "print(sorted(m for m in set(sys.modules) - before if m.startswith('rallysim.envs')));"
            "import rallysim.envs.simple_rally_v0, rallysim.envs.humanlike_rally_v0;"
            "import rallysim.envs.simple_return_v0, rallysim.envs.humanlike_return_v0;"
            "print(sorted(m for m in sys.modules if m.startswith('rallysim.render.')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.splitlines()
    assert out[0] == "[]"  # render: no env module
    # the envs, imported after render's drawing modules, add no render module of their own
    loaded = ast.literal_eval(out[1])
    assert "rallysim.render.scene" in loaded
    assert "rallysim.render.record" not in loaded and "rallysim.render.play" not in loaded
    code = ("import sys, rallysim.envs.simple_rally_v0, rallysim.envs.humanlike_rally_v0, "
            "rallysim.envs.simple_return_v0, rallysim.core.tasks.turns; "
            "print(sorted(m for m in sys.modules if m.startswith('rallysim.render')))")
    out = subprocess.run([sys.executable, "-c", code], capture_output=True, text=True,
                         check=True).stdout.strip()
    assert out == "[]"  # envs: no render module until a view renders


def test_env_view_draws_through_its_factories():
    """An env view's renderer and window come from its factories (module-level functions by
    default, so a view still pickles); no OpenGL is needed with stand-ins."""
    import pickle

    from rallysim.core.tasks.rally import RallyTask
    from rallysim.envs.rendering import EnvView, passive_viewer, scene_renderer
    from rallysim.players import HUMANLIKE

    made = []

    class Stub:
        def render(self, game, env_index=0, target_depth=None, hud_text=None, *,
                   target_velocity=None):
            return np.full((48, 64, 3), 7, np.uint8)

        def close(self):
            made.append("closed")

    def factory(n_players, width, height, camera, player, offscreen):
        made.append((n_players, width, height, camera, player, offscreen))
        return Stub()

    view = EnvView("rgb_array", 2, 64, 48, player="humanlike", renderer_factory=factory)
    task = RallyTask(1, spec=HUMANLIKE)
    assert view.render(task.game, 0).shape == (48, 64, 3)
    view.render(task.game, 0)
    view.close()
    assert made == [(2, 64, 48, None, "humanlike", True), "closed"]  # made once, on first use
    plain = EnvView("rgb_array", 1)
    assert (plain.renderer_factory, plain.viewer_factory) == (scene_renderer, passive_viewer)
    assert pickle.loads(pickle.dumps(plain)).renderer_factory is scene_renderer
