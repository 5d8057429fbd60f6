"""PettingZoo's conventions on both rally modules: ``env`` / ``raw_env`` / ``parallel_env``,
``max_cycles``, ``state`` / ``state_space``, ``is_parallelizable``, reset options, and
PettingZoo's own conformance tests."""

from __future__ import annotations

import copy
import pickle
import warnings
from collections.abc import Callable
from types import ModuleType
from typing import Any

import numpy as np
import pytest
from conftest import gl_problem
from golden import Hasher, View
from pettingzoo import AECEnv
from pettingzoo.test import (
    api_test,
    max_cycles_test,
    parallel_api_test,
    parallel_seed_test,
    render_test,
    seed_test,
    state_test,
)
from pettingzoo.utils.conversions import aec_to_parallel
from pettingzoo.utils.wrappers import OrderEnforcingWrapper

from rallysim.envs import (
    humanlike_rally_turn_v0,
    humanlike_rally_v0,
    simple_rally_turn_v0,
    simple_rally_v0,
)

MODULES = [simple_rally_v0, humanlike_rally_v0]
IDS = ["simple", "humanlike"]
OBS_SIZE = {simple_rally_v0: 20, humanlike_rally_v0: 86}
modules = pytest.mark.parametrize("mod", MODULES, ids=IDS)
# each rally module's goal-level turn game, a module of its own
TURN = {simple_rally_v0: simple_rally_turn_v0, humanlike_rally_v0: humanlike_rally_turn_v0}


def _maker(mod: ModuleType, make: str) -> Callable[..., Any]:
    """A view's constructor: the rally module's ``make``, or for ``"turn_env"`` the turn
    module's ``env``."""
    return TURN[mod].env if make == "turn_env" else getattr(mod, make)


def _strict(check: Callable[[], Any]) -> None:
    """Run ``check`` with every warning an error: PettingZoo's tests warn about suspicious
    envs (and our envs used to warn about the options these tests pass)."""
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        check()


# --- PettingZoo's own tests -------------------------------------------------------------------

PETTINGZOO_TESTS: dict[str, Callable[[ModuleType], Any]] = {
    "api_test": lambda m: api_test(m.env(), num_cycles=20),
    "parallel_api_test": lambda m: parallel_api_test(m.parallel_env(), num_cycles=20),
    "seed_test": lambda m: seed_test(m.env, num_cycles=10),
    "parallel_seed_test": lambda m: parallel_seed_test(m.parallel_env, num_cycles=10),
    "max_cycles_test": max_cycles_test,
    # state_test also runs its parallel check (test_parallel_env) on the parallel env
    "state_test": lambda m: state_test(m.env(), m.parallel_env(), num_cycles=10),
    "api_test/turn_env": lambda m: api_test(TURN[m].env(), num_cycles=20),
    "seed_test/turn_env": lambda m: seed_test(TURN[m].env, num_cycles=5),
    "state_test/turn_env": lambda m: state_test(TURN[m].env(), m.parallel_env(), num_cycles=2),
}


@pytest.mark.parametrize("check", sorted(PETTINGZOO_TESTS))
@modules
def test_pettingzoo_tests_pass_without_a_warning(mod, check):
    _strict(lambda: PETTINGZOO_TESTS[check](mod))


_GL = gl_problem()


@pytest.mark.skipif(_GL is not None, reason=_GL or "")
@pytest.mark.parametrize("make", ["env", "turn_env"])
@modules
def test_render_test_with_rgb_array(mod, make):
    def env_fn(render_mode: str | None = None) -> AECEnv:
        # render_test makes and plays every listed mode; "human" would open a window (or, with
        # no display, be refused), so it gets no rendering: render() is then None, as
        # render_test requires of "human"
        return _maker(mod, make)(render_mode="rgb_array" if render_mode == "rgb_array" else None)

    def is_a_scene(frame: np.ndarray) -> bool:
        return frame.shape == (360, 640, 3) and frame.std() > 20  # a drawn court, not blank

    _strict(lambda: render_test(env_fn, custom_tests={"rgb_array": is_a_scene}))


# --- env / raw_env / parallel_env, is_parallelizable -----------------------------------------

@modules
def test_env_is_raw_env_in_the_order_enforcing_wrapper(mod):
    env = mod.env()
    assert isinstance(env, OrderEnforcingWrapper) and isinstance(env.env, mod.raw_env)
    assert isinstance(mod.raw_env(), AECEnv)
    with pytest.raises(AttributeError, match="before reset"):
        _ = env.agent_selection
    assert env.metadata["is_parallelizable"] is True
    assert mod.raw_env.metadata["is_parallelizable"] is True
    assert str(env) == mod.__name__.rsplit(".", 1)[1]
    # PettingZoo's own conversion gives back the very parallel env under the AEC view
    par = aec_to_parallel(env)
    assert type(par) is type(mod.parallel_env()) and par is env.unwrapped



