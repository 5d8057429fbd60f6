"""Shared fixtures. First of all, the numerics are pinned (``rallysim.numerics.PINNED``) before
NumPy or torch load, so that the tests' exact hashes and values hold on any x86-64 CPU with AVX2
(docs/numerics.md). ``RALLYSIM_TEST_NUMERICS=native`` runs the suite on the machine's own
numerics instead, where the tests marked ``numerics`` (exact bits) skip."""

import importlib.util
import os
import sys
from pathlib import Path


def _load_numerics():
    """``rallysim.numerics`` without importing the package (which loads NumPy)."""
    if "rallysim.numerics" in sys.modules:  # (this file imported again as tests.conftest)
        return sys.modules["rallysim.numerics"]
    spec = importlib.util.find_spec("rallysim")
    assert spec is not None and spec.submodule_search_locations, "rallysim is not installed"
    path = Path(next(iter(spec.submodule_search_locations))) / "numerics.py"
    module_spec = importlib.util.spec_from_file_location("rallysim.numerics", path)
    module = importlib.util.module_from_spec(module_spec)
    module_spec.loader.exec_module(module)
    sys.modules["rallysim.numerics"] = module
    return module


numerics = _load_numerics()
NATIVE = os.environ.get("RALLYSIM_TEST_NUMERICS", "pinned") == "native"
WHY_UNPINNED = "RALLYSIM_TEST_NUMERICS=native" if NATIVE else numerics.can_pin()
if WHY_UNPINNED is None:
    numerics.pin_numerics()  # (raises if NumPy was loaded first: a plugin, say)

import numpy as np  # noqa: E402
import pytest  # noqa: E402

import rallysim  # noqa: E402
from rallysim.core.game import Game  # noqa: E402

rallysim.numerics = numerics  # (loaded above without the package: bind it as an import would)


def pytest_collection_modifyitems(config, items):
    """Tests of exact bits (marked ``numerics``) run only under the pinned numerics."""
    if WHY_UNPINNED is None:
        assert numerics.pinned_here(), "the numerics were pinned but NumPy runs AVX-512 code"
        return
    skip = pytest.mark.skip(reason=f"exact bits need the pinned numerics: {WHY_UNPINNED}")
    for item in items:
        if "numerics" in item.keywords:
            item.add_marker(skip)


def pytest_report_header(config):
    state = "pinned" if WHY_UNPINNED is None else f"native ({WHY_UNPINNED})"
    return f"rallysim numerics: {state}; CPU {numerics.cpu_model()}"


@pytest.fixture
def quiet_game():
    """A one-env, one-player game whose racket is disarmed: the shuttle just flies."""

    def make(shuttle: str = "paper", seed: int = 0) -> Game:
        g = Game(1, 1, shuttle=shuttle, seed=seed)
        g.reset(np.array([0]), base_x=np.array([[-6.5]]))
        g.armed[:] = False
        return g

    return make


def run_until_landed(game: Game, max_decisions: int = 500):
    actions = np.zeros((game.n_envs, game.n_players, 3))
    for _ in range(max_decisions):
        ev = game.step(actions)
        if ev.landed.all():
            return ev
    raise AssertionError("the shuttle never landed")


def humanlike_swing_at_face(game: Game) -> np.ndarray:
    """Game 0 (one HUMAN-LIKE player) restarted with the hips at x = -3, the shuttle held 5 cm
    along the handle from the face's centre; the actions (1, 1, 15) of a full-strength swing
    that meets it within a decision."""
    game.reset(np.array([0]), base_x=np.array([[-3.0]]), theta=0.0)
    game.shuttle.pos[0] = game.bodies.face_centre()[0, 0] + [0.0, 0.0, 0.05]
    game.shuttle.vel[0] = 0.0
    game._refresh()
    swing = np.zeros((1, 1, 15))
    swing[..., 2:10] = [0, 0, 0.3, 0, 0, -1, 0, 0]
    swing[..., 10:] = 1.0
    return swing


def gl_problem() -> str | None:
    """Why no OpenGL renderer can be made here (None: rendering works)."""
    try:
        from rallysim.render import SceneRenderer, active_backend
    except ImportError as err:
        return f"rendering extra not installed: {err}"
    try:
        with SceneRenderer(1, 32, 32) as view:
            view.render_current()
    except Exception as err:  # any failure to make a context means: no GL here
        return f"no OpenGL backend (MUJOCO_GL={active_backend()!r}): {err}"
    return None


def rollout_single(env, seed, actions):
    """Observations (then observation + reward per step) of one seeded single-env episode."""
    obs, _ = env.reset(seed=seed)
    out = [obs]
    for a in actions:
        obs, r, term, trunc, _ = env.step(a)
        out.append(np.append(obs, r))
        if term or trunc:
            break
    return out


def check_seeded_and_batched(make_single, make_vector, actions):
    """The same seed replays the same episode, and slot i of a batch seeded s replays a single
    env seeded s + i, bit for bit. ``actions``: (steps, slots, action size)."""
    steps, slots = actions.shape[:2]
    a = rollout_single(make_single(), 7, actions[:, 0])
    b = rollout_single(make_single(), 7, actions[:, 0])
    assert all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))
    vec = make_vector(slots)
    obs, _ = vec.reset(seed=5)
    singles = [rollout_single(make_single(), 5 + i, actions[:, i]) for i in range(slots)]
    for i in range(slots):
        assert np.array_equal(obs[i], singles[i][0])
    for k in range(steps):
        obs, r, _, _, _ = vec.step(actions[k])
        for i in range(slots):
            if k + 1 < len(singles[i]):
                assert np.array_equal(np.append(obs[i], r[i]), singles[i][k + 1])
