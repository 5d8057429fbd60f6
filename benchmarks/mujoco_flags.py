"""How much of MuJoCo's own step could be switched off without changing an episode's bits.

MuJoCo bounds issue 37's two missed 3x rows (docs/benchmarks.md), so this measures what its
disable flags (``mjtDisableBit``) could take off ``mj_step`` of the batched models the envs
step (``bodies.build_world``: contacts and constraints are already off). Per player kind:

bits
    Each flag not yet set (but the automatic reset of a diverged simulation, a behaviour a
    stable run never shows) is added in turn to the flags kept so far, and kept only while a
    ``Game`` of N = 8 games of 2 players, served, then stepped through 60 decisions (300
    physics steps) of seeded random actions by the bodies' own drive or servo, gives the same
    bits as with the model as built: the shuttles, the hits, and every MuJoCo array the rules,
    the servo and the observations read (positions, velocities, accelerations, bodies' and
    sites' poses, centres of mass, inertia, bias forces), with no MuJoCo warning. A flag that
    changes them is listed with each array it changes and that array's largest difference.
speed
    ``mj_step`` of the N = 256, 2-player model as built, with the kept flags, and with the
    kept flags and each flag that changes the bits (what it would save if the bits were
    free), timed in turn for ``--rounds`` rounds of 200 steps, each from rest (the bodies
    undriven); the best round of each, and MuJoCo's warnings over the rounds.

The set found depends on the order the flags are tried in: springs are kept before dampers
are tried, and with both off MuJoCo skips its passive forces altogether, the SIMPLE arm's
gravity compensation among them.

Run: ``python benchmarks/mujoco_flags.py [--rounds 7] [--json PATH]``
"""

from __future__ import annotations

import argparse
import datetime
import json
import platform
import time
from pathlib import Path

import mujoco
import numpy as np
from side_by_side import _cpu  # (this folder is on the path of a script run from it)

from rallysim.core.bodies import SimpleBodies, build_world
from rallysim.core.game import PHYSICS_DT, Game
from rallysim.core.humanlike import N_ACTIONS, HumanLikeBodies

KINDS = {"SIMPLE": "simple_player.xml", "HUMAN-LIKE": "humanlike_player.xml"}
BODIES = {"SIMPLE": SimpleBodies, "HUMAN-LIKE": HumanLikeBodies}
ACTION_SIZE = {"SIMPLE": 3, "HUMAN-LIKE": N_ACTIONS}
READ = ("qpos", "qvel", "qacc", "xpos", "xquat", "xmat", "site_xpos", "site_xmat", "cvel",
        "subtree_com", "M", "qfrc_bias", "actuator_force")
DECISIONS, SMALL_N, LARGE_N, PLAYERS = 60, 8, 256, 2


def model(xml: str, n_envs: int, flags: int) -> mujoco.MjModel:
    m = build_world(xml, n_envs, PLAYERS, PHYSICS_DT)
    m.opt.disableflags |= flags
    return m


def trajectory(kind: str, flags: int) -> dict[str, np.ndarray]:
    """Every array of ``READ``, the shuttles' motion and the hits, after each decision of
    ``DECISIONS`` decisions of a ``Game`` of that kind with seeded random actions, served at
    the start (the bodies' own drive or servo, joint stops and hips, as the envs run them)."""
    bodies = BODIES[kind](SMALL_N, PLAYERS, PHYSICS_DT)
    bodies.model.opt.disableflags |= flags
    game = Game(SMALL_N, PLAYERS, seed=0, bodies=bodies)
    game.reset(game.every_env)
    d = bodies.data
    rng = np.random.default_rng(0)
    size = ACTION_SIZE[kind]
    rows: dict[str, list] = {name: [] for name in (*READ, "shuttle", "hit")}
    for _ in range(DECISIONS):
        events = game.step(rng.uniform(-1.0, 1.0, (SMALL_N, PLAYERS, size)))
        for name in READ:
            rows[name].append(np.ravel(getattr(d, name)).copy())
        rows["shuttle"].append(game.shuttle.motion.ravel().copy())
        rows["hit"].append(events.hit.ravel().astype(np.float64))
    if any(w.number for w in d.warning):  # (a diverged run would compare MuJoCo's resets)
        raise RuntimeError(f"the {kind} test run with flags {flags_of(flags)} warned")
    return {name: np.array(values) for name, values in rows.items()}


