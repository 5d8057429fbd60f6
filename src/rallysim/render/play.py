"""``rallysim play``: watch a rally live in MuJoCo's viewer and take part by keyboard.

The rally is played by the turn loop (``rallysim.core.tasks.turn_loop``), as the turn-based
views and recorded videos play it, for SIMPLE or HUMAN-LIKE players. A person can take over one
player: a
SIMPLE player's actions come from the keys; a HUMAN-LIKE player's goals do (its 15 joints are
the learned low level's to move). Keys: ``rallysim.render.keyboard``. The other player (and
both, when nobody is taken over) is driven by the chosen low level with goals from the chosen
high level.

``play_match`` puts the person in a competitive game against any agent
(``rallysim.eval.agents``: ``scripted``, ``hrl``, ``mono``, the champion ``simple_compete``
once shipped, an exported policy): the keyboard is an agent too (``KeyboardAgent``), and
``rallysim.eval.competitive.Match`` plays the two, as it plays two agents for ``evaluate`` and
for recorded videos. The window's corner shows the score.

The window: ``rallysim.render.viewer`` (the scene only; the mouse moves the camera, Ctrl+A
returns to the starting view, ``[`` / ``]`` switch to the rendering model's fixed cameras).
"""

from __future__ import annotations

import contextlib
import copy
import time
from collections.abc import Callable
from typing import Any

import numpy as np

from rallysim.core.tasks.rally import RallyConfig
from rallysim.core.tasks.turn_loop import HighLevel, LowLevel, TurnLoop
from rallysim.eval.agents import Agent
from rallysim.eval.competitive import Match
from rallysim.render.keyboard import Keyboard, KeyboardAgent, KeyboardPlayer
from rallysim.render.markers import goal_markers
from rallysim.render.players import default_camera, rig_class
from rallysim.render.scoreboard import Scoreboard, held_goals, player_names
from rallysim.render.viewer import launch_viewer

DECISION_SECONDS = 0.1  # one decision of game time: the pace of a real-time window


def play(low_level: LowLevel | str, high_level: HighLevel, human: int | None = None,
         config: RallyConfig | None = None, seed: int = 0, rallies: int = 0,
         viewer_factory: Callable[..., Any] | None = None, realtime: bool = True,
         max_decisions: int | None = None, seconds: float | None = None,
         player: str = "simple", camera: str | None = None) -> list[int]:
    """Run rallies of ``player``'s players (``"simple"`` or ``"humanlike"``) in a live viewer
    until it is closed (or ``rallies`` are played, if > 0, or ``seconds`` of wall-clock time
    have passed, if given).

    ``human`` is the player (0 or 1) the keyboard drives, or None to watch. ``low_level`` (a
    callable or a name the rally core resolves) plays both players, ``high_level`` chooses
    the goals of every player the keyboard does not. Returns the rally lengths (in
    competitive mode: at each game's end). ``viewer_factory(model, data, key_callback)`` opens
    the window (default: ``launch_viewer``, MuJoCo's passive viewer, starting on ``camera``,
    default the player kind's: ``"side"`` for SIMPLE, ``"three_quarter_close"`` for
    HUMAN-LIKE); tests pass a stand-in."""
    from rallysim.render.scene import SceneRenderer

    _check_seconds(seconds)
    # the rally first: a bad low level's name fails before any window opens
    loop = TurnLoop.build(player, 1, low_level, config, seed)
    loop.reset(np.array([0]))
    keyboard = rig_class(player).keyboard()
    _load_compiled_steps(loop.rally.game, player)
    # the viewer draws the model itself: no offscreen OpenGL context next to its window's
    scene = SceneRenderer(2, offscreen=False, player=player)
    viewer = _open_window(scene, viewer_factory, camera or default_camera(player),
                          keyboard.press)
    lengths: list[int] = []

    def decision() -> None:
        _, term, trunc, _ = _decide(loop, high_level, keyboard, human)
        if term[0] or trunc[0]:
            lengths.append(int(loop.rally.game.hits[0]))
            loop.reset(np.array([0]))
            scene.reset_trail()
        _show(viewer, scene, loop.rally.game,
              goal_markers(loop.rally.player, loop.goals[0]))

    try:
        _run(viewer, decision, lambda: 0 < rallies <= len(lengths), realtime, max_decisions,
             seconds)
    finally:
        viewer.close()
        scene.close()
    return lengths


def _load_compiled_steps(game: Any, player: str) -> None:
    """Step a copy of ``game`` once, so that this process has loaded the compiled physics
    steps (from Numba's cache, or compiled them) before the window opens: otherwise the
    window's first second stands still. The copy is dropped; the rally is untouched."""
    from rallysim.players import get_player

    twin = copy.deepcopy(game)
    twin.step(np.zeros((twin.n_envs, twin.n_players, get_player(player).action.size)))


def _check_seconds(seconds: float | None) -> None:
    if seconds is not None and not seconds > 0:  # NaN included: it would never end
        raise ValueError(f"seconds must be > 0, got {seconds}")


def _open_window(scene: Any, viewer_factory: Callable[..., Any] | None, camera: str,
                 key_callback: Callable[[int], None]) -> Any:
    """The viewer on ``scene``'s model: ``viewer_factory(model, data, key_callback)``, by
    default MuJoCo's passive viewer starting on ``camera``."""
    if viewer_factory is None:
        def viewer_factory(model: Any, data: Any, key_callback: Callable[[int], None]) -> Any:
            return launch_viewer(model, data, camera, key_callback)

    return viewer_factory(scene.model, scene.data, key_callback)