@modules
def test_the_turn_game_is_a_module_of_its_own(mod):
    turn = TURN[mod]
    env = turn.env()
    assert isinstance(env, OrderEnforcingWrapper) and isinstance(env.env, turn.raw_env)
    assert str(env) == turn.__name__.rsplit(".", 1)[1] == turn.raw_env.metadata["name"]
    assert env.metadata["is_parallelizable"] is False
    assert not hasattr(turn, "parallel_env")  # players act in turns: no parallel view
    with pytest.raises(AttributeError, match="before reset"):
        _ = env.agent_selection
    # the same game as the raw env, step for step
    goal = 4.0 if mod is simple_rally_v0 else np.zeros(3)
    raw = turn.raw_env()
    for e in (env, raw):
        e.reset(seed=3)
        for _ in range(3):
            e.step(goal)
    assert env.rewards == raw.rewards and env.infos["player_0"]["decisions"] == \
        raw.infos["player_0"]["decisions"] > 0
    assert np.array_equal(env.observe("player_0"), raw.observe("player_0"))


@modules
@pytest.mark.parametrize("old", ["turn_env", "TurnAECEnv", "TurnVectorEnv", "TurnEnv"])
def test_the_turn_games_old_names_warn_and_give_the_new_ones(mod, old):
    turn = TURN[mod]
    prefix = "SimpleRally" if mod is simple_rally_v0 else "HumanLikeRally"
    name = old if old == "turn_env" else prefix + old
    with pytest.warns(DeprecationWarning, match=f"{mod.__name__}.{name} is deprecated: use "
                                                f"{turn.__name__}."):
        value = getattr(mod, name)
    assert value is (turn.raw_env if old == "turn_env" else getattr(turn, name))
    with pytest.raises(AttributeError, match="has no attribute 'turn_envs'"):
        _ = mod.turn_envs

def _play_parallel(env: Any, seed: int, actions: np.ndarray) -> list[Any]:
    obs, _ = env.reset(seed=seed)
    out: list[Any] = [obs["player_0"], obs["player_1"]]
    for a in actions:
        if not env.agents:
            break
        obs, rew, term, trunc, _ = env.step({"player_0": a[0], "player_1": a[1]})
        out += [obs["player_0"], obs["player_1"], rew["player_0"], rew["player_1"],
                term["player_0"], trunc["player_0"]]
    return out


def _play_aec(env: Any, seed: int, actions: np.ndarray) -> list[Any]:
    """The AEC view driven like ``_play_parallel``: the same values, read after each cycle."""
    env.reset(seed=seed)
    out: list[Any] = [env.observe("player_0"), env.observe("player_1")]
    for a in actions:
        if any(env.terminations.values()) or any(env.truncations.values()):
            break
        for i, agent in enumerate(("player_0", "player_1")):
            assert env.agent_selection == agent
            env.step(a[i])
        out += [env.observe("player_0"), env.observe("player_1"), env.rewards["player_0"],
                env.rewards["player_1"], env.terminations["player_0"],
                env.truncations["player_0"]]
    return out


def _same(a: list[Any], b: list[Any]) -> bool:
    return len(a) == len(b) and all(np.array_equal(x, y) for x, y in zip(a, b, strict=True))


@modules
def test_env_of_a_seed_replays_identically_and_matches_the_parallel_env(mod):
    size = mod.parallel_env().action_space("player_0").shape[0]
    actions = np.random.default_rng(0).uniform(-1, 1, (15, 2, size))
    first = _play_aec(mod.env(), 4, actions)
    assert len(first) == 2 + 6 * 15  # 15 whole cycles were played
    assert _same(_play_aec(mod.env(), 4, actions), first)
    assert _same(_play_parallel(mod.parallel_env(), 4, actions), first)
    assert not _same(_play_aec(mod.env(), 5, actions), first)  # the seed matters


@modules
def test_aec_env_refuses_a_bad_action_at_the_agents_own_step(mod):
    env = mod.env()
    env.reset(seed=0)
    size = env.action_space("player_0").shape[0]
    for bad, match in ((np.full(size, np.nan), "NaN"), (np.zeros(size + 1), "shape"),
                       (None, "real numbers")):
        with pytest.raises(ValueError, match=match):
            env.step(bad)
        assert env.agent_selection == "player_0"  # nothing was taken
    env.step(np.zeros(size))
    assert env.agent_selection == "player_1"


