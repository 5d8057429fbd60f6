"""Generated bad inputs across every view, reset option, constructor, file loader and CLI
command: each is refused with a ``ValueError`` (or ``FileNotFoundError`` for a missing file)
that says why, never another exception, and a refused call leaves the env exactly as it was
(its pickled state is byte-identical, and the same seed still replays the same episode)."""

from __future__ import annotations

import json
import pickle
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from golden import Hasher, View, views
from safetensors.numpy import load_file, save_file
from test_cli_errors import bad_input_templates

from rallysim.core.tasks.rally import RallyConfig
from rallysim.envs import humanlike_rally_turn_v0 as hrt
from rallysim.envs import humanlike_rally_v0 as hr
from rallysim.envs import simple_rally_turn_v0 as srt
from rallysim.envs import simple_rally_v0 as sr
from rallysim.envs.humanlike_return_v0 import HumanLikeReturnEnv, HumanLikeReturnVectorEnv
from rallysim.envs.simple_return_v0 import SimpleReturnEnv, SimpleReturnVectorEnv
from rallysim.policies.mlp import load_policy
from rallysim.policies.registry import pretrained_prefix

VIEWS = {v.name: v for v in views() if v.name.endswith(("/paper", "/paper/cooperative"))}


def _bad_arrays(shape: tuple[int, ...]) -> Iterator[tuple[str, Any]]:
    """Values that are not a valid action or goal of ``shape``."""
    good = np.zeros(shape)
    nan, inf = good.copy(), good.copy()
    nan.flat[0], inf.flat[-1] = np.nan, -np.inf
    yield "nan", nan
    yield "inf", inf
    yield "all-nan", np.full(shape, np.nan)
    yield "transposed", np.zeros(shape[::-1] if len(shape) > 1 and shape[0] != shape[-1]
                                 else (*shape, 2))
    yield "extra-axis", good[None]
    yield "one-short", np.zeros((*shape[:-1], shape[-1] + 1))[..., 1:-1]
    yield "one-long", np.zeros((*shape[:-1], shape[-1] + 1))
    yield "flattened-wrong", np.zeros(int(np.prod(shape)) + 1)
    yield "empty", np.zeros((0,))
    yield "string", "0.25"
    yield "string-array", np.full(shape, "0.5")
    yield "bytes", b"\x00\x01"
    yield "complex", good.astype(complex) + 1j
    yield "bool", np.zeros(shape, bool)
    yield "object", np.full(shape, None, dtype=object)
    yield "dict", {"a": 1}
    yield "none", None
    yield "ragged", [[0.0], [0.0, 0.0]]


def _bad_steps(view: View, env: Any) -> Iterator[tuple[str, Callable[[], Any]]]:
    if view.api == "parallel":
        agents = list(env.agents)
        shape = env.action_space(agents[0]).shape
        good = {a: np.zeros(shape, np.float32) for a in agents}
        for label, bad in _bad_arrays(shape):
            yield f"{label}@{agents[0]}", lambda bad=bad: env.step({**good, agents[0]: bad})
        yield "missing-agent", lambda: env.step({agents[0]: good[agents[0]]})
        yield "unknown-agent", lambda: env.step({**good, "player_9": good[agents[0]]})
        yield "not-a-dict", lambda: env.step([good[a] for a in agents])
    elif view.api == "aec":
        shape = env.action_space(env.agent_selection).shape
        for label, bad in _bad_arrays(shape):
            yield label, lambda bad=bad: env.step(bad)
    else:
        for label, bad in _bad_arrays(env.action_space.shape):
            yield label, lambda bad=bad: env.step(bad)


def _view_cases() -> list[tuple[str, str, int]]:
    out = []
    for name, view in VIEWS.items():
        env = view.make()
        view.reset(env, Hasher())
        out += [(name, label, i) for i, (label, _) in enumerate(_bad_steps(view, env))]
        env.close()
    return out


VIEW_CASES = _view_cases()


