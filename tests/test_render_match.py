"""Competitive games between two agents in pictures: ``record_match`` (``rallysim render --mode
competitive --players A B``) and ``play_match`` (``rallysim play --opponent NAME``), both played
by ``rallysim.eval.competitive.Match``: the HUD's score is the match's, the frames replay, a
person at a stand-in keyboard scores what the same match scores."""

from __future__ import annotations

import hashlib
import itertools
from dataclasses import dataclass
from typing import Any

import numpy as np
import pytest

from rallysim.cli import main
from rallysim.core.tasks.rally import RallyConfig
from rallysim.eval.agents import Direct, Hierarchical, agent
from rallysim.eval.competitive import Match, play_games
from rallysim.render.keyboard import (
    KEY_LEFT,
    KEY_RIGHT,
    KEY_SPACE,
    KEY_UP,
    KeyboardAgent,
    KeyboardPlayer,
)
from rallysim.render.scoreboard import Scoreboard, player_names
from tests.conftest import gl_problem

SHORT = RallyConfig(mode="competitive", points_to_win=3, win_by=1)  # games of a few hundred


class StandInView:
    """Stands in for ``SceneRenderer`` (no OpenGL): keeps each frame's HUD text and goals."""

    def __init__(self) -> None:
        self.huds: list[str] = []
        self.targets: list[list[Any]] = []
        self.trail_resets = 0

    def render(self, game: Any, env: int = 0, target_depth: Any = None,
               hud_text: str | None = None, **_: Any) -> np.ndarray:
        self.huds.append(hud_text or "")
        self.targets.append(list(target_depth))
        return np.zeros((2, 2, 3), np.uint8)

    def reset_trail(self) -> None:
        self.trail_resets += 1

    def close(self) -> None:
        pass


def record(a: str, b: str, **kwargs: Any) -> StandInView:
    from rallysim.render.record import record_match

    view = StandInView()
    frames = record_match(agent(a), agent(b), renderer=view, **kwargs)
    assert len(frames) == len(view.huds)
    return view


def scores_after(a: str, b: str, seed: int, decisions: int) -> np.ndarray:
    """The score (player 0, player 1) of game 0 of a match played apart from any picture."""
    match = Match(agent(a), agent(b), 1, seed)
    for _ in range(decisions):
        match.step()
    return match.task.score[0]


# -- the HUD ------------------------------------------------------------------------------------
def test_hud_shows_the_matchs_score_after_each_decision():
    """Seed 0, mono against scripted: scripted wins points at decisions 75 and 230 (rallies of 7
    and 13 hits); frame k (before decision k + 1) shows the match's score after k decisions."""
    view = record("mono", "scripted", seed=0, max_decisions=240)
    assert len(view.huds) == 241  # a frame before each decision and one after the last
    for k in (0, 74, 75, 229, 230, 240):
        s0, s1 = scores_after("mono", "scripted", 0, k)
        assert f"mono {s0} - {s1} scripted" in view.huds[k], (k, view.huds[k])
    assert "mono 0 - 0 scripted" in view.huds[74] and "mono 0 - 1 scripted" in view.huds[75]
    assert "last point: scripted (7 hits)" in view.huds[75]
    assert "mono 0 - 2 scripted" in view.huds[240]
    assert "last point: scripted (13 hits)" in view.huds[240]
    assert "last point" not in view.huds[74]  # nobody has scored yet
    assert view.huds[0].splitlines()[0] == "game 1/1   t = 0.0 s"
    assert view.huds[240].splitlines()[0] == "game 1/1   t = 24.0 s"
    assert view.trail_resets == 1 + 2  # the game's start, then after each point's rally


def test_a_whole_game_ends_where_play_games_ends_it():
    """A game to 3 recorded to its end: ``decisions + 1`` frames, the final score and its
    winner in the last HUD, the same numbers as ``play_games`` of the same agents and seed."""
    games = play_games(agent("mono"), agent("scripted"), 1, seed=4, config=SHORT)
    (p0, p1), decisions = games.points[0], int(games.decisions[0])
    assert games.winner[0] == 1 and (p0, p1) == (0, 3)
    view = record("mono", "scripted", seed=4, config=SHORT, max_decisions=5000)
    assert len(view.huds) == decisions + 1
    last = view.huds[-1]
    assert f"over after {decisions} decisions, game to scripted 3-0" in last
    assert "mono 0 - 3 scripted" in last