def _run(viewer: Any, decision: Callable[[], None], done: Callable[[], bool], realtime: bool,
         max_decisions: int | None, seconds: float | None) -> None:
    """The window's loop, whatever plays: ``decision()`` (one decision, drawn) until the
    viewer closes, ``done()``, ``max_decisions`` or ``seconds`` of wall-clock time; at the
    pace of game time when ``realtime``."""
    decisions = 0
    began = time.perf_counter()
    while viewer.is_running() and not done():
        if max_decisions is not None and decisions >= max_decisions:
            break
        start = time.perf_counter()
        if seconds is not None and start - began >= seconds:
            break
        decision()
        decisions += 1
        if realtime:
            time.sleep(max(0.0, DECISION_SECONDS - (time.perf_counter() - start)))


def _decide(loop: TurnLoop, high_level: HighLevel, keyboard: Keyboard, human: int | None,
            ) -> tuple[np.ndarray, np.ndarray, np.ndarray, dict[str, Any]]:
    """One decision of the turn loop with the person's part in it: the goal its keys set
    (HUMAN-LIKE), or the action (SIMPLE)."""
    obs = loop.observe()
    steers_goals = human is not None and keyboard.steers_goals
    loop.choose_goals(high_level, obs, skip=human if steers_goals else None)
    if steers_goals:
        loop.set_goal(0, human, keyboard.goal())
    actions = loop.low_level_actions(obs)
    if human is not None and not keyboard.steers_goals:
        actions[0, human] = keyboard.action()
    return loop.step(actions)


def _show(viewer: Any, scene: Any, game: Any, markers: dict[str, Any],
          text: str | None = None) -> None:
    """Copy game 0 of ``game`` into the world the viewer draws with the goals ``markers``,
    hand the viewer the targets drawn per frame (HUMAN-LIKE's arrows) and the shuttle's trail
    (not bodies of the model: decor in the viewer's own scene), and ``text`` for its top-left
    corner, and draw."""
    # MuJoCo's viewer reads the data and its scene on its own thread; stand-ins for it in
    # tests may have neither a lock nor a scene (nor text).
    lock = getattr(viewer, "lock", None)
    with lock() if lock is not None else contextlib.nullcontext():
        scene.set_state(game, 0, **markers)
        user_scn = getattr(viewer, "user_scn", None)
        if user_scn is not None:
            user_scn.ngeom = 0
            scene.draw_markers(user_scn)
            scene.trail.draw(user_scn)
    set_texts = getattr(viewer, "set_texts", None)
    if text is not None and set_texts is not None:
        set_texts((None, None, text, None))  # the default font and corner: top left
    viewer.sync()


def play_match(opponent: Agent, human: int = 0, config: RallyConfig | None = None,
               seed: int = 0, games: int = 0, viewer_factory: Callable[..., Any] | None = None,
               realtime: bool = True, max_decisions: int | None = None,
               seconds: float | None = None, camera: str | None = None,
               keyboard: KeyboardPlayer | None = None) -> Scoreboard:
    """A person at the keyboard (player ``human``, 0 or 1; a SIMPLE player's actions, keys:
    ``rallysim.render.keyboard``) against the agent ``opponent`` in competitive games (rules:
    ``config``, default ``RallyConfig(mode="competitive")``) in a live viewer, until it is
    closed (or ``games`` are finished, if > 0, or ``max_decisions`` decisions or ``seconds``
    of wall-clock time have passed, if given).

    Game k is game 0 of ``Match(you, opponent, 1, seed + k, config)`` (``you`` first when
    ``human`` is 0, else second), the same games, decision for decision, as that match plays
    with the same keys. Returns the ``Scoreboard``: the score, every point's winner, the
    finished games. ``keyboard`` is the person's key state (default a fresh
    ``KeyboardPlayer``); ``viewer_factory`` as for ``play``."""
    from rallysim.render.scene import SceneRenderer

    if human not in (0, 1):
        raise ValueError(f"human must be player 0 or 1, got {human!r}")
    _check_seconds(seconds)
    you = KeyboardAgent(keyboard)
    pair = (you, opponent) if human == 0 else (opponent, you)

    def new_match(k: int) -> Match:
        return Match(*pair, 1, seed + k, config)

    match = new_match(0)  # before the window: bad rules fail here
    board = Scoreboard(player_names(pair[0].name, pair[1].name, match.side[0]))
    scene = SceneRenderer(2, offscreen=False, player="simple")
    viewer = _open_window(scene, viewer_factory, camera or default_camera("simple"),
                          you.keyboard.press)

    def decision() -> None:
        nonlocal match
        ended, info = match.step()
        board.update(info, bool(ended[0]))
        if info["rally_over"][0]:
            scene.reset_trail()  # the next rally's shuttle, not a line from the last one
        if ended[0]:
            # the next game at once: the window shows the play, the score its result
            board.new_game()
            board.last = f"game {len(board.games)} to {board.result(board.games[-1])}"
            match = new_match(len(board.games))
        text = board.text(f"game {len(board.games) + 1}", int(match.task.game.hits[0]))
        goals = goal_markers(match.task.player, held_goals(match))
        _show(viewer, scene, match.task.game, goals, text)

    try:
        _run(viewer, decision, lambda: 0 < games <= len(board.games), realtime, max_decisions,
             seconds)
    finally:
        viewer.close()
        scene.close()
    return board

