"""Player specs (``rallysim.players``) and the policy registry read from them."""

from __future__ import annotations

import pickle

import numpy as np
import pytest

from rallysim.core.tasks.rally import RallyTask
from rallysim.players import HUMANLIKE, PLAYERS, SIMPLE, Layout, get_player
from rallysim.policies.callables import UniformRandom
from rallysim.policies.registry import resolve


def test_layouts_name_every_slice_once():
    assert SIMPLE.obs["shuttle_position"] == slice(10, 13)
    assert SIMPLE.low_obs["goal_depth"] == slice(16, 17)
    assert SIMPLE.rally_obs["my_turn"] == slice(19, 20)
    assert (SIMPLE.obs.size, SIMPLE.low_obs.size, SIMPLE.rally_obs.size) == (16, 17, 20)
    assert HUMANLIKE.obs["hips_position"] == slice(76, 79)
    assert (HUMANLIKE.obs.size, HUMANLIKE.low_obs.size, HUMANLIKE.rally_obs.size) == (82, 85, 86)
    assert (SIMPLE.action.size, HUMANLIKE.action.size) == (3, 15)
    assert HUMANLIKE.action["strength"] == slice(10, 15)
    with pytest.raises(ValueError, match="twice"):
        Layout((("a", 1), ("a", 2)))
    with pytest.raises(KeyError, match="parts: base_position"):
        SIMPLE.obs["goal"]


def test_tasks_take_their_sizes_and_goals_from_the_spec():
    simple, humanlike = RallyTask(1), RallyTask(1, spec=HUMANLIKE)
    for task, spec in ((simple, SIMPLE), (humanlike, HUMANLIKE)):
        assert task.spec is spec and task.player == spec.name
        assert (task.obs_size, task.action_size) == (spec.rally_obs.size, spec.action.size)
        assert task.observe().shape == (1, 2, spec.rally_obs.size)
        assert type(task.game.bodies) is type(spec.make_bodies(1, 2))
    assert simple.default_goal == 4.0 and humanlike.default_goal == (0.0, 0.0, 0.0)
    assert (simple.obs_size, humanlike.obs_size) == (20, 86)


def test_simple_goal_mapping_is_the_originals_and_keeps_the_dtype():
    a = np.array([-3.0, -1.0, -0.25, 0.0, 0.5, 1.0, 7.0])
    assert SIMPLE.goal.from_action(a).tolist() == [2.0, 2.0, 3.5, 4.0, 5.0, 6.0, 6.0]
    a32 = np.array([[0.3], [-0.7]], np.float32)
    goals = SIMPLE.goal.from_action(a32)
    assert goals.dtype == np.float32 and goals.shape == (2,)
    assert np.array_equal(goals, 4.0 + 2.0 * np.clip(a32.reshape(-1), -1.0, 1.0))
    assert SIMPLE.goal.mapping == "goal_m = 4 + 2 * clip(action, -1, 1)"


def test_goal_clip_and_sample_stay_in_range():
    assert SIMPLE.goal.clip([9.0, -3.0, 4.5]).tolist() == [6.0, 2.0, 4.5]
    assert HUMANLIKE.goal.clip([[2.0, -2.0, 0.5]]).tolist() == [[1.0, -1.0, 0.5]]
    with pytest.raises(ValueError, match="finite"):
        SIMPLE.goal.clip([np.nan])
    rng = np.random.default_rng(0)
    s, h = SIMPLE.goal.sample(rng, 1000), HUMANLIKE.goal.sample(rng, 1000)
    assert s.shape == (1000,) and s.min() >= 2.0 and s.max() <= 6.0
    assert h.shape == (1000, 3) and h.min() >= -1.0 and h.max() <= 1.0
    assert HUMANLIKE.goal.from_action(np.array([[2.0, 0.1, -5.0]])).tolist() == [[1.0, 0.1, -1.0]]


def test_a_player_kind_is_one_module_defining_player(tmp_path, monkeypatch):
    import rallysim.players as players

    (tmp_path / "robot.py").write_text(
        "import dataclasses\nfrom rallysim.players.simple import SIMPLE\n"
        "PLAYER = dataclasses.replace(SIMPLE, name='robot')\n")
    monkeypatch.setattr(players, "__path__", [*players.__path__, str(tmp_path)])
    monkeypatch.syspath_prepend(str(tmp_path))
    found = players._discover()
    assert list(found) == ["humanlike", "robot", "simple"]
    assert found["robot"].goal is SIMPLE.goal