def test_monolithic_meets_hierarchical_with_only_the_held_goal_drawn():
    """mono (a Direct agent: no goal) as player 0 against hrl: player 0 has no marker,
    player 1's is hrl's held goal, which changes as its turns begin."""
    from rallysim.render.record import record_match

    mono, hrl = agent("mono"), agent("hrl")
    assert isinstance(mono, Direct) and isinstance(hrl, Hierarchical)
    view = StandInView()
    record_match(mono, hrl, seed=1, max_decisions=150, renderer=view)
    assert all(np.isnan(t[0]) for t in view.targets)  # NaN: no marker
    goals = [t[1] for t in view.targets]
    assert all(isinstance(g, float) and 2.0 <= g <= 6.0 for g in goals)
    assert goals[-1] == pytest.approx(float(hrl.goals[0]))
    assert len(set(goals)) >= 2  # chosen anew at its turns, not the default held throughout
    assert "mono" in view.huds[-1].splitlines()[1].split(" - ")[0]


def test_two_games_each_replay_their_own_match():
    view = record("random", "scripted", n_games=2, seed=5, max_decisions=40)
    assert len(view.huds) == 2 * 41
    assert view.huds[41].startswith("game 2/2   t = 0.0 s")
    for k, frame in ((0, 40), (1, 81)):
        s0, s1 = scores_after("random", "scripted", 5 + k, 40)
        assert f"random {s0} - {s1} scripted" in view.huds[frame]


def test_scoreboard_names_and_lines():
    assert player_names("hrl", "mono", np.array([0, 1])) == ("hrl", "mono")
    assert player_names("hrl", "mono", np.array([1, 0])) == ("mono", "hrl")
    assert player_names("scripted", "scripted", np.array([0, 1])) == ("scripted (A)",
                                                                       "scripted (B)")
    board = Scoreboard(("hrl", "scripted"))
    info = {"point_winner": np.array([1]), "score": np.array([[3, 5]]),
            "rally_length": np.array([1]), "rally_over": np.array([True])}
    board.update(info)
    assert board.score_line == "hrl 3 - 5 scripted"
    assert board.text("t", 0).splitlines() == ["t", "hrl 3 - 5 scripted   rally length 0",
                                               "last point: scripted (1 hit)"]
    assert board.result() == "scripted 5-3" and board.result((21, 19)) == "hrl 21-19"
    board.update({**info, "point_winner": np.array([-1]), "rally_length": np.array([50])})
    assert board.last == "last rally: a let at 50 hits, replayed"
    assert board.point_winners == [1] and board.games == []


def test_record_match_refuses_bad_counts():
    from rallysim.render.record import record_match

    for kwargs in ({"n_games": 0}, {"max_decisions": 0}, {"max_decisions": 2.5}):
        with pytest.raises(ValueError, match="positive integer"):
            record_match(agent("scripted"), agent("scripted"), renderer=StandInView(), **kwargs)
    with pytest.raises(ValueError, match="competitive"):
        record_match(agent("scripted"), agent("scripted"), config=RallyConfig(),
                     renderer=StandInView())


# -- real frames --------------------------------------------------------------------------------
_GL = gl_problem()
needs_gl = pytest.mark.skipif(_GL is not None, reason=_GL or "")


def digest(frames: list[np.ndarray]) -> str:
    h = hashlib.sha256()
    for f in frames:
        h.update(f.tobytes())
    return h.hexdigest()


@needs_gl
def test_frames_replay_for_a_seed_and_count_the_decision_limit():
    from rallysim.render.record import record_match

    def frames(seed: int) -> list[np.ndarray]:
        return record_match(agent("hrl"), agent("mono"), seed=seed, max_decisions=25,
                            width=96, height=64)

    first, again, other = frames(3), frames(3), frames(4)
    assert len(first) == 26 and all(f.shape == (64, 96, 3) for f in first)
    assert digest(first) == digest(again)
    assert digest(first) != digest(other)
    assert any(np.any(a != b) for a, b in itertools.pairwise(first))


@needs_gl
def test_render_players_writes_the_game(tmp_path, capsys):
    pytest.importorskip("imageio")
    import imageio.v3 as iio

    argv = ["render", "--mode", "competitive", "--players", "hrl", "mono", "--size", "160x96",
            "--stills", "4", "--out", str(tmp_path)]
    assert main([*argv, "--decisions", "20"]) == 0
    stem = tmp_path / "match_hrl_vs_mono"
    assert iio.imread(stem.with_suffix(".mp4")).shape == (21, 96, 160, 3)
    assert "(21 frames)" in capsys.readouterr().out
    assert stem.with_name(stem.name + "_strip.png").stat().st_size > 1000
    assert main([*argv, "--seconds", "1.5"]) == 0  # 15 decisions of game time
    assert iio.imread(stem.with_suffix(".mp4")).shape[0] == 16


