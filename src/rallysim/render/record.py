"""Recording episodes as frames, one per decision (10 frames/s of game time), for SIMPLE and
HUMAN-LIKE players:

- ``record_low_level``: episodes of the low-level task (``SimpleReturnEnv`` or
  ``HumanLikeReturnEnv``) with the goal's marker and a HUD of the episode and its reward;
- ``record_rally``: rallies played by the turn loop (``rallysim.core.tasks.turn_loop``) with each
  player's held goal and a HUD of the rally length and score;
- ``record_match``: competitive games between two agents (``rallysim.eval.agents``: a
  Monolithic player can meet a hierarchical one) played by ``rallysim.eval.competitive.Match``,
  with the hierarchical players' held goals and a HUD of both names with their score, the
  rally length and who won the last point.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from rallysim.core.game import PHYSICS_DT, PHYSICS_STEPS_PER_DECISION
from rallysim.core.tasks.rally import RallyConfig, RallyTask
from rallysim.core.tasks.turn_loop import TurnLoop
from rallysim.eval.agents import Agent
from rallysim.eval.competitive import Match
from rallysim.players import PlayerSpec, get_player
from rallysim.policies.registry import resolve
from rallysim.policies.types import HighLevel, LowLevel, Policy
from rallysim.render.markers import goal_markers, target_markers
from rallysim.render.scene import SceneRenderer
from rallysim.render.scoreboard import Scoreboard, held_goals, player_names

POLICIES = ("scripted", "random")
DECISION_SECONDS = PHYSICS_DT * PHYSICS_STEPS_PER_DECISION  # 0.1 s


# -- the low-level task -------------------------------------------------------------------------
@dataclass(frozen=True)
class _LowLevelTask:
    """What recording one player kind's low-level task needs."""

    make_env: Callable[[str], Any]  # shuttle -> a single env
    player: str
    goal_text: Callable[[Any], str]
    event_text: Callable[[dict[str, Any]], str]  # "" when nothing happened


def _simple_task() -> _LowLevelTask:
    from rallysim.envs.simple_return_v0 import SimpleReturnEnv

    def event(info: dict[str, Any]) -> str:
        if info.get("landed"):
            return f"landed {'in' if info['landed_in'] else 'out'} at {info['landing_depth']:.2f} m"
        if info.get("hit"):
            return f"hit at {info['racket_speed']:.1f} m/s"
        return ""

    return _LowLevelTask(lambda shuttle: SimpleReturnEnv(shuttle=shuttle), "simple",
                         lambda goal: f"target {goal:.2f} m", event)


def _humanlike_task() -> _LowLevelTask:
    from rallysim.envs.humanlike_return_v0 import HumanLikeReturnEnv

    def event(info: dict[str, Any]) -> str:
        if info.get("landed"):
            return f"landed at x = {info['landing_point'][0]:+.2f} m"
        if info.get("hit"):
            speed = float(np.linalg.norm(info["racket_velocity"]))
            return f"hit at {speed:.1f} m/s, {info['angle_error']:.0f} deg off"
        return ""

    return _LowLevelTask(lambda shuttle: HumanLikeReturnEnv(shuttle=shuttle), "humanlike",
                         lambda v: f"target ({v[0]:+.1f}, {v[1]:+.1f}, {v[2]:+.1f}) m/s", event)


_LOW_LEVEL_TASKS = {"simple": _simple_task, "humanlike": _humanlike_task}


