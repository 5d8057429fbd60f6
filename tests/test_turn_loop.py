"""One turn loop (``rallysim.core.tasks.turn_loop``) serves the turn-based views, recorded videos
and the live viewer: given the same seed and high level they play the same rally, decision for
decision, for SIMPLE and HUMAN-LIKE players. None of this needs OpenGL (the recorder gets a
renderer that draws nothing, the viewer a stand-in window)."""

from __future__ import annotations

from typing import Any

import numpy as np
import pytest

from rallysim.core.tasks.turn_loop import TurnLoop
from rallysim.core.tasks.turns import TurnTask


class Events:
    """Every decision played through ``TurnLoop.step``, whoever drives it: the hits of both
    players, whether the shuttle landed, where, and the rally length."""

    def __init__(self, monkeypatch: pytest.MonkeyPatch) -> None:
        self.rows: list[tuple] = []
        real = TurnLoop.step

        def step(loop: TurnLoop, actions: np.ndarray, active: np.ndarray | None = None):
            out = real(loop, actions, active)
            info = out[3]
            self.rows.append((tuple(info["hit"][0].tolist()), bool(info["landed"][0]),
                              tuple(info["landing_point"][0].tolist()),
                              int(info["rally_length"][0])))
            return out

        monkeypatch.setattr(TurnLoop, "step", step)

    def take(self) -> list[tuple]:
        rows, self.rows = self.rows, []
        return rows


class NoFrames:
    """A renderer stand-in for ``record_rally``: counts frames, keeps the HUDs and targets."""

    def __init__(self) -> None:
        self.huds: list[str] = []
        self.targets: list[dict[str, Any]] = []

    def render(self, game: Any, env_index: int = 0, target_depth: Any = None,
               hud_text: str | None = None, *, target_velocity: Any = None) -> np.ndarray:
        self.huds.append(hud_text or "")
        self.targets.append({"depth": target_depth, "velocity": target_velocity})
        return np.zeros((2, 2, 3), np.uint8)

    def reset_trail(self) -> None:
        pass

    def close(self) -> None:
        pass


class Window:
    """A stand-in for MuJoCo's viewer: open until closed."""

    def __init__(self) -> None:
        self.synced = 0

    def is_running(self) -> bool:
        return True

    def sync(self) -> None:
        self.synced += 1

    def close(self) -> None:
        pass


def high_level(player: str, seed: int):
    """A fresh seeded random high level of ``player``."""
    from rallysim.policies.registry import resolve

    return resolve("random", "high", player, seed)


def turn_env(player: str, low: str):
    if player == "simple":
        from rallysim.envs.simple_rally_turn_v0 import SimpleRallyTurnEnv

        return SimpleRallyTurnEnv(low_level=low)
    from rallysim.envs.humanlike_rally_turn_v0 import HumanLikeRallyTurnEnv

    return HumanLikeRallyTurnEnv(low_level=low)


# (player, low level, seed): a SIMPLE rally of 10 hits, a HUMAN-LIKE one of 4
RALLIES = [("simple", "scripted", 3), ("humanlike", "pretrained", 2)]


@pytest.mark.parametrize("player, low, seed", RALLIES)
def test_turn_env_record_and_play_play_the_same_rally(player, low, seed, monkeypatch):
    from rallysim.render.play import play
    from rallysim.render.record import record_rally

    events = Events(monkeypatch)
    # the Gymnasium turn view, reset with the seed, its goals from the high level
    env = turn_env(player, low)
    obs, _ = env.reset(seed=seed)
    high = high_level(player, seed)
    done, decisions = False, 0
    while not done:
        obs, _, term, trunc, info = env.step(np.asarray(high(obs[None]))[0])
        decisions += info["decisions"]
        done = term or trunc
    by_env = events.take()
    assert len(by_env) == decisions and by_env[-1][3] == info["rally_length"]

    view = NoFrames()
    record_rally(1, high_level(player, seed), low, seed, renderer=view, player=player)
    by_record = events.take()
    assert len(view.huds) == decisions + 1  # a frame before each decision and one at the end

    lengths = play(low, high_level(player, seed), human=None, seed=seed, rallies=1,
                   viewer_factory=lambda model, data, key: Window(), realtime=False,
                   player=player)
    by_play = events.take()

    assert by_record == by_env
    assert by_play == by_env
    assert lengths == [info["rally_length"]]
    assert f"rally length {info['rally_length']}" in view.huds[-1]


def test_the_seeded_simple_rally_is_the_one_videos_always_showed(monkeypatch):
    """SIMPLE seed 3 with random goals and the scripted low level, as the recorder played it
    before the turn loop was shared: 10 hits, 154 decisions, the landing in player 0's half."""
    from rallysim.render.record import record_rally

    events = Events(monkeypatch)
    view = NoFrames()
    record_rally(1, high_level("simple", 3), "scripted", 3, renderer=view)
    rows = events.take()
    assert len(rows) == 154 and len(view.huds) == 155
    assert sum(sum(hit) for hit, *_ in rows) == 10 == rows[-1][3]
    landed = [i for i, row in enumerate(rows) if row[1]]
    assert landed == [153]
    assert rows[-1][2][0] == pytest.approx(-2.748037061441333, abs=1e-9)
    # both players' goals drawn as depths: the held ones, 4 m before the first turn
    assert view.targets[0]["depth"][1] == 4.0 and view.targets[0]["velocity"] is None
    assert all(2.0 <= d <= 6.0 for t in view.targets for d in t["depth"])


def test_turn_task_goals_are_the_loops():
    """``TurnTask`` keeps no goals of its own: a view's goals are the loop's arrays, so every
    driver reads and draws the same ones."""
    turns = TurnTask(3, "scripted", seed=0, player="humanlike")
    turns.reset(np.arange(3))
    assert turns.goals is turns.loop.goals and turns.goals.shape == (3, 2, 3)
    assert turns.turn_player is turns.loop.turn_player
    turns.step(np.array([0.5, -0.5, 1.0]))
    assert turns.loop.goals[0, 0].tolist() == [0.5, -0.5, 1.0]
    with pytest.raises(ValueError, match="finite"):
        turns.step(np.full(3, np.nan))
    with pytest.raises(ValueError, match="unknown player kind 'robot'; valid: 'humanlike'"):
        TurnLoop.build("robot", 1, "scripted")