# -- render: bad command lines ------------------------------------------------------------------
@pytest.mark.parametrize("argv, words", [
    (["--mode", "competitive", "--players", "hrl"], "two names"),
    (["--mode", "competitive", "--players", "hrl", "mono", "random"], "two names"),
    (["--players", "hrl", "mono"], "add --mode competitive"),
    (["--mode", "cooperative", "--players", "hrl", "mono"], "add --mode competitive"),
    (["--mode", "competitive", "--players", "hrl", "bogus"], "unknown competitive player 'bogus'"),
    (["--mode", "competitive", "--players", "no/such/champion", "hrl"],
     "unknown competitive player 'no/such/champion'"),
    (["--mode", "competitive", "--players", "hrl", "mono", "--env", "low"], "--env low"),
    # HUMAN-LIKE players play competitive games, but no HUMAN-LIKE Monolithic policy is shipped
    (["--mode", "competitive", "--players", "hrl", "mono", "--player", "humanlike"],
     "no pretrained humanlike mono-level policy"),
    (["--mode", "competitive", "--players", "hrl", "mono", "--high", "random"], "--high"),
    (["--mode", "competitive", "--players", "hrl", "mono", "--decisions", "0"], "--decisions"),
    (["--mode", "competitive", "--players", "hrl", "mono", "--seconds", "4000"], "--seconds"),
    (["--mode", "competitive", "--players", "hrl", "mono", "--seconds", "1", "--decisions",
      "3"], "not allowed"),
    (["--decisions", "5"], "--players"),
])
def test_render_players_errors_are_one_line(argv, words, tmp_path, capsys, monkeypatch):
    import rallysim.render.record

    def never(*args: Any, **kwargs: Any) -> Any:
        raise AssertionError("rendered despite a bad command line")

    for name in ("record_match", "record_rally", "record_low_level"):
        monkeypatch.setattr(rallysim.render.record, name, never)
    out = tmp_path / "videos"
    assert main(["render", *argv, "--out", str(out)]) == 2
    captured = capsys.readouterr()
    lines = captured.err.splitlines()
    assert captured.out == "" and len(lines) == 1
    assert lines[0].startswith("rallysim render: error: ") and words in lines[0], lines[0]
    assert not out.exists()  # nothing made before the error


# -- play against an agent ----------------------------------------------------------------------
@dataclass
class ScriptedKeys(KeyboardPlayer):
    """A person at the keyboard who presses the same keys at the same decisions every time."""

    count: int = 0

    def action(self) -> np.ndarray:
        key = KEY_SPACE if self.count % 7 == 0 else {3: KEY_RIGHT, 10: KEY_LEFT,
                                                      12: KEY_UP}.get(self.count % 40)
        if key is not None:
            self.press(key)
        self.count += 1
        return super().action()


class TextViewer:
    """Stands in for MuJoCo's window: closes after ``n`` syncs, keeps the corner's text."""

    def __init__(self, n: int) -> None:
        self.n, self.synced, self.texts = n, 0, []
        self.press = None

    def is_running(self) -> bool:
        return self.synced < self.n

    def sync(self) -> None:
        self.synced += 1

    def set_texts(self, texts: tuple) -> None:
        self.texts.append(texts[2])

    def close(self) -> None:
        pass


def replay(human: int, seed: int, decisions: int) -> tuple[list[int], list[tuple[int, int]]]:
    """Point winners and finished games' scores of the same keys against scripted, played by
    ``Match`` alone: game k seeded seed + k."""
    you, opponent = KeyboardAgent(ScriptedKeys()), agent("scripted")
    pair = (you, opponent) if human == 0 else (opponent, you)
    winners, games, k = [], [], 0
    match = Match(*pair, 1, seed, SHORT)
    for _ in range(decisions):
        ended, info = match.step()
        if info["point_winner"][0] >= 0:
            winners.append(int(info["point_winner"][0]))
        if ended[0]:
            games.append(tuple(int(v) for v in info["score"][0]))
            k += 1
            match = Match(*pair, 1, seed + k, SHORT)
    return winners, games


@pytest.mark.parametrize("human", [0, 1])
def test_play_match_scores_what_the_match_scores(human):
    from rallysim.render.play import play_match

    viewer = TextViewer(200)

    def factory(model: Any, data: Any, key_callback: Any) -> TextViewer:
        viewer.press = key_callback
        return viewer

    board = play_match(agent("scripted"), human, SHORT, seed=1, viewer_factory=factory,
                       realtime=False, keyboard=ScriptedKeys())
    assert viewer.synced == 200
    winners, games = replay(human, 1, 200)
    assert board.point_winners == winners and board.games == games
    assert len(games) >= 2 and len(winners) >= 7  # games to 3 restart; both sides score
    assert human in winners and 1 - human in winners
    assert board.names == (("you", "scripted") if human == 0 else ("scripted", "you"))
    # the window's corner shows the score as it stands
    s0, s1 = board.score
    assert f"{board.names[0]} {s0} - {s1} {board.names[1]}" in viewer.texts[-1]
    assert viewer.texts[-1].startswith(f"game {len(games) + 1}\n")


