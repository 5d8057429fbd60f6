"""Golden episodes: a hash of every value each env view returns over seeded steps.

A behaviour-preserving change must leave every hash unchanged; a change that alters behaviour
regenerates them in its own commit, with the reason (``python tests/golden.py --write``).
Actions are drawn from a seeded generator over each view's action space, so the hashes cover
misses, net touches, landings and episode ends as well as good play.
"""

from __future__ import annotations

import hashlib
import json
import sys
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import gymnasium as gym
import numpy as np

import rallysim  # noqa: F401  (registers the env ids)
from rallysim.envs import (
    humanlike_rally_turn_v0,
    humanlike_rally_v0,
    simple_rally_turn_v0,
    simple_rally_v0,
)

GOLDEN_FILE = Path(__file__).with_name("data") / "golden.json"
SHUTTLES = ("paper", "paper-alg1", "aero")
STEPS = 2000  # env steps per case (a vector view's steps count each of its envs)
SEED = 7


class Hasher:
    """SHA-256 over values rounded to 1e-9, so the digest is one of values, not of dtypes."""

    def __init__(self) -> None:
        self._h = hashlib.sha256()

    def add(self, value: Any) -> None:
        if isinstance(value, dict):
            for key in sorted(value):
                self._h.update(str(key).encode())
                self.add(value[key])
            return
        if isinstance(value, (list, tuple)):
            for item in value:
                self.add(item)
            return
        if isinstance(value, str):
            self._h.update(value.encode())
            return
        arr = np.asarray(value)
        if arr.dtype == object:
            self.add(list(arr.ravel()))
            return
        if arr.dtype.kind in "fc":
            arr = np.round(arr.astype(np.float64), 9)
            arr = np.where(arr == 0.0, 0.0, arr)  # -0.0 and 0.0 hash alike
        self._h.update(str(arr.shape).encode())
        self._h.update(np.ascontiguousarray(arr).tobytes())

    def hexdigest(self) -> str:
        return self._h.hexdigest()[:16]


def _steps_gym_single(env: gym.Env, steps: int, rng: np.random.Generator, h: Hasher) -> None:
    for _ in range(steps):
        action = rng.uniform(env.action_space.low, env.action_space.high)
        out = env.step(action.astype(env.action_space.dtype))
        h.add(out)
        if out[2] or out[3]:
            h.add(env.reset())