@modules
def test_aec_env_copies_step_like_the_original(mod):
    view = View("aec", "aec", mod.env)
    env = view.make()
    view.reset(env, Hasher(), seed=3)
    view.play(env, 9, np.random.default_rng(0), Hasher())  # mid-cycle: player_1 to act

    def play(e: Any) -> str:
        h = Hasher()
        view.play(e, 30, np.random.default_rng(1), h)
        return h.hexdigest()

    twins = [copy.deepcopy(env), pickle.loads(pickle.dumps(env))]
    digests = [play(t) for t in twins]
    assert digests == [play(env)] * 2


# --- stepping outside an episode ---------------------------------------------------------------

PARALLEL_VIEWS = {"parallel_env": lambda m, **kw: m.parallel_env(**kw),
                  # PettingZoo's conversion of env() gives the parallel env back: the same rule
                  "aec_to_parallel": lambda m, **kw: aec_to_parallel(m.env(**kw))}


@modules
@pytest.mark.parametrize("view", sorted(PARALLEL_VIEWS))
def test_parallel_step_before_reset_and_after_the_end_follows_pettingzoo(mod, view):
    env = PARALLEL_VIEWS[view](mod, max_cycles=3)
    zero = np.zeros(env.action_space("player_0").shape)
    for actions in ({}, {"player_0": zero, "player_1": zero}):
        with pytest.raises(RuntimeError, match=r"before reset\(\): call reset\(\) first"):
            env.step(actions)
    env.reset(seed=0)
    steps = 0
    while env.agents:  # PettingZoo's usual loop, which builds {} once the episode is over
        env.step({a: zero for a in env.agents})
        steps += 1
    assert steps == 3 and env.agents == []
    before = pickle.dumps(env)
    # as PettingZoo's aec_to_parallel: no agent acts, nothing happens, empty dicts come back
    assert env.step({}) == ({}, {}, {}, {}, {})
    assert env.step({}) == ({}, {}, {}, {}, {})
    with pytest.raises(ValueError, match=r"agent 'player_0' is done; call reset\(\)"):
        env.step({"player_0": zero})
    assert pickle.dumps(env) == before and env.agents == []
    obs, _ = env.reset(seed=0)
    fresh, _ = PARALLEL_VIEWS[view](mod).reset(seed=0)
    assert all(np.array_equal(obs[a], fresh[a]) for a in ("player_0", "player_1"))
    with pytest.raises(ValueError, match=r"missing actions for \['player_1'\]"):
        env.step({"player_0": zero})  # {} is no decision only once the episode is over


# --- max_cycles ---------------------------------------------------------------------------------

@modules
def test_parallel_max_cycles_truncates_every_agent_on_exactly_that_step(mod):
    env = mod.parallel_env(max_cycles=7)
    assert env.max_cycles == 7
    zero = np.zeros(env.action_space("player_0").shape)
    for episode in range(2):  # reset() restarts the count
        env.reset(seed=0)
        ends = []
        while env.agents:
            _, _, term, trunc, _ = env.step({a: zero for a in env.agents})
            ends.append((any(term.values()), all(trunc.values()), any(trunc.values())))
        assert ends == [(False, False, False)] * 6 + [(False, True, True)], episode
    # the same episode without the limit runs on past 7 steps (it lasts 15 or 18 decisions)
    free = mod.parallel_env()
    free.reset(seed=0)
    for _ in range(7):
        free.step({a: zero for a in free.agents})
    assert free.agents == ["player_0", "player_1"]


@modules
def test_aec_max_cycles_truncates_both_players_after_that_many_cycles(mod):
    env = mod.env(max_cycles=7)
    assert env.max_cycles == 7
    env.reset(seed=0)
    zero = np.zeros(env.action_space("player_0").shape)
    live = {"player_0": 0, "player_1": 0}
    dead = {"player_0": 0, "player_1": 0}
    for agent in env.agent_iter(max_iter=100):
        _, _, term, trunc, _ = env.last()
        if term or trunc:
            assert sum(live.values()) == 14 and trunc and not term  # 7 cycles of 2 agents
            dead[agent] += 1
            env.step(None)
            continue
        assert not any(env.truncations.values())
        live[agent] += 1
        env.step(zero)
    assert live == {"player_0": 7, "player_1": 7} and dead == {"player_0": 1, "player_1": 1}
    assert env.agents == []


@modules
def test_turn_max_cycles_counts_turns(mod):
    goal = 4.0 if mod is simple_rally_v0 else np.zeros(3)
    env = TURN[mod].env(max_cycles=3)
    env.reset(seed=0)
    truncated = []
    for _ in range(3):
        env.step(goal)
        truncated.append(dict(env.truncations))
    both = {"player_0": True, "player_1": True}
    assert truncated == [{"player_0": False, "player_1": False}] * 2 + [both]
    assert not any(env.terminations.values())
    free = TURN[mod].env()  # this rally goes on for 50 hits without the limit
    free.reset(seed=0)
    for _ in range(3):
        free.step(goal)
    assert not any(free.truncations.values()) and not any(free.terminations.values())


