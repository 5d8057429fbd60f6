"""Competitive play of HUMAN-LIKE players: games between two HUMAN-LIKE agents (the kind comes
from the agents), the compete stage's league for ``--player humanlike``, and ``evaluate`` /
``render --mode competitive --player humanlike``."""

from __future__ import annotations

import json

import numpy as np
import pytest

from rallysim.cli import main
from rallysim.eval.agents import agent
from rallysim.eval.competitive import Match
from rallysim.players import HUMANLIKE


def test_a_game_needs_two_players_of_one_kind():
    with pytest.raises(ValueError, match="a game needs two players of one kind"):
        Match(agent("scripted"), agent("scripted", "humanlike"), 1)


def test_humanlike_agents_play_with_humanlike_bodies():
    match = Match(agent("scripted", "humanlike"), agent("hrl", "humanlike"), 2, seed=0)
    assert match.task.spec is HUMANLIKE
    assert match.actions.shape == (2, 2, HUMANLIKE.action.size)
    obs = match.task.observe()
    assert obs.shape == (2, 2, HUMANLIKE.rally_obs.size)
    for _ in range(30):  # the serve comes over and the receiver swings
        match.step()
    assert match.task.game.hits[0] + match.task.game.hits[1] >= 1


@pytest.fixture(scope="module")
def scripted_vs_random(tmp_path_factory):
    """``evaluate --mode competitive --player humanlike``: the scripted swing against random
    goals; its JSON and printout."""
    out = tmp_path_factory.mktemp("hl") / "games.json"
    code = main(["evaluate", "--mode", "competitive", "--player", "humanlike", "--players",
                 "scripted", "random", "--games", "4", "--seed", "3", "--max-decisions", "1000",
                 "--json", str(out)])
    return code, json.loads(out.read_text())["competitive"]


@pytest.mark.slow
def test_evaluate_plays_humanlike_players(scripted_vs_random):
    code, doc = scripted_vs_random
    assert code == 0 and doc["players"] == ["scripted", "random"]
    assert doc["settings"]["player"] == "humanlike"


@pytest.mark.slow  # (scripted_vs_random: HUMAN-LIKE games)
def test_the_scripted_swing_beats_random_goals(scripted_vs_random):
    _, doc = scripted_vs_random
    assert doc["points"] >= 30
    assert doc["point_win_rate"]["value"] >= 0.6  # random goals send many shots out or short
    assert 1.0 <= doc["mean_rally"]["value"] <= 10.0


@pytest.mark.slow
def test_a_humanlike_low_level_makes_the_games_humanlike(tmp_path):
    # --low names a HUMAN-LIKE low level: the player kind follows it without --player
    out = tmp_path / "games.json"
    assert main(["evaluate", "--mode", "competitive", "--low", "humanlike_low", "--players",
                 "scripted", "hrl", "--games", "2", "--max-decisions", "300",
                 "--json", str(out)]) == 0
    assert json.loads(out.read_text())["competitive"]["settings"]["player"] == "humanlike"


@pytest.mark.slow  # trains
def test_the_compete_stage_trains_a_humanlike_high_level(tmp_path):
    pytest.importorskip("stable_baselines3")
    from rallysim.policies.mlp import load_policy
    from rallysim.train.config import load_config
    from rallysim.train.runner import train_stage

    config = load_config("compete", overrides={
        "player": "humanlike", "budget": 256, "ppo.n_envs": 8, "ppo.n_steps": 32,
        "ppo.batch_size": 128, "ppo.n_epochs": 1, "checkpoint_every": 256, "eval.every": 0,
        "eval.episodes": 1, "league.snapshot_every": 256, "league.max_decisions": 600,
        "league.rating_games": 1, "league.rating_decisions": 200,
        "league.ladder": "scripted", "league.eval_opponents": "scripted"})
    assert config.league.ladder == "scripted"  # the user's setting wins over the overlay
    assert load_config("compete", overrides={"player": "humanlike"}).league.ladder == \
        "random,scripted,hrl"  # the HUMAN-LIKE overlay: no mono or fixed-depth rung
    out = tmp_path / "run"
    curve = train_stage(config, out, progress=False)
    names = sorted(p.stem for p in (out / "pool").glob("*.json"))
    assert names == ["snapshot_000000000000", "snapshot_000000000256"]
    doc = json.loads((out / "pool" / f"{names[-1]}.json").read_text())
    assert doc["metadata"]["player"] == "humanlike"
    policy = load_policy(out / "pool" / names[-1])
    goals = policy(np.zeros((3, HUMANLIKE.rally_obs.size), np.float32))
    assert goals.shape == (3, HUMANLIKE.goal.size)  # speed, elevation, azimuth
    assert curve["final"]["vs_scripted"]["points"] > 0
    # the champion is a HUMAN-LIKE player: refused as a SIMPLE one, and evaluate plays it
    # as HUMAN-LIKE without --player
    with pytest.raises(ValueError, match="is a humanlike player"):
        agent(str(out / "policy"), "simple")
    games = tmp_path / "games.json"
    assert main(["evaluate", "--mode", "competitive", "--players", str(out / "policy"),
                 "scripted", "--games", "1", "--max-decisions", "200", "--json",
                 str(games)]) == 0
    doc = json.loads(games.read_text())["competitive"]
    assert doc["settings"]["player"] == "humanlike" and doc["decisions"] == 200


class TargetsSeen:
    """Stands in for ``SceneRenderer`` (no OpenGL): keeps each frame's target velocities."""

    def __init__(self) -> None:
        self.targets: list[np.ndarray] = []

    def render(self, game, env=0, target_depth=None, hud_text=None, *, target_velocity=None):
        assert target_depth is None  # HUMAN-LIKE goals are drawn as velocities
        self.targets.append(np.array(target_velocity))
        return np.zeros((2, 2, 3), np.uint8)

    def reset_trail(self) -> None:
        pass


def test_held_humanlike_goals_are_drawn_as_target_velocities():
    from rallysim.players.humanlike import targets_from_goals
    from rallysim.render.record import record_match

    hrl, scripted = agent("hrl", "humanlike"), agent("scripted", "humanlike")
    view = TargetsSeen()
    record_match(hrl, scripted, seed=0, max_decisions=60, renderer=view)
    last = view.targets[-1]
    assert last.shape == (2, 3)
    # hrl is player 0 in game 0: its held goal as the racket velocity it asks for, in m/s
    np.testing.assert_allclose(last[0], targets_from_goals(hrl.goals[:1])[0])
    np.testing.assert_allclose(last[1], targets_from_goals(scripted.goals[:1])[0])
    assert len({tuple(t[0]) for t in view.targets}) >= 2  # hrl chose anew at its turns


def test_render_a_humanlike_match(tmp_path):
    from tests.conftest import gl_problem

    problem = gl_problem()
    if problem:
        pytest.skip(problem)
    from rallysim.render.record import record_match

    frames = record_match(agent("scripted", "humanlike"), agent("hrl", "humanlike"), seed=0,
                          width=160, height=90, max_decisions=20)
    assert len(frames) == 21 and frames[0].shape == (90, 160, 3)
    assert not np.array_equal(frames[0], frames[-1])  # the players and the shuttle moved