def record_low_level(n_episodes: int = 1, policy: str | Policy = "scripted", seed: int = 0,
                     shuttle: str = "paper", width: int = 640, height: int = 360,
                     camera: str | None = None, renderer: SceneRenderer | None = None,
                     player: str = "simple") -> list[np.ndarray]:
    """Play ``n_episodes`` of the low-level task of ``player`` (``"simple"``:
    ``SimpleReturnEnv``; ``"humanlike"``: ``HumanLikeReturnEnv``) and render every decision.

    ``policy`` is "scripted" (``ScriptedController``; HUMAN-LIKE: ``AimedSwing``), "random"
    (uniform actions) or a batched callable ``(N, obs) observations -> (N, actions)``. Episode
    k is reset with seed ``seed + k``, so each episode replays on its own. Each episode gives
    its reset frame and one frame per step, the landing included. ``camera`` None is the
    player kind's default. Pass a ``renderer`` (one player) to reuse its OpenGL context; its
    size and camera then win over the arguments."""
    if player not in _LOW_LEVEL_TASKS:
        raise ValueError(f"unknown player kind {player!r}; valid: "
                         f"{', '.join(map(repr, _LOW_LEVEL_TASKS))}")
    if not callable(policy) and policy not in POLICIES:
        raise ValueError(f"unknown policy {policy!r}; valid: {', '.join(map(repr, POLICIES))}")
    if n_episodes < 1:
        raise ValueError(f"n_episodes must be >= 1, got {n_episodes}")
    task = _LOW_LEVEL_TASKS[player]()
    own = renderer is None
    view = (SceneRenderer(1, width, height, camera, player=player) if renderer is None
            else renderer)
    env = task.make_env(shuttle)
    batched = resolve(policy, "low", task.player, seed)

    def act(obs: np.ndarray) -> np.ndarray:  # one observation -> one action
        return np.asarray(batched(obs[None, :]))[0]

    frames: list[np.ndarray] = []
    try:
        for k in range(n_episodes):
            frames += _episode(env, view, act, task, player, seed + k,
                               f"episode {k + 1}/{n_episodes}")
    finally:
        if own:
            view.close()
    return frames


def _episode(env: Any, view: SceneRenderer, act: Policy, task: _LowLevelTask, player: str,
             seed: int, title: str) -> list[np.ndarray]:
    obs, info = env.reset(seed=seed)
    goal = info[env.goal_key]
    marker = target_markers(player, goal)
    game = env.task.game
    view.reset_trail()
    total, decisions, event = 0.0, 0, ""

    def frame() -> np.ndarray:
        line1 = f"{title}   t = {decisions * DECISION_SECONDS:.1f} s   reward {total:+.3f}"
        line2 = task.goal_text(goal) + (f"   {event}" if event else "")
        return view.render(game, 0, hud_text=f"{line1}\n{line2}", **marker)

    frames = [frame()]
    done = False
    while not done:
        obs, reward, term, trunc, info = env.step(act(obs))
        total += reward
        decisions += 1
        done = term or trunc
        event = task.event_text(info) or event
        frames.append(frame())
    return frames


# -- rallies ------------------------------------------------------------------------------------
def record_rally(n_rallies: int = 1, high_level: HighLevel | None = None,
                 low_level: LowLevel | str = "scripted", seed: int = 0,
                 config: RallyConfig | None = None, width: int = 640, height: int = 360,
                 camera: str | None = None, max_decisions: int = 2000,
                 renderer: SceneRenderer | None = None, player: str = "simple",
                 ) -> list[np.ndarray]:
    """Play ``n_rallies`` rallies (or competitive games) of ``player``'s players (``"simple"``
    or ``"humanlike"``) and render every decision.

    Each player's goal is chosen by ``high_level`` (observations (M, obs) -> M goals) when
    its turn begins (default: uniform: depths in [2, 6] m; HUMAN-LIKE goals in [-1, 1]^3) and
    drawn as its red marker (a disc at the depth; HUMAN-LIKE: the target racket velocity's
    arrow); ``low_level`` (a callable or a name the rally core resolves) swings. The HUD shows
    the rally length and the score. Rally k is seeded ``seed + k``: the rally of a turn-based
    env reset with that seed and given the same goals. ``camera`` None is the player kind's
    default."""
    if n_rallies < 1:
        raise ValueError(f"n_rallies must be >= 1, got {n_rallies}")
    spec = get_player(player)
    choose = high_level or _uniform_goals(spec, np.random.default_rng(seed))
    low = resolve(low_level, "rally_low", spec, seed)
    own = renderer is None
    view = (SceneRenderer(2, width, height, camera, player=player) if renderer is None
            else renderer)
    frames: list[np.ndarray] = []
    try:
        for k in range(n_rallies):
            loop = TurnLoop(RallyTask(1, config, seed + k, spec), low)
            loop.reset(np.array([0]))
            view.reset_trail()
            frames += _rally(loop, view, choose, f"rally {k + 1}/{n_rallies}", max_decisions)
    finally:
        if own:
            view.close()
    return frames


