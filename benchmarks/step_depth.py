"""Python frames between an env's ``step`` and MuJoCo's ``mj_step``, per env id.

Each frame is a call a decision pays for (and a place to read when following the code); the
redesign (issue 16) reports this before and after. Run: ``python benchmarks/step_depth.py``
(add ``--stack`` to print each stack).
"""

from __future__ import annotations

import argparse
import sys
import warnings

import gymnasium as gym
import numpy as np

import rallysim  # noqa: F401  (registers the ids)

IDS = ("RallySim/SimpleReturn-v0", "RallySim/SimpleRallyTurn-v0", "RallySim/SimpleRallyTurn-v1",
       "RallySim/HumanLikeReturn-v0", "RallySim/HumanLikeRallyTurn-v0")
STEPS = ("mj_step", "mj_step2")  # HUMAN-LIKE bodies split MuJoCo's step, mj_step2 first


def stack_to_mj_step(env_id: str) -> list[str]:
    """The rallysim frames on the stack when MuJoCo first steps during ``env.step``."""
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        env = gym.make(env_id).unwrapped
    env.reset(seed=0)
    found: list[str] = []

    def profile(frame, event, arg):
        if event == "c_call" and getattr(arg, "__name__", "") in STEPS and not found:
            while frame is not None:
                name = frame.f_code.co_filename
                if "/rallysim/" in name:
                    found.append(f"{name.split('/rallysim/')[-1]}:{frame.f_code.co_name}")
                frame = frame.f_back

    action = env.action_space.sample() * 0.0
    sys.setprofile(profile)
    try:
        env.step(np.asarray(action, env.action_space.dtype))
    finally:
        sys.setprofile(None)
    return found


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--stack", action="store_true", help="print each stack")
    args = parser.parse_args()
    print("| env id | frames from step to mj_step |\n|---|---:|")
    stacks = {env_id: stack_to_mj_step(env_id) for env_id in IDS}
    for env_id, stack in stacks.items():
        print(f"| {env_id} | {len(stack)} |")
    if args.stack:
        for env_id, stack in stacks.items():
            print(f"\n{env_id}:\n  " + "\n  ".join(stack))


if __name__ == "__main__":
    main()