def test_rendering_reads_the_rig_from_the_spec(monkeypatch):
    """Rendering and play switch on no kind's name: a new kind renders through the rig its
    spec names (here a copy of SIMPLE drawn by HUMAN-LIKE's rig, to tell the two apart)."""
    import dataclasses

    import rallysim.players as players
    from rallysim.render.markers import goal_markers, target_markers
    from rallysim.render.players import HumanLikeRig, SimpleRig, default_camera, rig_class

    assert rig_class("simple") is SimpleRig and rig_class("humanlike") is HumanLikeRig
    for kind in players.PLAYERS:  # every shipped kind names a rig that loads
        assert rig_class(kind).bodies_type is type(get_player(kind).make_bodies(1, 1))
    robot = dataclasses.replace(SIMPLE, name="robot", rig="rallysim.render.players:HumanLikeRig",
                                camera="back")
    monkeypatch.setitem(players.PLAYERS, "robot", robot)
    assert rig_class("robot") is HumanLikeRig and default_camera("robot") == "back"
    assert goal_markers("simple", np.array([2.5, 5.0])) == {"target_depth": [2.5, 5.0]}
    velocity = goal_markers("robot", np.zeros((2, 3)))["target_velocity"]
    assert velocity.shape == (2, 3) and np.allclose(np.linalg.norm(velocity, axis=1), 3.0)
    assert target_markers("robot", 1.0) == {"target_velocity": 1.0}
    assert isinstance(rig_class("robot").keyboard(), HumanLikeRig.keyboard)
    monkeypatch.setitem(players.PLAYERS, "bad", dataclasses.replace(
        SIMPLE, name="bad", rig="rallysim.render.players:default_camera"))
    with pytest.raises(TypeError, match=r"player kind 'bad': rig .* is not a PlayerRig"):
        rig_class("bad")


def test_get_player_names_the_valid_kinds():
    assert get_player("humanlike") is HUMANLIKE and get_player(SIMPLE) is SIMPLE
    assert set(PLAYERS) == {"simple", "humanlike"}
    with pytest.raises(ValueError, match="'humanlike', 'simple'"):
        get_player("robot")


def test_registry_resolves_each_role_for_each_player():
    obs20, obs86 = np.zeros((4, 20), np.float32), np.zeros((4, 86), np.float32)
    random_high = resolve("random", "high", "simple", seed=3)
    assert np.array_equal(random_high(obs20), UniformRandom(None, 3, 2.0, 6.0)(obs20))
    assert resolve("fixed:3.5", "high")(obs20).tolist() == [3.5] * 4
    assert resolve("fixed:9", "high")(obs20).tolist() == [6.0] * 4  # clipped into the range
    assert resolve("fixed:0,0.5,0", "high", "humanlike")(obs86).tolist() == [[0.0, 0.5, 0.0]] * 4
    assert resolve("random", "rally_low", "humanlike", 0)(obs86, np.zeros((4, 3))).shape == (4, 15)
    scripted = resolve("scripted", "rally_low", "simple")
    assert scripted(obs20, np.full(4, 4.0)).shape == (4, 3)
    shipped = resolve("pretrained", "high", "simple")
    from rallysim.policies.registry import load_network

    net = load_network("pretrained", "high")
    assert np.array_equal(shipped(obs20), 4.0 + 2.0 * np.clip(net(obs20).reshape(-1), -1, 1))
    policy = lambda o: o  # noqa: E731
    assert resolve(policy, "mono") is policy


@pytest.mark.parametrize(("spec", "role", "player", "words"), [
    ("genius", "rally_low", "simple", "unknown simple low_level 'genius'"),
    ("fixed:nan", "high", "simple", "fixed"),
    ("fixed:1,2", "high", "humanlike", "3 finite value"),
    ("scripted", "high", "simple", "unknown simple high policy"),
    ("random", "boss", "simple", "unknown policy role"),
    (3, "low", "simple", "callable or a name"),
])
def test_registry_refuses_bad_names_clearly(spec, role, player, words):
    with pytest.raises(ValueError, match=words):
        resolve(spec, role, player)


def test_a_missing_policy_path_is_reported_by_the_loader(tmp_path):
    with pytest.raises(FileNotFoundError):
        resolve(str(tmp_path / "nothing"), "low")


def test_resolved_policies_pickle():
    for player in PLAYERS:
        low = resolve("scripted", "rally_low", player)
        assert type(pickle.loads(pickle.dumps(low))) is type(low)
