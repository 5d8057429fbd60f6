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
