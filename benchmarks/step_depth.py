"""Python frames between an env's ``step`` and its compiled physics step, per env id.

Each frame is a call a decision pays for (and a place to read when following the code); the
redesign (issue 16) reports this before and after. Run: ``python benchmarks/step_depth.py``
(add ``--stack`` to print each stack).
"""

from __future__ import annotations

import argparse
import sys
import warnings
from collections.abc import Callable
from typing import Any

import gymnasium as gym
import numpy as np

import rallysim  # noqa: F401  (registers the ids)

IDS = ("RallySim/SimpleReturn-v0", "RallySim/SimpleRallyTurn-v0", "RallySim/SimpleRallyTurn-v1",
       "RallySim/HumanLikeReturn-v0", "RallySim/HumanLikeRallyTurn-v0")


def stack_to_compiled_step(env_id: str) -> list[str]:
    """The rallysim frames on the stack when ``env.step`` first calls a compiled step (the
    Numba function that runs the physics steps), innermost first."""
    from rallysim.core.kernels import humanlike, simple

    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gym.make(env_id).unwrapped
    env.reset(seed=0)
    found: list[str] = []

    def spy(function: Callable) -> Callable:
        def called(*args: Any) -> Any:
            frame = sys._getframe(1)
            while frame is not None and not found:  # (the first call only)
                stack = []
                while frame is not None:
                    name = frame.f_code.co_filename
                    if "/rallysim/" in name:
                        stack.append(f"{name.split('/rallysim/')[-1]}:{frame.f_code.co_name}")
                    frame = frame.f_back
                found.extend(stack or [""])
            return function(*args)

        return called

    # the compiled entry points the envs call, each wrapped in a Python spy for one step
    patches = []
    for kernel in (simple.SimpleKernel.compiled, humanlike.HumanLikeKernel.compiled):
        compiled = kernel.get()
        patches.append((kernel, "function", compiled._replace(steps=spy(compiled.steps))))
    saved = [(owner, name, getattr(owner, name)) for owner, name, _ in patches]
    action = env.action_space.sample() * 0.0
    try:
        for owner, name, value in patches:
            setattr(owner, name, value)
        env.step(np.asarray(action, env.action_space.dtype))
    finally:
        for owner, name, value in saved:
            setattr(owner, name, value)
    return [f for f in found if f]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stack", action="store_true", help="print each stack")
    args = parser.parse_args()
    print("| env id | frames from step to the compiled step |\n|---|---:|")
    stacks = {env_id: stack_to_compiled_step(env_id) for env_id in IDS}
    for env_id, stack in stacks.items():
        print(f"| {env_id} | {len(stack)} |")
    if args.stack:
        for env_id, stack in stacks.items():
            print(f"\n{env_id}:\n  " + "\n  ".join(stack))


if __name__ == "__main__":
    main()
