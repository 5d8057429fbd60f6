"""Where a trained hierarchy's rallies are lost, and whether the lost shots could be met.

For each training seed of a ``rallysim reproduce`` run (``--runs``: its ``runs`` folder), HRL
plays the evaluation's rallies (the same evaluation seed, ``reproduce.evaluation_seed``, capped
at 50 hits) and the study reports:

- the share of rallies lost at 0-1 hits, at 2 hits, at 3-49 hits, and reaching the cap;
- at the start of the turn that lost the rally, whether ``ShotPlanner`` (the scripted
  controller's reach model) finds a full-speed meeting with the incoming shuttle from where
  the player stood, and from the best of ``rallysim.core.reach.BASES`` (eight base positions
  across the court); the same for the rallies that went on past that turn;
- whether the player who made the lost shot had another: at the start of its turn, a
  full-speed meeting (``ShotPlanner``) whose shot, at that meeting's elevation, the next player
  could meet from one of ``reach.BASES`` (the planner's model: full-speed swings only);
- where the waiting player stands when its turn begins (the turn player's base x at the start
  of turns 1-11, median, own frame).

``--seeds -1`` plays the scripted controller at a fixed goal (``--goal``) instead: the
reference for what the game allows.

    python -m experiments.first_exchange --runs results/runs --seeds 0,1,2 --json first.json

docs/research-log/reproduce.md ("Where the 10-seed study's HRL rallies are lost") quotes a
run of it on the 10-seed study.
"""

from __future__ import annotations

import argparse
import json
from pathlib import Path
from typing import Any

import numpy as np

from rallysim.core.reach import PlayerState, ShotPlanner
from rallysim.core.tasks.turns import TurnTask
from rallysim.train.reproduce import evaluation_seed

CAP = 50
WAIT_TURNS = 11  # turns 1..11: where the waiting player stands when its turn begins


def play(low: Any, high: Any, rallies: int, seed: int, goal: float = 3.5) -> dict[str, Any]:
    """Play ``rallies`` rallies; return their lengths, each early turn's planner state and the
    turn players' base x at their turns' starts. ``high`` None: every goal is ``goal``."""
    task = TurnTask(rallies, low, seed=seed)
    task.reset(np.arange(rallies))
    lengths = np.full(rallies, -1)
    states: dict[int, PlayerState] = {}
    waiting: list[np.ndarray] = []
    for turn in range(CAP + 2):
        playing = np.flatnonzero(lengths < 0)
        if not len(playing):
            break
        obs = task.observe()
        if turn < 3:
            states[turn] = PlayerState.from_observations(obs[:, :16])
        if 1 <= turn <= WAIT_TURNS:
            base = task.rally.game.bodies.base_x
            waiting.append(base[playing, task.turn_player[playing]].copy())
        goals = np.full(rallies, goal)
        if high is not None:
            goals[playing] = np.asarray(high(obs[playing])).reshape(-1)
        out = task.step(goals, playing)
        done = playing[(out["terminated"] | out["truncated"])[playing]]
        lengths[done] = out["rally_length"][done]
    return {"lengths": lengths, "states": states, "waiting": np.concatenate(waiting)}


def another_shot(planner: ShotPlanner, state: PlayerState) -> np.ndarray:
    """Whether each hitter of ``state`` (at the start of its turn) has a full-speed meeting
    whose shot lands beyond the net and can be met by the next player from some base."""
    m = planner.meetings(state)
    n = len(state.base_x)
    found = np.zeros(n, bool)
    for e, elevation in enumerate(planner.elev):
        # the shot in the next player's own frame: x turned, leaving toward it
        pos = np.stack([-m.x_hit[:, e], np.zeros(n), np.full(n, planner.hit_z[e])], axis=1)
        speed = planner.speed * np.array([-np.cos(elevation), 0.0, np.sin(elevation)])
        vel = np.broadcast_to(speed, (n, 3))
        usable = m.feasible[:, e] & (m.depth[:, e] > 0.0)
        found |= usable & planner.meetable(pos, vel)
    return found