@pytest.fixture(scope="module")
def live_envs() -> dict[str, Any]:
    """One env per view, reset and a few steps in: the state a refused call must not touch."""
    envs = {}
    for name, view in VIEWS.items():
        env = view.make()
        view.reset(env, Hasher(), seed=5)
        view.play(env, 3, np.random.default_rng(0), Hasher())
        if view.api == "aec" and (env.terminations[env.agent_selection]
                                  or env.truncations[env.agent_selection]):
            view.reset(env, Hasher(), seed=5)  # a live agent: its bad goals reach the checks
        envs[name] = env
    return envs


def _refused(call: Callable[[], Any], state: Callable[[], bytes]) -> str:
    before = state()
    with pytest.raises(ValueError) as err:
        call()
    assert state() == before, "a refused call changed the state"
    return str(err.value)


@pytest.mark.parametrize(("name", "label", "index"), VIEW_CASES,
                         ids=[f"{n}:{lab}" for n, lab, _ in VIEW_CASES])
def test_bad_step_is_refused_and_changes_nothing(name, label, index, live_envs):
    view, env = VIEWS[name], live_envs[name]
    _, call = list(_bad_steps(view, env))[index]
    message = _refused(call, lambda: pickle.dumps(env))
    assert message and "\n" not in message


# --- reset options and seeds ----------------------------------------------------------------

SIMPLE_OPTIONS = [
    {"target_depth": 1.0}, {"target_depth": 6.5}, {"target_depth": np.nan},
    {"target_depth": np.inf}, {"target_depth": "4"}, {"target_depth": 4 + 1j},
    {"target_depth": None}, {"target_depth": [4.0, 5.0, 3.0]}, {"target_depth": {"x": 1}},
    {"target_depth": True}, {"base_x": 0.0}, {"base_x": -7.0}, {"base_x": "far"},
    {"arm_angle": 3.0}, {"arm_angle": np.nan}, {"arm_angle": [0.1, 0.2, 0.3]},
    {"target_depth": 4.0, "base_x": 9.0}, {"target_depth": 4.0, "bogus": 1}, {"speed": 3},
    {"": None}, {1: 2},
]
HUMANLIKE_OPTIONS = [
    {"target_velocity": [0.0, 0.0, 0.0]}, {"target_velocity": [0.1, 0.1, 0.1]},
    {"target_velocity": [6.0, 0.0, 0.0]}, {"target_velocity": [np.nan, 1.0, 1.0]},
    {"target_velocity": [1.0, 1.0]}, {"target_velocity": np.zeros((3, 2))},
    {"target_velocity": "fast"}, {"target_velocity": [1 + 1j, 1.0, 1.0]},
    {"target_velocity": None}, {"hips_position": [0.0, 0.0]},
    {"hips_position": [-3.0, 9.0]}, {"hips_position": [-3.0]}, {"hips_position": [[-3.0, 0.0]] * 3},
    {"hips_position": [np.inf, 0.0]}, {"target_depth": 4.0}, {"bogus": 1},
]
NOT_OPTIONS = ["options", 4, ["target_depth"], ("a", 1)]
BAD_SEEDS = [-1, 1.5, "7", True, 2**64, np.nan, [1, 2, 3], None.__class__, {"seed": 1},
             np.array(-2), np.array([[1, 2]]), 2**63 - 1]  # the last: too big for env 1

RESET_ENVS: dict[str, Callable[[], Any]] = {
    "SimpleReturn/single": SimpleReturnEnv, "SimpleReturn/vector": lambda: SimpleReturnVectorEnv(2),
    "HumanLikeReturn/single": HumanLikeReturnEnv,
    "HumanLikeReturn/vector": lambda: HumanLikeReturnVectorEnv(2),
    "simple_rally/vector": lambda: sr.SimpleRallyVectorEnv(2),
    "simple_rally/turn_vector": lambda: srt.SimpleRallyTurnVectorEnv(2),
    "humanlike_rally/turn_vector": lambda: hrt.HumanLikeRallyTurnVectorEnv(2),
    "SimpleRallyTurn/single": srt.SimpleRallyTurnEnv,
}