def test_play_match_keys_come_from_the_window(monkeypatch):
    """The viewer's key presses reach the person's player: it walks after KEY_RIGHT."""
    from rallysim.core.tasks.rally import RallyTask
    from rallysim.render.play import play_match

    moves = []
    real = RallyTask.step

    def spy(self, actions, active=None):
        moves.append(float(actions[0, 1, 2]))  # player 1's movement
        return real(self, actions, active)

    monkeypatch.setattr(RallyTask, "step", spy)
    viewer = TextViewer(5)

    def factory(model: Any, data: Any, key_callback: Any) -> TextViewer:
        key_callback(KEY_RIGHT)
        return viewer

    play_match(agent("mono"), 1, seed=0, viewer_factory=factory, realtime=False)
    assert moves == [1.0] * 5
    with pytest.raises(ValueError, match="player 0 or 1"):
        play_match(agent("mono"), 2, viewer_factory=factory, realtime=False)
    with pytest.raises(ValueError, match="one game"):
        KeyboardAgent().start(2)


def test_keyboard_agent_acts_once_per_decision():
    keys = KeyboardPlayer()
    you = KeyboardAgent(keys)
    you.start(1)
    keys.press(KEY_SPACE)
    obs, started, row = np.zeros((1, 20)), np.zeros(1, bool), np.array([0])
    assert you.act(obs[:0], started[:0], row[:0]).shape == (0, 3)  # no live game: no decision
    swings = [you.act(obs, started, row)[0, 0] for _ in range(4)]
    assert swings[:3] == [1.0, 1.0, 1.0] and swings[3] == pytest.approx(-45 / 85)


# -- the play command ---------------------------------------------------------------------------
@pytest.fixture
def stand_in_play(monkeypatch):
    """``play`` and ``play_match`` record their arguments instead of opening a window."""
    import rallysim.envs.rendering
    import rallysim.render.play

    calls: list[tuple[str, tuple, dict]] = []

    def stand_in(name: str) -> Any:
        def run(*args: Any, **kwargs: Any) -> Any:
            calls.append((name, args, kwargs))
            return Scoreboard(("you", "x")) if name == "play_match" else []

        return run

    monkeypatch.setattr(rallysim.render.play, "play", stand_in("play"))
    monkeypatch.setattr(rallysim.render.play, "play_match", stand_in("play_match"))
    monkeypatch.setattr(rallysim.envs.rendering, "has_display", lambda: True)
    return calls


@pytest.mark.parametrize("argv, runner, opponent", [
    ([], "play_match", "simple_compete"),  # the default opponent: the shipped champion
    (["--opponent", "hrl"], "play_match", "hrl"),
    (["--opponent", "mono", "--human", "1"], "play_match", "mono"),
    (["--high", "fixed:3"], "play_match", "fixed:3 goals"),  # the computer of --high/--policy
    (["--human", "none"], "play", None),
    (["--mode", "cooperative"], "play", None),
    (["--player", "humanlike"], "play", None),
])
def test_play_command_picks_the_opponent(argv, runner, opponent, stand_in_play):
    assert main(["play", *argv]) == 0
    [(name, args, _)] = stand_in_play
    assert name == runner
    if opponent is not None:
        assert args[0].name == opponent
        assert args[1] == (1 if "1" in argv else 0)


@pytest.mark.parametrize("argv, words", [
    (["--opponent", "bogus"], "unknown competitive player 'bogus'"),
    (["--opponent", "no/such/champion"], "unknown competitive player 'no/such/champion'"),
    (["--opponent", "hrl", "--mode", "cooperative"], "--mode competitive"),
    (["--opponent", "hrl", "--player", "humanlike"], "HUMAN-LIKE"),
    (["--opponent", "hrl", "--human", "none"], "--human 0 or 1"),
    (["--opponent", "hrl", "--policy", "scripted"], "drop --policy and --high"),
])
def test_play_opponent_errors_are_one_line(argv, words, stand_in_play, capsys):
    assert main(["play", *argv]) == 2
    assert stand_in_play == []
    lines = capsys.readouterr().err.splitlines()
    assert len(lines) == 1 and lines[0].startswith("rallysim play: error: ")
    assert words in lines[0], lines[0]