def profile(played: dict[str, Any]) -> dict[str, Any]:
    """The loss shares, the meetable shares of the lost turn and the waiting position."""
    lengths, planner = played["lengths"], ShotPlanner()
    share = {"lost_0_1": lengths <= 1, "lost_2": lengths == 2,
             "lost_3_49": (lengths >= 3) & (lengths < CAP), "capped": lengths == CAP}
    out: dict[str, Any] = {k: float(v.mean()) for k, v in share.items()}
    out["mean"] = float(lengths.mean())
    # the turn that lost most rallies: turn k ends at k hits
    lost_at = 1 if (lengths == 1).sum() >= (lengths == 2).sum() else 2
    state = played["states"][lost_at]
    lost, kept = lengths == lost_at, lengths > lost_at
    here = planner.meetings(state).feasible.any(axis=1)  # from where the player stood
    best = planner.meetable(state.pos, state.vel)
    other = another_shot(planner, played["states"][lost_at - 1])
    out["lost_turn"] = {
        "hits": lost_at, "rallies_lost": int(lost.sum()),
        "meetable_from_own_base": {"lost": _mean(here[lost]), "went_on": _mean(here[kept])},
        "meetable_from_best_base": {"lost": _mean(best[lost]), "went_on": _mean(best[kept])},
        "hitter_had_a_meetable_shot": {"lost": _mean(other[lost]),
                                       "went_on": _mean(other[kept])}}
    out["waiting_base_x_median"] = float(np.median(played["waiting"]))
    return out


def _mean(x: np.ndarray) -> float | None:
    return float(x.mean()) if len(x) else None


def seed_profile(runs: Path | None, seed: int, rallies: int, goal: float) -> dict[str, Any]:
    """One seed's profile (``seed`` -1: the scripted controller at ``goal``)."""
    if seed < 0:
        return profile(play("scripted", None, rallies, 1_000_000, goal))
    from rallysim.policies.registry import resolve

    if runs is None:
        raise ValueError("--runs is needed for trained seeds")
    low = resolve(str(runs / f"low_seed{seed}" / "policy"), "rally_low")
    high = resolve(str(runs / f"high_seed{seed}" / "policy"), "high")
    return profile(play(low, high, rallies, evaluation_seed(seed)))


def table(profiles: dict[int, dict[str, Any]]) -> list[str]:
    lines = ["| seed | HRL mean | lost at 0-1 hits | at 2 hits | at 3-49 hits | reaching 50 "
             "| lost turn: meetable from own base / best base | hitter had a meetable shot "
             "| waiting player, median base x |",
             "|---|---|---|---|---|---|---|---|---|"]
    for seed, p in profiles.items():
        t = p["lost_turn"]
        own, best = t["meetable_from_own_base"]["lost"], t["meetable_from_best_base"]["lost"]
        meet = "—" if own is None else f"{100 * own:.0f} % / {100 * best:.0f} %"
        other = t["hitter_had_a_meetable_shot"]["lost"]
        other_cell = "—" if other is None else f"{100 * other:.0f} %"
        lines.append(f"| {'scripted' if seed < 0 else seed} | {p['mean']:.2f} "
                     + "".join(f"| {100 * p[k]:.1f} % " for k in
                               ("lost_0_1", "lost_2", "lost_3_49", "capped"))
                     + f"| {meet} (hit {t['hits']}) | {other_cell} "
                     + f"| {p['waiting_base_x_median']:.2f} m |")
    return lines


def main(argv: list[str] | None = None) -> None:
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=Path, help="a reproduce run's runs/ folder")
    parser.add_argument("--seeds", default="0", help="comma-separated; -1: scripted")
    parser.add_argument("--rallies", type=int, default=200)
    parser.add_argument("--goal", type=float, default=3.5, help="the scripted rallies' goal")
    parser.add_argument("--json", type=Path, help="write the profiles here")
    args = parser.parse_args(argv)
    seeds = [int(s) for s in args.seeds.split(",")]
    profiles = {s: seed_profile(args.runs, s, args.rallies, args.goal) for s in seeds}
    print("\n".join(table(profiles)))
    if args.json is not None:
        args.json.write_text(json.dumps({str(k): v for k, v in profiles.items()}, indent=1))


if __name__ == "__main__":
    main()