def _reset_cases() -> Iterator[tuple[str, str, Any, Any]]:
    for env_name in RESET_ENVS:
        options = (SIMPLE_OPTIONS if env_name.startswith("Simple") else HUMANLIKE_OPTIONS
                   if env_name.startswith("HumanLike") else [{"target_depth": 4.0}, {"x": 1}])
        for i, opt in enumerate([*options, *NOT_OPTIONS]):
            yield env_name, f"options{i}", opt, 3
        for i, seed in enumerate(BAD_SEEDS):
            if not (seed is BAD_SEEDS[-1] and env_name.endswith("single")):
                yield env_name, f"seed{i}", None, seed


RESET_CASES = list(_reset_cases())


@pytest.fixture(scope="module")
def reset_envs() -> dict[str, Any]:
    envs = {}
    for name, make in RESET_ENVS.items():
        env = make()
        env.reset(seed=3)
        envs[name] = env
    return envs


@pytest.mark.parametrize(("env_name", "label", "options", "seed"), RESET_CASES,
                         ids=[f"{e}:{lab}" for e, lab, _, _ in RESET_CASES])
def test_bad_reset_is_refused_and_changes_nothing(env_name, label, options, seed, reset_envs):
    env = reset_envs[env_name]
    _refused(lambda: env.reset(seed=seed, options=options), lambda: pickle.dumps(env))


@pytest.mark.parametrize("env_name", ["SimpleReturn/single", "HumanLikeReturn/vector"])
def test_a_refused_reset_keeps_the_seeded_episode(env_name):
    bad = {"target_depth": 9.0} if env_name.startswith("Simple") else {
        "target_velocity": [0.0, 0.0, 0.0]}
    fresh, tried = RESET_ENVS[env_name](), RESET_ENVS[env_name]()
    with pytest.raises(ValueError):
        tried.reset(seed=4, options=bad)
    a, b = fresh.reset(seed=4), tried.reset(seed=4)
    assert Hasher().hexdigest() != (h := Hasher(), h.add(a))[0].hexdigest()
    ha, hb = Hasher(), Hasher()
    ha.add(a), hb.add(b)
    assert ha.hexdigest() == hb.hexdigest()
    # and afterwards the stream continues as if the bad reset never happened
    ha2, hb2 = Hasher(), Hasher()
    ha2.add(fresh.reset()), hb2.add(tried.reset())
    assert ha2.hexdigest() == hb2.hexdigest()


def test_an_option_changes_only_what_it_sets():
    """A given option does not shift the random stream: the serve and the next episode are
    those of the same seed without the option."""
    plain, given = SimpleReturnEnv(), SimpleReturnEnv()
    a, _ = plain.reset(seed=8)
    b, info = given.reset(seed=8, options={"base_x": -3.0, "target_depth": 5.0})
    assert info["target_depth"] == 5.0
    shuttle = slice(4, 10)  # the serve's position and velocity in the observation
    np.testing.assert_array_equal(a[shuttle], b[shuttle])
    np.testing.assert_array_equal(plain.reset()[0], given.reset()[0])


# --- constructors ---------------------------------------------------------------------------