def test_max_cycles_default_leaves_the_episode_unchanged():
    actions = np.random.default_rng(2).uniform(-1, 1, (200, 2, 3))
    plain = _play_parallel(simple_rally_v0.parallel_env(), 1, actions)
    limited = _play_parallel(simple_rally_v0.parallel_env(max_cycles=10_000), 1, actions)
    assert len(plain) > 2 + 6 * 10 and _same(plain, limited)


@pytest.mark.parametrize("value", [0, -3, 2.5, "7", True])
@pytest.mark.parametrize("make", ["parallel_env", "env", "turn_env"])
def test_bad_max_cycles_is_refused(make, value):
    with pytest.raises(ValueError, match="max_cycles must be an integer >= 1"):
        _maker(simple_rally_v0, make)(max_cycles=value)


def test_unknown_arguments_are_refused_by_name():
    # Python's wording and type: TorchRL's GymEnv retries without an argument on exactly this
    with pytest.raises(TypeError, match=r"unexpected keyword argument 'max_hit'; valid "
                                        r"arguments: render_mode, max_cycles, shuttle, .*max_hits"):
        simple_rally_v0.parallel_env(max_hit=3)
    with pytest.raises(TypeError, match=r"'low_levl'; valid arguments: low_level, "):
        simple_rally_turn_v0.env(low_levl="scripted")
    # the Gymnasium views limit episodes with Gymnasium's TimeLimit, not max_cycles
    with pytest.raises(TypeError, match="'max_cycles'; valid arguments: num_rallies, "):
        simple_rally_v0.SimpleRallyVectorEnv(2, max_cycles=5)


@pytest.mark.parametrize(("env_id", "goal_size"), [("RallySim/SimpleRallyTurn-v0", 1),
                                                  ("RallySim/SimpleRallyTurn-v1", 1),
                                                  ("RallySim/HumanLikeRallyTurn-v0", 3)])
def test_torchrl_gym_env_opens_the_turn_ids(env_id, goal_size):
    # GymEnv passes frameskip= first and falls back on Python's unexpected-argument TypeError
    gym_env = pytest.importorskip("torchrl.envs.libs.gym").GymEnv
    env = gym_env(env_id)
    env.set_seed(0)
    rollout = env.rollout(3)
    steps = rollout["next", "reward"].shape[0]
    done = rollout["next", "done"][:, 0].tolist()
    # a rally may end on a random goal before 3 turns; the rollout then stops at that turn
    assert 1 <= steps <= 3 and done == [False] * (steps - 1) + [steps < 3 or done[-1]]
    assert rollout["next", "reward"].shape == (steps, 1)
    assert env.action_spec.shape == (goal_size,)


# --- state ------------------------------------------------------------------------------------

@modules
@pytest.mark.parametrize("make", ["parallel_env", "env", "turn_env"])
def test_state_has_the_state_space_shape_and_dtype_and_lies_in_it(mod, make):
    env = _maker(mod, make)()
    space = env.state_space
    assert space.shape == (OBS_SIZE[mod],) and space.dtype == np.float32
    assert np.all(space.low == -1.0) and np.all(space.high == 1.0)
    env.reset(seed=0)
    states = []
    for _ in range(4):  # seed 0, middle actions: no view's episode ends this early
        state = env.state()
        assert state.shape == space.shape and state.dtype == space.dtype
        assert space.contains(state)
        if make != "parallel_env":
            assert np.array_equal(state, env.observe("player_0"))  # player 0's observation
        states.append(state.copy())
        middle = {a: (env.action_space(a).low + env.action_space(a).high) / 2
                  for a in env.possible_agents}
        env.step(middle if make == "parallel_env" else middle[env.agent_selection])
    assert not np.array_equal(states[0], states[-1])  # it follows the game


# --- reset options ----------------------------------------------------------------------------

@modules
@pytest.mark.parametrize("make", ["parallel_env", "env", "turn_env"])
def test_reset_options_none_and_empty_are_silent_and_others_ignored(mod, make):
    env = _maker(mod, make)()

    def first_obs(options: Any) -> np.ndarray:
        out = env.reset(seed=6, options=options)
        return out[0]["player_0"] if make == "parallel_env" else env.observe("player_0")

    with warnings.catch_warnings():
        warnings.simplefilter("error")
        plain = first_obs(None).copy()
        assert np.array_equal(first_obs({}), plain)
        # the rallies have no options: any key is ignored, as PettingZoo's envs do
        assert np.array_equal(first_obs({"options": 1, "server": 1}), plain)
    for bad in ("server", [("server", 1)], 3):
        with pytest.raises(ValueError, match="options must be a dict or None"):
            env.reset(seed=7, options=bad)
    assert np.array_equal(first_obs(None), plain)
