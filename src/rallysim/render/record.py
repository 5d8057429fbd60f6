"""Recording episodes of the low-level task as frames, one per decision (10 frames/s of game
time), with the goal's marker on the floor and a HUD of the episode and its reward."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rallysim.core.game import PHYSICS_DT, PHYSICS_STEPS_PER_DECISION
from rallysim.envs.rally_task import RALLY_OBS_SIZE, RallyConfig, RallyTask
from rallysim.envs.simple_return_v0 import SimpleReturnEnv
from rallysim.policies.registry import resolve
from rallysim.policies.resolve import low_level_policy
from rallysim.policies.types import LowLevel
from rallysim.render.scene import SceneRenderer

POLICIES = ("scripted", "random")
DECISION_SECONDS = PHYSICS_DT * PHYSICS_STEPS_PER_DECISION  # 0.1 s
Policy = Callable[[np.ndarray], np.ndarray]  # one observation (17,) -> one action (3,)


def record_low_level(n_episodes: int = 1, policy: str | Policy = "scripted", seed: int = 0,
                     shuttle: str = "paper", width: int = 640, height: int = 360,
                     camera: str = "side", renderer: SceneRenderer | None = None,
                     ) -> list[np.ndarray]:
    """Play ``n_episodes`` of ``SimpleReturnEnv`` and render every decision.

    ``policy`` is "scripted" (``ScriptedController``), "random" (uniform actions) or a batched
    callable ``(N, 17) observations -> (N, 3) actions``. Episode k
    is reset with seed ``seed + k``, so each episode replays on its own. Each episode gives its
    reset frame and one frame per step, the landing included. Pass a ``renderer`` (one player)
    to reuse its OpenGL context; its size and camera then win over the arguments."""
    if not callable(policy) and policy not in POLICIES:
        raise ValueError(f"unknown policy {policy!r}; valid: {', '.join(map(repr, POLICIES))}")
    if n_episodes < 1:
        raise ValueError(f"n_episodes must be >= 1, got {n_episodes}")
    own = renderer is None
    view = SceneRenderer(1, width, height, camera) if renderer is None else renderer
    env = SimpleReturnEnv(shuttle=shuttle)
    act = _policy(policy, seed)
    frames: list[np.ndarray] = []
    try:
        for k in range(n_episodes):
            frames += _episode(env, view, act, seed + k, f"episode {k + 1}/{n_episodes}")
    finally:
        if own:
            view.close()
    return frames


def _policy(name: str | Policy, seed: int) -> Policy:
    """One observation -> one action, from a batched policy or a shipped one's name."""
    batched = name if callable(name) else low_level_policy(name, seed)
    return lambda obs: np.asarray(batched(obs[None, :]))[0]


def _episode(env: SimpleReturnEnv, view: SceneRenderer, act: Policy, seed: int, title: str,
             ) -> list[np.ndarray]:
    obs, info = env.reset(seed=seed)
    goal = info["target_depth"]
    game = env.task.game
    view.reset_trail()
    total, decisions, event = 0.0, 0, ""
    frames = [view.render(game, 0, goal, _hud(title, decisions, goal, total, event))]
    done = False
    while not done:
        obs, reward, term, trunc, info = env.step(act(obs))
        total += reward
        decisions += 1
        done = term or trunc
        if info.get("hit"):
            event = f"hit at {info['racket_speed']:.1f} m/s"
        if info.get("landed"):
            where = "in" if info["landed_in"] else "out"
            event = f"landed {where} at {info['landing_depth']:.2f} m"
        frames.append(view.render(game, 0, goal, _hud(title, decisions, goal, total, event)))
    return frames


def _hud(title: str, decisions: int, goal: float, total: float, event: str) -> str:
    line1 = f"{title}   t = {decisions * DECISION_SECONDS:.1f} s   reward {total:+.3f}"
    line2 = f"target {goal:.2f} m" + (f"   {event}" if event else "")
    return f"{line1}\n{line2}"


HighLevel = Callable[[np.ndarray], np.ndarray]  # (M, 20) observations -> (M,) goals


def record_rally(n_rallies: int = 1, high_level: HighLevel | None = None,
                 low_level: LowLevel | str = "scripted", seed: int = 0,
                 config: RallyConfig | None = None, width: int = 640, height: int = 360,
                 camera: str = "side", max_decisions: int = 2000,
                 renderer: SceneRenderer | None = None) -> list[np.ndarray]:
    """Play ``n_rallies`` rallies (or competitive games) and render every decision.

    Each player's goal is chosen by ``high_level`` when its turn begins (default: uniform in
    [2, 6] m) and shown as its red marker; ``low_level`` swings. The HUD shows the rally
    length and the score. Rally k is seeded ``seed + k``."""
    if n_rallies < 1:
        raise ValueError(f"n_rallies must be >= 1, got {n_rallies}")
    rng = np.random.default_rng(seed)
    choose = high_level or (lambda obs: rng.uniform(2.0, 6.0, len(obs)))
    low = resolve(low_level, "rally_low", "simple", seed)
    own = renderer is None
    view = SceneRenderer(2, width, height, camera) if renderer is None else renderer
    frames: list[np.ndarray] = []
    try:
        for k in range(n_rallies):
            task = RallyTask(1, config, seed=seed + k)
            task.reset(np.array([0]))
            view.reset_trail()
            frames += _rally(task, view, choose, low, f"rally {k + 1}/{n_rallies}",
                             max_decisions)
    finally:
        if own:
            view.close()
    return frames


def _rally(task: RallyTask, view: SceneRenderer, choose: HighLevel, low: LowLevel, title: str,
           max_decisions: int) -> list[np.ndarray]:
    goals = np.full(2, 4.0)
    frames = []
    for decisions in range(max_decisions + 1):
        obs = task.observe()[0]
        starting = task.turn_started[0]
        if starting.any():
            goals[starting] = choose(obs[starting])
        score = task.score[0]
        hud = (f"{title}   t = {decisions * DECISION_SECONDS:.1f} s\n"
               f"rally length {int(task.game.hits[0])}   score {score[0]}-{score[1]}")
        frames.append(view.render(task.game, 0, list(goals), hud))
        if decisions == max_decisions:
            break
        actions = np.clip(low(obs.reshape(2, RALLY_OBS_SIZE), goals), -1.0, 1.0)
        _, term, trunc, _ = task.step(actions.reshape(1, 2, 3))
        if term[0] or trunc[0]:
            score = task.score[0]
            frames.append(view.render(task.game, 0, list(goals), (
                f"{title}   over after {decisions + 1} decisions\n"
                f"rally length {int(task.game.hits[0])}   score {score[0]}-{score[1]}")))
            break
    return frames