BAD_CONFIGS = [
    {"hit_reward": np.nan}, {"hit_reward": np.inf}, {"hit_reward": "0.2"}, {"hit_reward": None},
    {"max_hits": 0}, {"max_hits": -5}, {"max_hits": 2.5}, {"max_hits": "50"}, {"max_hits": True},
    {"max_decisions": 0}, {"max_decisions": np.nan}, {"mode": "versus"}, {"mode": None},
    {"shuttle": "feather"}, {"shuttle": 3}, {"points_to_win": 0}, {"points_to_win": 40},
    {"win_by": 0}, {"max_points": 10}, {"points_to_win": 21.0},
]
CONSTRUCTORS: dict[str, Callable[..., Any]] = {
    "RallyConfig": RallyConfig, "simple_rally.parallel_env": sr.parallel_env,
    "simple_rally.turn_env": srt.raw_env, "humanlike_rally.parallel_env": hr.parallel_env,
    "SimpleRallyVectorEnv": lambda **kw: sr.SimpleRallyVectorEnv(2, **kw),
}
ENV_ARGS: list[tuple[Callable[..., Any], dict[str, Any]]] = [
    *[(make, {"num_envs": n}) for make in (SimpleReturnVectorEnv, HumanLikeReturnVectorEnv)
      for n in (0, -1, 1.5, "4", None, True)],
    *[(make, {"max_decisions": v}) for make in (SimpleReturnEnv, HumanLikeReturnEnv)
      for v in (0, -3, np.nan, 2.5, "9")],
    *[(make, {"shuttle": v}) for make in (SimpleReturnEnv, HumanLikeReturnEnv)
      for v in ("", "Paper", None)],
    *[(make, {"render_mode": v}) for make in (SimpleReturnEnv, HumanLikeReturnEnv,
                                              sr.parallel_env) for v in ("rgb", "RGB_ARRAY", 1)],
    (SimpleReturnEnv, {"target_depth_range": (5.0, 3.0)}),
    (SimpleReturnEnv, {"target_depth_range": (1.0, 3.0)}),
    (SimpleReturnEnv, {"incoming": "volley"}),
    *[(make, {"low_level": v}) for make in (srt.raw_env, hrt.raw_env,
                                            srt.SimpleRallyTurnVectorEnv)
      for v in ("teacher", 5, None, "")],
    (lambda **kw: SimpleReturnVectorEnv(2, **kw), {"seed": -1}),
    (lambda **kw: SimpleReturnVectorEnv(2, **kw), {"seed": 1.5}),
    (lambda **kw: sr.SimpleRallyVectorEnv(2, **kw), {"autoreset_mode": "sometimes"}),
    (srt.SimpleRallyTurnVectorEnv, {"mode": "competitive"}),
    *[(make, {"shuttle": v}) for make in (SimpleReturnEnv, HumanLikeReturnEnv, RallyConfig)
      for v in (["paper"], {}, 0)],
    *[(SimpleReturnEnv, {"target_depth_range": v}) for v in (None, ("3", "4"), (3.0,),
                                                            (3.0, 4.0, 5.0), (np.nan, 4.0))],
    *[(SimpleReturnEnv, {"keep_bodies": v}) for v in ("no", 1, None)],
    *[(make, {key: v}) for make in (SimpleReturnEnv, SimpleReturnVectorEnv)
      for key in ("returnable", "ready") for v in (-0.5, np.inf, np.nan, "0.5", True, None)],
    *[(lambda **kw: SimpleReturnVectorEnv(2, **kw), {"render_envs": v}) for v in (0, -1, "x")],
]
CONSTRUCTOR_CASES = [(name, cfg) for name in CONSTRUCTORS for cfg in BAD_CONFIGS]


@pytest.mark.parametrize(("name", "config"), CONSTRUCTOR_CASES,
                         ids=[f"{n}:{sorted(c.items())}" for n, c in CONSTRUCTOR_CASES])
def test_bad_rally_config_is_refused(name, config):
    with pytest.raises(ValueError, match="|".join(config)):
        CONSTRUCTORS[name](**config)


@pytest.mark.parametrize(("make", "kwargs"), ENV_ARGS,
                         ids=[f"{i}:{sorted(k.items())}" for i, (_, k) in enumerate(ENV_ARGS)])
def test_bad_env_argument_is_refused(make, kwargs):
    with pytest.raises((ValueError, FileNotFoundError)):
        make(**kwargs)


# --- policy files ---------------------------------------------------------------------------