def _uniform_goals(spec: PlayerSpec, rng: np.random.Generator) -> HighLevel:
    return lambda obs: spec.goal.sample(rng, len(obs))


def _rally(loop: TurnLoop, view: SceneRenderer, choose: HighLevel, title: str,
           max_decisions: int) -> list[np.ndarray]:
    task = loop.rally
    frames = []

    def frame(first_line: str) -> np.ndarray:
        score = task.score[0]
        hud = f"{first_line}\nrally length {int(task.game.hits[0])}   score {score[0]}-{score[1]}"
        return view.render(task.game, 0, hud_text=hud, **goal_markers(task.player, loop.goals[0]))

    for decisions in range(max_decisions + 1):
        obs = loop.observe()
        loop.choose_goals(choose, obs)
        frames.append(frame(f"{title}   t = {decisions * DECISION_SECONDS:.1f} s"))
        if decisions == max_decisions:
            break
        _, term, trunc, _ = loop.step(loop.low_level_actions(obs))
        if term[0] or trunc[0]:
            frames.append(frame(f"{title}   over after {decisions + 1} decisions"))
            break
    return frames


# -- competitive games between two agents -------------------------------------------------------
MATCH_DECISIONS = 600  # a minute of game time: 415 MB of 640x360 frames, held in memory


def record_match(a: Agent, b: Agent, n_games: int = 1, seed: int = 0,
                 config: RallyConfig | None = None, width: int = 640, height: int = 360,
                 camera: str | None = None, max_decisions: int = MATCH_DECISIONS,
                 renderer: SceneRenderer | None = None) -> list[np.ndarray]:
    """Play ``n_games`` competitive games of agent ``a`` against agent ``b`` (players of their
    kind, ``config`` default ``RallyConfig(mode="competitive")``) and render every decision.

    Game k is game 0 of ``Match(a, b, 1, seed + k, config)``: ``a`` plays player 0, on the left
    of the side camera's picture, and it replays as that match does. A game stops at its end or
    after ``max_decisions`` decisions. Each game gives a frame before each decision and one
    after its last, so ``decisions + 1`` frames. The HUD names both players with their score
    (player 0 first), the rally length and who won the last point; a hierarchical player's held
    goal is its red marker. ``camera`` None is the side view. Pass a ``renderer`` (two players)
    to reuse its OpenGL context; its size and camera then win over the arguments."""
    if not isinstance(n_games, int) or n_games < 1:
        raise ValueError(f"n_games must be a positive integer, got {n_games!r}")
    if not isinstance(max_decisions, int) or max_decisions < 1:
        raise ValueError(f"max_decisions must be a positive integer, got {max_decisions!r}")
    own = renderer is None
    if renderer is None:
        view = SceneRenderer(2, width, height, camera, player=a.player.name)
    else:
        view = renderer
    frames: list[np.ndarray] = []
    try:
        for k in range(n_games):
            match = Match(a, b, 1, seed + k, config)
            view.reset_trail()
            frames += _game(match, view, f"game {k + 1}/{n_games}", max_decisions)
    finally:
        if own:
            view.close()
    return frames


def _game(match: Match, view: SceneRenderer, title: str, max_decisions: int,
          ) -> list[np.ndarray]:
    task = match.task
    board = Scoreboard(player_names(match.a.name, match.b.name, match.side[0]))
    frames = []

    def frame(first_line: str) -> np.ndarray:
        # a goal chosen at a turn's start shows from the frame after that decision: agents
        # choose inside Match.step, where the turn loop of record_rally chooses before its
        # frame
        hud = board.text(first_line, int(task.game.hits[0]))
        return view.render(task.game, 0, hud_text=hud,
                           **goal_markers(task.player, held_goals(match)))

    for decisions in range(max_decisions + 1):
        frames.append(frame(f"{title}   t = {decisions * DECISION_SECONDS:.1f} s"))
        if decisions == max_decisions:
            break
        ended, info = match.step()
        board.update(info, bool(ended[0]))
        if info["rally_over"][0]:
            view.reset_trail()  # the next rally's shuttle, not a line from the last one
        if ended[0]:
            frames.append(frame(f"{title}   over after {decisions + 1} decisions, "
                                f"game to {board.result()}"))
            break
    return frames
