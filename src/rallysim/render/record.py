"""Recording episodes of the low-level task as frames, one per decision (10 frames/s of game
time), with the goal's marker on the floor and a HUD of the episode and its reward."""

from __future__ import annotations

from collections.abc import Callable

import numpy as np

from rallysim.core.game import PHYSICS_DT, PHYSICS_STEPS_PER_DECISION
from rallysim.envs.simple_return_v0 import SimpleReturnEnv
from rallysim.policies.scripted import ScriptedController
from rallysim.render.scene import SceneRenderer

POLICIES = ("scripted", "random")
DECISION_SECONDS = PHYSICS_DT * PHYSICS_STEPS_PER_DECISION  # 0.1 s
Policy = Callable[[np.ndarray], np.ndarray]  # one observation (17,) -> one action (3,)


def record_low_level(n_episodes: int = 1, policy: str = "scripted", seed: int = 0,
                     shuttle: str = "paper", width: int = 640, height: int = 360,
                     camera: str = "side", renderer: SceneRenderer | None = None,
                     ) -> list[np.ndarray]:
    """Play ``n_episodes`` of ``SimpleReturnEnv`` and render every decision.

    ``policy`` is "scripted" (``ScriptedController``) or "random" (uniform actions). Episode k
    is reset with seed ``seed + k``, so each episode replays on its own. Each episode gives its
    reset frame and one frame per step, the landing included. Pass a ``renderer`` (one player)
    to reuse its OpenGL context; its size and camera then win over the arguments."""
    if policy not in POLICIES:
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


def _policy(name: str, seed: int) -> Policy:
    if name == "scripted":
        controller = ScriptedController()
        return lambda obs: controller.act_return(obs[None, :])[0]
    rng = np.random.default_rng(seed)
    return lambda obs: rng.uniform(-1.0, 1.0, 3)


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