def _policy_damage() -> Iterator[tuple[str, Callable[[dict, dict], tuple[Any, Any]]]]:
    """(label, damage): damage(spec, tensors) -> (the JSON document or raw bytes, tensors)."""
    def json_edit(edit: Callable[[dict], Any]) -> Callable[[dict, dict], tuple[Any, Any]]:
        def damage(spec: dict, tensors: dict) -> tuple[Any, Any]:
            out = edit(json.loads(json.dumps(spec)))
            return out, tensors
        return damage

    def tensor_edit(edit: Callable[[dict], None]) -> Callable[[dict, dict], tuple[Any, Any]]:
        def damage(spec: dict, tensors: dict) -> tuple[Any, Any]:
            t = {k: v.copy() for k, v in tensors.items()}
            edit(t)
            s = dict(spec)
            s.pop("weights_sha256", None)  # the tensors were edited on purpose
            return s, t
        return damage

    def set_path(doc: dict, path: str, value: Any) -> dict:
        keys = path.split(".")
        node = doc
        for key in keys[:-1]:
            node = node[key]
        node[keys[-1]] = value
        return doc

    def delete(doc: dict, path: str) -> dict:
        keys = path.split(".")
        node = doc
        for key in keys[:-1]:
            node = node[key]
        del node[keys[-1]]
        return doc

    yield "list", json_edit(lambda d: [d])
    yield "string", json_edit(lambda d: "policy")
    yield "null", json_edit(lambda d: None)
    yield "bad-utf8", lambda s, t: (b'{"format": "\xff\xfe"}', t)
    yield "not-json", lambda s, t: (b"{format: 1", t)
    yield "empty", lambda s, t: (b"", t)
    yield "nested-too-deep", lambda s, t: (b"[" * 100_000 + b"]" * 100_000, t)
    for path in ("format", "format_version", "architecture", "architecture.sizes",
                 "architecture.n_layers", "architecture.activation", "action", "action.low",
                 "action.high"):
        yield f"missing:{path}", json_edit(lambda d, p=path: delete(d, p))
    for path, value in [("format", "onnx"), ("format_version", 2), ("architecture", [1, 2]),
                        ("architecture.sizes", "17,64,3"), ("architecture.sizes", [17, 64]),
                        ("architecture.sizes", [17, -64, 64, 3]),
                        ("architecture.sizes", [17, 64.0, 64, 3]),
                        ("architecture.n_layers", "3"), ("architecture.n_layers", 0),
                        ("architecture.n_layers", True), ("architecture.activation", "sigmoid"),
                        ("architecture.activation", None), ("action", "bounded"),
                        ("action.low", [-1.0]), ("action.low", "low"),
                        ("action.low", [float("nan")] * 3), ("action.high", [float("inf")] * 3),
                        ("action.low", [2.0] * 3), ("action.high", ["1", "1", "1"]),
                        ("weights_sha256", 12), ("weights_sha256", "0" * 64)]:
        yield f"{path}={value!r}", json_edit(lambda d, p=path, v=value: set_path(d, p, v))
    yield "nan-weight", tensor_edit(lambda t: t["layers.0.weight"].__setitem__((0, 0), np.nan))
    yield "inf-bias", tensor_edit(lambda t: t["layers.1.bias"].__setitem__(0, np.inf))
    yield "nan-log-std", tensor_edit(lambda t: t["log_std"].__setitem__(0, np.nan))
    yield "broadcasting-bias", tensor_edit(
        lambda t: t.__setitem__("layers.0.bias", t["layers.0.bias"][:1].copy()))
    yield "bias-matrix", tensor_edit(
        lambda t: t.__setitem__("layers.0.bias", t["layers.0.bias"][None].copy()))
    yield "transposed-weight", tensor_edit(
        lambda t: t.__setitem__("layers.0.weight", t["layers.0.weight"].T.copy()))
    yield "missing-tensor", tensor_edit(lambda t: t.pop("log_std"))
    yield "int-weight", tensor_edit(
        lambda t: t.__setitem__("layers.1.weight", t["layers.1.weight"].astype(np.int32)))


POLICY_CASES = [label for label, _ in _policy_damage()]