# (MuJoCo's reset of a diverged simulation is a behaviour no bit test of a stable run sees)
SKIP = ("mjDSBL_AUTORESET",)
FLAGS = {name: int(bit) for name, bit in mujoco.mjtDisableBit.__members__.items()
         if name.startswith("mjDSBL_") and name not in SKIP}


def flags_of(mask: int) -> list[str]:
    return [name for name, bit in FLAGS.items() if bit & mask]


def bits(kind: str, xml: str) -> dict:
    """The flags that keep the bits (added one at a time, kept while they do) and those that
    change them."""
    built = build_world(xml, 1, PLAYERS, PHYSICS_DT).opt.disableflags
    reference = trajectory(kind, 0)
    kept, changed = 0, {}
    for name, b in FLAGS.items():
        if b & built:
            continue
        run = trajectory(kind, kept | b)
        gaps = {}
        for array, values in run.items():
            if not np.array_equal(values, reference[array]):
                with np.errstate(invalid="ignore"):
                    gap = np.nanmax(np.abs(values - reference[array]))
                gaps[array] = float(gap) if np.isfinite(gap) else "NaN or inf"
        if gaps:
            changed[name] = gaps
        else:
            kept |= b
    return {"already_set": flags_of(built), "kept": flags_of(kept), "kept_mask": kept,
            "change_bits": changed}


def speed(xml: str, masks: dict[str, int], rounds: int) -> tuple[dict[str, float], int]:
    """µs per ``mj_step`` of the N = ``LARGE_N`` model with each set of flags, best round, and
    the warnings MuJoCo gave over the rounds."""
    runs = {}
    for name, mask in masks.items():
        m = model(xml, LARGE_N, mask)
        runs[name] = (m, mujoco.MjData(m), [])
    warnings = 0
    for _ in range(rounds):
        for m, d, times in runs.values():
            mujoco.mj_resetData(m, d)
            mujoco.mj_step(m, d)  # (warm)
            began = time.perf_counter()
            for _ in range(200):
                mujoco.mj_step(m, d)
            times.append((time.perf_counter() - began) / 200 * 1e6)
            warnings += sum(w.number for w in d.warning)
    return {name: min(times) for name, (_, _, times) in runs.items()}, warnings


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--rounds", type=int, default=7)
    parser.add_argument("--json", type=Path)
    args = parser.parse_args()
    out = {"date": datetime.date.today().isoformat(),
           "machine": {"cpu": _cpu(), "mujoco": mujoco.__version__,
                       "python": platform.python_version()},
           "n_envs": LARGE_N, "players": PLAYERS, "rounds": args.rounds,
           "steps_per_round": 200, "test_decisions": DECISIONS, "test_games": SMALL_N,
           "kinds": {}}
    for kind, xml in KINDS.items():
        found = bits(kind, xml)
        masks = {"as_built": 0, "kept": found["kept_mask"]}
        masks.update({f"kept+{name}": found["kept_mask"] | FLAGS[name]
                      for name in found["change_bits"]})
        times, found["timing_warnings"] = speed(xml, masks, args.rounds)
        found["us_per_step"] = times
        found["saving"] = {name: 1.0 - t / times["as_built"] for name, t in times.items()
                           if name != "as_built"}
        out["kinds"][kind] = found
        print(f"{kind}: keep the bits {', '.join(found['kept']) or '(none)'}")
        for name, gaps in found["change_bits"].items():
            print(f"  {name} changes " + ", ".join(
                f"{a} (up to {g:.3g})" if isinstance(g, float) else f"{a} ({g})"
                for a, g in gaps.items()))
        print(f"  mj_step at N = {LARGE_N} x {PLAYERS}: as built {times['as_built']:.1f} µs, "
              f"with the kept flags {times['kept']:.1f} µs ({found['saving']['kept']:.1%} less)")
        for name in found["change_bits"]:
            print(f"  and {name} too (other bits): {times['kept+' + name]:.1f} µs "
                  f"({found['saving']['kept+' + name]:.1%} less)")
    if args.json:
        args.json.write_text(json.dumps(out, indent=1) + "\n")


if __name__ == "__main__":
    main()
