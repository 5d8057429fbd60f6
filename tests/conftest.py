import numpy as np
import pytest

from rallysim.core.game import Game


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