@pytest.mark.parametrize("label", POLICY_CASES)
def test_damaged_policy_file_is_refused_naming_the_file(label, tmp_path):
    damage = dict(_policy_damage())[label]
    weights, doc = pretrained_prefix("low").with_suffix(".safetensors"), None
    source = pretrained_prefix("low")
    spec = json.loads(Path(f"{source}.json").read_text())
    tensors = load_file(str(weights))
    doc, tensors = damage(spec, tensors)
    prefix = tmp_path / "policy"
    save_file(tensors, str(prefix) + ".safetensors")
    raw = doc if isinstance(doc, bytes) else json.dumps(doc).encode()
    Path(f"{prefix}.json").write_bytes(raw)
    with pytest.raises(ValueError) as err:
        load_policy(prefix)
    assert "policy" in str(err.value) and str(tmp_path) in str(err.value)


def test_enough_generated_bad_inputs():
    """The issue's bar: at least 500 generated bad inputs, over views, options, constructors,
    file loaders (policies here; checkpoints in test_checkpoint_crash) and the CLI
    (test_cli_errors)."""
    counts = {"views": len(VIEW_CASES), "resets": len(RESET_CASES),
              "constructors": len(CONSTRUCTOR_CASES) + len(ENV_ARGS),
              "policy files": len(POLICY_CASES), "cli": len(bad_input_templates())}
    assert counts["views"] >= 10 * len(VIEWS) and counts["policy files"] >= 30
    assert sum(counts.values()) - counts["cli"] >= 500, counts


def test_evaluate_with_a_damaged_policy_fails_in_one_line(tmp_path, capsys):
    """A policy with a NaN weight used to play on and print "HRL mean rally 0.00", exit 0."""
    from rallysim.cli import main

    source = pretrained_prefix("low")
    spec = json.loads(Path(f"{source}.json").read_text())
    spec.pop("weights_sha256")
    tensors = load_file(f"{source}.safetensors")
    tensors["layers.0.weight"][0, 0] = np.nan
    prefix = tmp_path / "damaged"
    save_file(tensors, f"{prefix}.safetensors")
    Path(f"{prefix}.json").write_text(json.dumps(spec))
    assert main(["evaluate", "--low", str(prefix), "--rallies", "4", "--seeds", "1"]) == 2
    err = capsys.readouterr().err.strip().splitlines()
    assert len(err) == 1 and "layers.0.weight" in err[0] and "finite" in err[0]


class _NaNForRally:
    """A low level that returns NaN for rally 1's players only (picklable, so the state of
    the whole env can be compared)."""

    def __call__(self, obs: np.ndarray, goals: Any) -> np.ndarray:
        out = np.zeros((len(obs), 3))
        out[2:4] = np.nan
        return out


def test_a_nan_low_level_is_refused_before_any_rally_moves():
    """MuJoCo resets the whole batch on a NaN: the turn view refuses it before the physics, so
    rally 0 (whose actions were fine) is untouched too."""
    env = srt.SimpleRallyTurnVectorEnv(3, low_level=_NaNForRally())
    env.reset(seed=0)
    before = pickle.dumps(env)
    with pytest.raises(ValueError, match=r"low level .* non-finite"):
        env.step(np.zeros((3, 1)))
    assert pickle.dumps(env) == before


def test_game_refuses_non_finite_actions_from_any_caller():
    from rallysim.core.game import Game

    game = Game(2, 2, seed=0)
    game.reset(np.arange(2))
    before = pickle.dumps(game)
    actions = np.zeros((2, 2, 3))
    actions[1, 0, 2] = np.inf
    with pytest.raises(ValueError, match=r"game\(s\) \[1\]"):
        game.step(actions)
    assert pickle.dumps(game) == before


@pytest.mark.parametrize("make", [sr.parallel_env, srt.raw_env])
def test_pettingzoo_views_ignore_odd_option_keys_silently(make):
    # PettingZoo's own api_test resets with made-up options, so they are ignored, not refused
    env = make()
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        env.reset(seed=0, options={1: 2, "a": 3})
    plain = make()
    plain.reset(seed=0)
    np.testing.assert_array_equal(env.state(), plain.state())
    with pytest.raises(ValueError, match="options must be a dict"):
        env.reset(seed=0, options="a")
