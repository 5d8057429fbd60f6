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