def _steps_gym_vector(env: gym.vector.VectorEnv, steps: int, rng: np.random.Generator,
                      h: Hasher) -> None:
    space = env.action_space
    for _ in range(steps // env.num_envs):
        h.add(env.step(rng.uniform(space.low, space.high).astype(space.dtype)))


def _steps_parallel(env: Any, steps: int, rng: np.random.Generator, h: Hasher) -> None:
    for _ in range(steps):
        if not env.agents:
            h.add(env.reset())
        actions = {a: rng.uniform(env.action_space(a).low, env.action_space(a).high)
                   .astype(np.float32) for a in env.agents}
        h.add(env.step(actions))
        h.add(env.state())


def _steps_aec(env: Any, steps: int, rng: np.random.Generator, h: Hasher) -> None:
    for _ in range(steps):
        if not env.agents:
            env.reset()
        agent = env.agent_selection
        h.add([agent, env.last()])
        space = env.action_space(agent)
        done = env.terminations[agent] or env.truncations[agent]
        env.step(None if done else rng.uniform(space.low, space.high).astype(np.float32))
        h.add([env.rewards, env.infos])


STEPPERS = {"gym": _steps_gym_single, "vector": _steps_gym_vector,
            "parallel": _steps_parallel, "aec": _steps_aec}


@dataclass(frozen=True)
class View:
    """One env view: how to make it, which API it speaks, how many steps its golden run takes."""

    name: str
    api: str  # a key of STEPPERS
    make: Callable[[], Any]
    steps: int = STEPS

    def reset(self, env: Any, h: Hasher, seed: int | None = SEED) -> None:
        out = env.reset(seed=seed)
        if self.api != "aec":
            h.add(out)

    def play(self, env: Any, steps: int, rng: np.random.Generator, h: Hasher) -> None:
        STEPPERS[self.api](env, steps, rng, h)

    def digest(self) -> str:
        env = self.make()
        h = Hasher()
        self.reset(env, h)
        self.play(env, self.steps, np.random.default_rng(SEED), h)
        env.close()
        return h.hexdigest()


# The turn views play a whole turn (tens of decisions of the low level) per step; HUMAN-LIKE's
# decisions cost several times SIMPLE's.
TURN_STEPS = {"simple_rally_v0": 200, "humanlike_rally_v0": 60}


def views() -> Iterator[View]:
    """Every env id and view, for each shuttle model (rallies: both modes where they differ)."""
    for s in SHUTTLES:
        yield View(f"SimpleReturn-v0/single/{s}", "gym",
                   lambda s=s: gym.make("RallySim/SimpleReturn-v0", shuttle=s))
        yield View(f"SimpleReturn-v0/vector/{s}", "vector",
                   lambda s=s: gym.make_vec("RallySim/SimpleReturn-v0", num_envs=8, shuttle=s))
        yield View(f"HumanLikeReturn-v0/single/{s}", "gym",
                   lambda s=s: gym.make("RallySim/HumanLikeReturn-v0", shuttle=s))
        yield View(f"HumanLikeReturn-v0/vector/{s}", "vector",
                   lambda s=s: gym.make_vec("RallySim/HumanLikeReturn-v0", num_envs=8,
                                            shuttle=s))
        # (the turn views keep the names they had while they lived in the rally modules)
        for name, mod, vec, turn, turn_vec, turn_single in (
                ("simple_rally_v0", simple_rally_v0, simple_rally_v0.SimpleRallyVectorEnv,
                 simple_rally_turn_v0, simple_rally_turn_v0.SimpleRallyTurnVectorEnv,
                 simple_rally_turn_v0.SimpleRallyTurnEnv),
                ("humanlike_rally_v0", humanlike_rally_v0,
                 humanlike_rally_v0.HumanLikeRallyVectorEnv, humanlike_rally_turn_v0,
                 humanlike_rally_turn_v0.HumanLikeRallyTurnVectorEnv,
                 humanlike_rally_turn_v0.HumanLikeRallyTurnEnv)):
            turns = TURN_STEPS[name]
            for mode in ("cooperative", "competitive"):
                yield View(f"{name}/parallel/{s}/{mode}", "parallel",
                           lambda s=s, m=mod, mode=mode: m.parallel_env(shuttle=s, mode=mode))
                yield View(f"{name}/turn_aec/{s}/{mode}", "aec",
                           lambda s=s, t=turn, mode=mode: t.raw_env(shuttle=s, mode=mode), turns)
            yield View(f"{name}/vector/{s}", "vector", lambda s=s, v=vec: v(4, shuttle=s))
            yield View(f"{name}/turn_vector/{s}", "vector",
                       lambda s=s, v=turn_vec: v(4, shuttle=s), turns)
            yield View(f"{name}/turn_single/{s}", "gym",
                       lambda s=s, t=turn_single: t(shuttle=s), turns)
    yield View("SimpleRallyTurn-v0/gym.make/paper", "gym",
               lambda: gym.make("RallySim/SimpleRallyTurn-v0", shuttle="paper"),
               TURN_STEPS["simple_rally_v0"])


def _pretrained_simple() -> str:
    """The shipped SIMPLE policies' evaluation numbers: returns, HRL and Monolithic rallies."""
    from rallysim.eval.low_eval import evaluate_return
    from rallysim.eval.rally_eval import rally_lengths_direct, rally_lengths_turns
    from rallysim.policies.registry import resolve

    h = Hasher()
    h.add(evaluate_return(resolve("pretrained", "low"), episodes=64, seed=99).as_dict())
    h.add(rally_lengths_turns(resolve("pretrained", "high"), resolve("pretrained", "rally_low"),
                              16, seed=99))
    h.add(rally_lengths_direct(resolve("pretrained", "mono"), 16, seed=99))
    return h.hexdigest()


def _pretrained_humanlike() -> str:
    """The shipped HUMAN-LIKE pair's evaluation numbers (serves and 3-D rallies)."""
    from rallysim.eval.humanlike_eval import evaluate_humanlike_player

    out = evaluate_humanlike_player(episodes=32, rallies=4, seeds=1)
    h = Hasher()
    h.add([out["low_level"], out["lengths"]])
    return h.hexdigest()


def cases() -> Iterator[tuple[str, Callable[[], str]]]:
    for view in views():
        yield view.name, view.digest
    yield "pretrained/simple", _pretrained_simple
    yield "pretrained/humanlike", _pretrained_humanlike


def compute(names: list[str] | None = None) -> dict[str, str]:
    return {name: run() for name, run in cases() if names is None or name in names}


if __name__ == "__main__":
    if sys.argv[1:] != ["--write"]:
        sys.exit("usage: python tests/golden.py --write   (regenerates tests/data/golden.json)")
    from rallysim.numerics import pinned_environ, pinned_here

    if not pinned_here():  # the hashes are the pinned numerics' (docs/numerics.md)
        import os

        os.execve(sys.executable, [sys.executable, *sys.argv], pinned_environ())
    GOLDEN_FILE.parent.mkdir(exist_ok=True)
    GOLDEN_FILE.write_text(json.dumps(compute(), indent=1, sort_keys=True) + "\n")
    print(f"wrote {GOLDEN_FILE}")
