"""``rallysim reproduce``: the paper's pipeline end to end, and its Table VII with statistics.

For each training seed: the low level (PPO on ``RallySim/SimpleReturn-v0``), then the high level
(PPO on the turn-based rally with that low level frozen), then the Monolithic baseline (PPO on
the rally at the physics rate, given the same budget as the two stages together, counted in
player-decisions: the low stage's steps plus two per rally decision simulated in the high
stage). Then every method plays ``rallies`` evaluation rallies per seed: HRL (trained high +
low), Random High-level (trained low, goals ~ U[2, 6] m), Monolithic. The report gives mean,
median and IQM rally lengths with 95 % hierarchical bootstrap intervals, the capped counts and
survival curves, beside the paper's numbers.

Rallies end at ``cap`` hits (default 50, the paper's; up to 100,000): only a landing or the
cap ends a rally. Beside the mean, the report says where rallies are lost: the serve-return rate,
the first return's miss rate, the early-loss rate (lost before the second hit) and the per-hit
miss rate after that, pooled and per seed, with the worst seed named.

The stages and evaluations run in a pool of processes, one per CPU core by default: each
process takes one step of one seed at a time, so seeds overlap and no core idles while another
seed's chain of steps is still long.

Everything lands in ``out`` (``runs/`` per stage and seed, ``results.json``, ``report.md``,
``learning_curves.png``, ``survival.png``; at another cap ``results_cap{N}.json`` and so on);
an interrupted reproduction resumes where it stopped, and a finished one only re-evaluates.
Training is deterministic: the same seed and budget on the same machine give bit-identical
weights.
"""

from __future__ import annotations

import json
import multiprocessing as mp
import sys
import time
from concurrent.futures import FIRST_COMPLETED, ProcessPoolExecutor, wait
from dataclasses import asdict, dataclass, fields, replace
from pathlib import Path
from typing import Any

import numpy as np

from rallysim.eval.rally_eval import PAPER_CAP
from rallysim.train.players import PLAYERS
from rallysim.train.progress import Heartbeat, say_stderr
from rallysim.train.study_tables import number_cell

PAPER_TABLE_VII = {
    "HRL": {"mean": 20.25, "capped": 13},
    "Random High-level": {"mean": 12.90, "capped": 3},
    "Monolithic": {"mean": 1.32, "capped": 0},
}
PAPER_LOW_REWARD = 1.8  # Fig. 6, after 2M steps
METHODS = tuple(PAPER_TABLE_VII)


@dataclass(frozen=True)
class Budget:
    """How much of everything a reproduction does."""

    name: str
    low_decisions: int
    high_turns: int
    seeds: int  # training seeds (0 .. seeds - 1); ``--seeds`` sets another count
    rallies: int  # evaluation rallies per seed and method
    low_eval_episodes: int = 1000
    warm_start: str = "scripted"  # the low level's start: "scripted" (cloned) or "none"
    goals: str = "uniform"  # the low level's task: SimpleReturn-v0 ("uniform") or -v1
    player: str = "simple"  # the players: "simple" or "humanlike" (the 3-D rally)
    low_extra: tuple[tuple[str, Any], ...] = ()  # further settings of the low stage

    def overrides(self, stage: str) -> dict[str, Any]:
        """The stage's settings from this budget (the mono stage's follow from the others':
        ``LINKS``)."""
        low: dict[str, Any] = {"budget": self.low_decisions,
                               "warm_start.teacher": self.warm_start}
        if self.player == "simple":
            low.update({"eval.every": max(self.low_decisions // 8, 1), "goals": self.goals})
        low.update(dict(self.low_extra))
        per_stage = {
            "low": low,
            "high": {"budget": self.high_turns, "eval.every": max(self.high_turns // 3, 1),
                     "checkpoint_every": max(self.high_turns // 6, 1)},
        }
        return {"player": self.player, **per_stage.get(stage, {})}

    def settings(self) -> dict[str, Any]:
        """The budget as JSON gives it back (a SIMPLE budget without the fields that came
        with HUMAN-LIKE runs, as earlier runs wrote it)."""
        out = json.loads(json.dumps(asdict(self)))
        if self.player == "simple" and not self.low_extra:
            del out["player"], out["low_extra"]
        return out


# The low level's task with the terms that widen its band of goals it can rally from: half its
# episodes start from recorded rally shots, not serves (not the paper's task: docs/deviations.md).
RALLY_SHOTS: tuple[tuple[str, Any], ...] = (("returnable", 0.5), ("ready", 0.5),
                                            ("incoming", "mixed"))
BUDGETS = {
    # the low stage's task adds both terms and rally shots (docs/research-log/reproduce.md)
    "default": Budget("default", 2_000_000, 45_000, 3, 200, low_extra=RALLY_SHOTS),
    "quick": Budget("quick", 600_000, 3_000, 3, 100, 500, low_extra=RALLY_SHOTS),
    "smoke": Budget("smoke", 8_192, 256, 2, 8, 64, warm_start="none", low_extra=RALLY_SHOTS),
    # the paper's method throughout: the low level trained from scratch
    "scratch": Budget("scratch", 2_000_000, 45_000, 3, 200, warm_start="none"),
    # no teacher anywhere: PPO from scratch on SimpleReturn-v1's reachable goals
    "rl": Budget("rl", 2_000_000, 45_000, 3, 200, warm_start="none", goals="reachable"),
}
# The HUMAN-LIKE reproduction (issue 39): the low level is the clone of AimedSwing with DAgger
# rounds (configs/low_humanlike.yaml: no PPO after it), the high level trains over it; "quick"
# clones a quarter of the decisions for two thirds of the epochs, then plays all its DAgger
# rounds in the rally, which the rally needs most (docs/humanlike.md).
HUMANLIKE_BUDGETS = {
    "default": Budget("default", 0, 32_768, 3, 200, 500, player="humanlike"),
    "quick": Budget("quick", 0, 8_192, 3, 100, 200, player="humanlike",
                    low_extra=(("warm_start.decisions", 131_072), ("warm_start.dagger", 0),
                               ("warm_start.rally_dagger", 4), ("warm_start.epochs", 20))),
    "smoke": Budget("smoke", 0, 256, 2, 8, 16, player="humanlike",
                    low_extra=(("warm_start.decisions", 8_192), ("warm_start.dagger", 0),
                               ("warm_start.rally_dagger", 1),
                               ("warm_start.epochs", 2), ("warm_start.batch_size", 256))),
}
# the target of every seed's HRL mean at the paper's cap (issues 36 and 39)
SEED_TARGETS = {"simple": 40, "humanlike": 45}
# the low level's numbers a report averages over seeds, per player
LOW_SUMMARY = {"simple": ("mean_reward", "hit_rate", "median_error"),
               "humanlike": ("mean_reward", "hit_rate", "mean_angle_error",
                             "mean_abs_speed_error")}


def budget_named(name: str, player: str = "simple") -> Budget:
    """The budget called ``name`` for ``player``'s reproduction; a clear error otherwise."""
    table = BUDGETS if player == "simple" else HUMANLIKE_BUDGETS if player == "humanlike" \
        else None
    if table is None:
        raise ValueError(f"unknown player {player!r}; valid: 'simple', 'humanlike'")
    if name not in table:
        raise ValueError(f"the {player} reproduction has no budget {name!r}; valid: "
                         + ", ".join(repr(k) for k in table))
    return table[name]
METHOD_STAGES = ("low", "high", "mono")  # Table VII's stages (not compete)


def _say(queue: Any, text: str) -> None:
    if queue is None:
        say_stderr(text)
    else:
        queue.put(text)


def result_names(cap: int) -> dict[str, str]:
    """The files a reproduction writes for its evaluation at ``cap`` hits."""
    tag = "" if cap == PAPER_CAP else f"_cap{cap}"
    return {"json": f"results{tag}.json", "report": f"report{tag}.md",
            "survival": f"survival{tag}.png", "curves": "learning_curves.png"}


# the smoke budget's small rollouts and evaluations, so that it runs in seconds
SMOKE_SIZES: dict[str, Any] = {"ppo.n_envs": 32, "ppo.n_steps": 16, "ppo.batch_size": 256,
                               "eval.episodes": 16, "checkpoint_every": 1024}
SMOKE_STAGE_SIZES: dict[str, dict[str, Any]] = {"high": {"ppo.n_steps": 8,
                                                         "ppo.batch_size": 64}}


def _frozen_low_level(seed: int, out: Path, curves: dict[str, Any]) -> dict[str, Any]:
    """The high stage plays over the low level this seed trained."""
    return {"low_policy": str(out / "runs" / f"low_seed{seed}" / "policy")}


def _hierarchy_budget(seed: int, out: Path, curves: dict[str, Any]) -> dict[str, Any]:
    """The Monolithic baseline gets the hierarchy's budget in player-decisions: the low
    stage's PPO steps, the teacher's decisions it cloned, and two player-decisions per rally
    decision run inside the high stage's turns."""
    low_steps = curves["low"]["steps"] + int(
        curves["low"].get("warm_start", {}).get("samples", 0))
    budget = low_steps + 2 * curves["high"]["decisions_simulated"]
    return {"budget": budget, "eval.every": max(budget // 4, 1)}


# what a stage takes from the stages trained before it
LINKS = {"high": _frozen_low_level, "mono": _hierarchy_budget}


def train_seed_stage(seed: int, stage: str, budget: Budget, out: Path,
                     curves: dict[str, Any], queue: Any = None) -> dict[str, Any]:
    """Train one stage of one seed, given the curves of that seed's earlier stages (``LINKS``),
    and return its curve; a stage already trained is read back, not trained again."""
    from rallysim.train.config import load_config
    from rallysim.train.run_log import finished
    from rallysim.train.runner import train_stage
    from rallysim.train.stages import headline

    run = out / "runs" / f"{stage}_seed{seed}"
    overrides = {"seed": seed, **budget.overrides(stage)}
    if budget.name == "smoke":
        overrides.update({**SMOKE_SIZES, **SMOKE_STAGE_SIZES.get(stage, {})})
    if stage in LINKS:
        overrides.update(LINKS[stage](seed, out, curves))
    config = load_config(stage, None, overrides)
    check_same_settings(run, config)
    done = finished(run, config.budget)
    if done is not None:
        _say(queue, f"[seed {seed}] {stage}: already trained, skipped")
        return done
    t = time.perf_counter()
    what = f"training {config.budget:,} {config.budget_unit}"
    if config.budget == 0 and config.warm_start.enabled:  # the clone is the policy
        what = (f"cloning the scripted player ({config.warm_start.decisions:,} decisions, "
                f"{config.warm_start.dagger} DAgger rounds"
                + (f", {config.warm_start.rally_dagger} in the rally"
                   if config.warm_start.rally_dagger else "") + "; no PPO after it)")
    _say(queue, f"[seed {seed}] {stage}: {what} ...")
    curve = train_stage(config, run, progress=False, say=lambda text: _say(queue, text))
    _say(queue, f"[seed {seed}] {stage}: done in {time.perf_counter() - t:.0f} s, "
                + headline(config, curve["final"]))
    return curve


def check_same_settings(run: Path, config: Any) -> None:
    """A run in ``--out`` (finished or to be resumed) is taken only if its recorded settings
    (``config.yaml``) are ``config``'s, a setting it predates counting as its default;
    ``ValueError`` naming those that differ. The low level a high stage plays over is named by
    a path, which may be written another way: it is not compared."""
    import yaml

    from rallysim.train.config import BUDGET_UNIT, LEGACY_KEYS, SECTIONS, TrainConfig

    path = run / "config.yaml"
    if not path.is_file():
        return
    doc = yaml.safe_load(path.read_text())
    # (a backend writes its own keys beside the settings)
    known = {f.name for f in fields(TrainConfig)} | set(LEGACY_KEYS) | set(SECTIONS) | {
        BUDGET_UNIT}
    try:
        recorded = TrainConfig.from_dict({k: v for k, v in doc.items() if k in known},
                                         warn=False)
    except (ValueError, TypeError, AttributeError) as exc:
        raise ValueError(f"{path} cannot be read as settings ({exc}): reproduce into another "
                         f"--out, or remove that run") from None

    def flat(c: Any) -> dict[str, Any]:
        return {f"{key}.{k}" if isinstance(value, dict) else key: v
                for key, value in c.to_dict().items() if key != "low_policy"
                for k, v in (value.items() if isinstance(value, dict) else [(None, value)])}

    old, new = flat(recorded), flat(config)
    differ = [f"{key}: {old.get(key)!r} there, {value!r} here"
              for key, value in new.items() if old.get(key) != value]
    if differ:
        raise ValueError(f"{run} was trained with other settings ({'; '.join(differ)}): "
                         f"reproduce into another --out, or remove that run and the seed's "
                         f"later stages to train them again")


def evaluation_seed(seed: int) -> int:
    """The evaluation seed of training seed ``seed``: unseen by training, whose envs use
    ``seed + i``."""
    return 1_000_000 + 1000 * seed


def evaluate_seed(seed: int, out: Path, rallies: int, low_episodes: int,
                  cap: int = PAPER_CAP, beat: Heartbeat | None = None,
                  player: str = "simple") -> dict[str, Any]:
    """Rally lengths of every method (rallies end at ``cap`` hits), and the low level's
    numbers, for one trained seed of ``player``."""
    from rallysim.eval.compare import play_methods
    from rallysim.eval.rally_eval import rules_for_cap
    from rallysim.policies.mlp import load_policy
    from rallysim.policies.registry import resolve

    runs = out / "runs"
    low_prefix = str(runs / f"low_seed{seed}" / "policy")
    low = resolve(low_prefix, "rally_low", player)
    high = resolve(str(runs / f"high_seed{seed}" / "policy"), "high", player)
    mono = load_policy(runs / f"mono_seed{seed}" / "policy")
    eval_seed = evaluation_seed(seed)
    lengths = play_methods(high, low, mono, rallies, eval_seed, rules_for_cap(cap), beat,
                           f"seed {seed} ", player=player)
    return {"lengths": {k: v.tolist() for k, v in lengths.items()},
            "low_level": low_level_numbers(load_policy(low_prefix), low_episodes, eval_seed,
                                           player)}


def low_level_numbers(policy: Any, episodes: int, seed: int, player: str) -> dict[str, Any]:
    """The low level on ``episodes`` fresh serves from ``seed`` (deterministic policy), judged
    as the low stage judges it (SIMPLE: the task's statistics and goal following; HUMAN-LIKE:
    the hit rate and the racket velocity's errors)."""
    from rallysim.train.config import load_config
    from rallysim.train.stages import LOW

    config = load_config("low", None, {"player": player, "eval.seed": seed})
    return LOW.evaluate(config, policy, episodes)


def run_reproduce(budget: Budget, out: Path, workers: int | None = None,
                  seeds: int | None = None, cap: int = PAPER_CAP) -> dict[str, Any]:
    """Train every seed and evaluate it with rallies capped at ``cap`` hits (``workers``
    processes at a time, by default one per CPU core; ``seeds`` overrides the budget's count),
    then write the report."""
    from rallysim.eval.rally_eval import rules_for_cap

    rules_for_cap(cap)  # refuse a bad cap before any training
    if seeds is not None:
        if seeds < 1:
            raise ValueError(f"seeds must be >= 1, got {seeds}")
        budget = replace(budget, seeds=int(seeds))
    workers = default_workers() if workers is None else workers
    if workers < 1:
        raise ValueError(f"workers must be >= 1, got {workers}")
    out.mkdir(parents=True, exist_ok=True)
    names = result_names(cap)
    start = time.perf_counter()
    low = (f"low {budget.low_decisions:,} decisions" if budget.player == "simple" else
           "low: the clone of AimedSwing with DAgger rounds")
    say_stderr(f"reproduce ({PLAYERS[budget.player].label}, {budget.name}): {budget.seeds} "
               f"seeds x ({low}, high {budget.high_turns:,} turns, mono the same budget, then "
               f"the evaluation); rallies capped at {cap} hits; "
               f"{min(workers, budget.seeds)} worker(s); results in {out}")
    curves, per_seed, train_wall = _run_all(budget, out, workers, cap)
    results = summarise(budget, curves, per_seed, train_wall, time.perf_counter() - start, cap)
    (out / names["json"]).write_text(json.dumps(results, indent=1))
    (out / names["report"]).write_text(markdown_report(results))
    plot_learning_curves(curves, out / names["curves"], budget.player)
    plot_survival(results, out / names["survival"])
    say_stderr(f"done in {time.perf_counter() - start:.0f} s: {out / names['report']}")
    return results


def default_workers() -> int:
    """One worker per CPU core this process may use."""
    import os

    return len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else (
        os.cpu_count() or 1)


# what one seed does, each step after the one before: its three stages, then its evaluation
SEED_STEPS = (*METHOD_STAGES, "evaluate")


def evaluation_path(out: Path, seed: int, cap: int) -> Path:
    """Where one seed's evaluation at ``cap`` hits is kept, as soon as it is played."""
    return out / "evaluations" / f"seed{seed}_cap{cap}.json"


def _evaluation_settings(out: Path, seed: int, budget: Budget, cap: int) -> dict[str, Any]:
    """What an evaluation on disk must have been played with to be taken again: the cap, the
    budget (its seed count aside), the numeric settings and the SHA-256 of each policy it
    played."""
    from rallysim.numerics import describe
    from rallysim.policies.mlp import sha256_file

    policies = {}
    for stage in METHOD_STAGES:
        path = out / "runs" / f"{stage}_seed{seed}" / "policy.safetensors"
        policies[stage] = sha256_file(path) if path.is_file() else None
    return {"cap": cap, "budget": {k: v for k, v in budget.settings().items() if k != "seeds"},
            "numerics": describe()["environment"], "policies": policies}


def stored_evaluation(out: Path, seed: int, budget: Budget, cap: int) -> dict[str, Any] | None:
    """The seed's evaluation from an earlier run, if one was played with the same settings
    and policies (``_evaluation_settings``); None otherwise, or where the file is damaged."""
    from rallysim.jsondoc import read_object

    path = evaluation_path(out, seed, cap)
    if not path.exists():
        return None
    try:
        doc = read_object(path, "evaluation")
    except ValueError:
        return None  # (a crash mid-write cannot leave one: written atomically)
    result = doc.get("result")
    if doc.get("settings") != _evaluation_settings(out, seed, budget, cap) or not (
            isinstance(result, dict) and isinstance(result.get("lengths"), dict)):
        return None
    return result


def check_lengths(result: dict[str, Any], seed: int, cap: int) -> None:
    """Every method's rally lengths lie in [0, ``cap``]; ``ValueError`` names the seed and the
    method otherwise."""
    for method, lengths in result["lengths"].items():
        x = np.asarray(lengths)
        if x.size and (x.min() < 0 or x.max() > cap):
            raise ValueError(f"seed {seed}, {method}: rally lengths must lie in [0, {cap}], "
                             f"got {int(x.min())} to {int(x.max())}")


def run_seed_step(seed: int, step: str, budget: Budget, out: Path, curves: dict[str, Any],
                  cap: int, queue: Any = None) -> dict[str, Any]:
    """One step of one seed (``SEED_STEPS``): a stage's curve, or the seed's evaluation. An
    evaluation is written to ``evaluation_path`` as soon as it is played, before it is
    checked, and one already there with the same settings is taken instead of played."""
    from rallysim.train.checkpoint import atomic_write

    if step != "evaluate":
        return train_seed_stage(seed, step, budget, out, curves, queue)
    path = evaluation_path(out, seed, cap)
    result = stored_evaluation(out, seed, budget, cap)
    if result is not None:
        _say(queue, f"[seed {seed}] evaluation at cap {cap}: already played, read back")
    else:
        with Heartbeat(f"[evaluate seed {seed}]", len(METHODS), lambda t: _say(queue, t),
                       unit="rally sets") as beat:
            result = evaluate_seed(seed, out, budget.rallies, budget.low_eval_episodes, cap,
                                   beat, budget.player)
        path.parent.mkdir(parents=True, exist_ok=True)
        doc = {"seed": seed, "settings": _evaluation_settings(out, seed, budget, cap),
               "result": result}
        atomic_write(path, json.dumps(doc).encode())
    try:
        check_lengths(result, seed, cap)
    except ValueError as err:
        raise ValueError(f"{err} (kept in {path}; delete it to play the evaluation again)"
                         ) from None
    hrl = np.mean(result["lengths"]["HRL"])
    _say(queue, f"[seed {seed}] evaluated: HRL mean rally {hrl:.2f} (cap {cap})")
    return result


def next_seed(ready: set[int], steps_done: dict[int, int]) -> int:
    """Of the seeds whose next step may start, the one with most steps left (the lowest seed
    among equals)."""
    return min(ready, key=lambda s: (steps_done[s], s))


def _run_all(budget: Budget, out: Path, workers: int, cap: int
             ) -> tuple[dict[int, dict[str, Any]], dict[int, Any], float]:
    """Every seed's steps: the curves per seed and stage, the evaluations per seed, and the
    wall time until the last stage was trained.

    With one worker the steps run in this process: every seed's stages, then the
    evaluations. With more, a pool of fresh processes takes single steps: a seed's next step
    is submitted as soon as its last one is done, and a free worker takes the step of the seed
    with most steps left (every seed's chain of steps is the same length, so starting the
    longest chains first keeps both cores busy to the end; three seeds on two cores no longer
    leave the third seed's whole chain to run alone). Each step is deterministic on its own,
    so the results do not depend on which process ran it or when."""
    seeds = range(budget.seeds)
    curves: dict[int, dict[str, Any]] = {s: {} for s in seeds}
    evaluations: dict[int, Any] = {}
    steps_done = dict.fromkeys(seeds, 0)
    t0 = time.perf_counter()
    train_wall = 0.0

    def record(seed: int, result: dict[str, Any]) -> None:
        nonlocal train_wall
        step = SEED_STEPS[steps_done[seed]]
        if step == "evaluate":
            evaluations[seed] = result
        else:
            curves[seed][step] = result
            train_wall = time.perf_counter() - t0
        steps_done[seed] += 1

    if workers == 1:  # every seed's stages, then every seed's evaluation
        for steps in (METHOD_STAGES, ("evaluate",)):
            for s in seeds:
                for step in steps:
                    record(s, run_seed_step(s, step, budget, out, curves[s], cap))
        return curves, evaluations, train_wall
    ctx = mp.get_context("spawn")  # fresh interpreters: torch and fork do not mix
    manager = ctx.Manager()
    queue = manager.Queue()
    ready, running = set(seeds), {}
    with ProcessPoolExecutor(max_workers=workers, mp_context=ctx) as pool:
        while ready or running:
            while ready and len(running) < workers:
                s = next_seed(ready, steps_done)
                ready.remove(s)
                running[pool.submit(run_seed_step, s, SEED_STEPS[steps_done[s]], budget, out,
                                    curves[s], cap, queue)] = s
            finished, _ = wait(running, timeout=0.5, return_when=FIRST_COMPLETED)
            while not queue.empty():
                print(f"{time.perf_counter() - t0:7.0f} s  {queue.get()}", file=sys.stderr,
                      flush=True)
            for f in finished:
                s = running.pop(f)
                record(s, f.result())
                if steps_done[s] < len(SEED_STEPS):
                    ready.add(s)
    manager.shutdown()
    return curves, evaluations, train_wall


LOSS_KEYS = ("serve_return", "first_return_miss", "early_loss", "later_miss_rate")


CLIMB_TOLERANCE = 0.1  # of the training cap: what a high level's last third may add
CAPPED_GOAL = 0.9  # of HRL's rallies reaching the cap, on every seed (issue 14's goal)
CAPPED_CHECK = f"no_seed_hrl_capped_share_ci_below_{CAPPED_GOAL}"
# Checks that earlier runs wrote and that are no longer applied: reports and docs omit them.
# The capped share's point estimate over a seed's 200 rallies decided seeds near the goal by
# chance (docs/results.md, "Where rallies are lost"); ``CAPPED_CHECK`` replaces it.
RETIRED_CHECKS = frozenset({"every_seed_hrl_capped_fraction_at_least_0.9"})


def capped_check(per_seed: dict[str, Any], cap: int) -> bool:
    """``CAPPED_CHECK``: no seed's share of HRL rallies that reach ``cap`` lies below
    ``CAPPED_GOAL`` with its whole 95 % interval (a seed near the goal passes: its sample
    cannot tell)."""
    from rallysim.eval.stats import capped_fraction, estimate

    return all(estimate([np.asarray(v["lengths"]["HRL"])], capped_fraction(cap)).high
               >= CAPPED_GOAL for v in per_seed.values())


def current_checks(r: dict[str, Any]) -> dict[str, bool]:
    """A reproduction's checks as today's code applies them: ``RETIRED_CHECKS`` left out, and
    ``CAPPED_CHECK`` computed from the rallies where a run made before it lacks it."""
    checks = {k: v for k, v in r.get("checks", {}).items() if k not in RETIRED_CHECKS}
    seeds = r.get("per_seed") or {}
    if CAPPED_CHECK not in checks and seeds and all(
            "HRL" in v.get("lengths", {}) for v in seeds.values()):
        checks[CAPPED_CHECK] = capped_check(seeds, r.get("cap", PAPER_CAP))
    return checks


def last_climb(curve: dict[str, Any]) -> float | None:
    """How much the high level's mean rally rose between its last two training evaluations
    (at two thirds of the budget and at its end, in ``reproduce``); None with fewer than two.
    Training evaluations are capped at the paper's 50 hits."""
    evals = curve.get("evals", [])
    if len(evals) < 2:
        return None
    return float(evals[-1]["mean_rally"] - evals[-2]["mean_rally"])


def summarise(budget: Budget, curves: dict[int, dict[str, Any]], per_seed: dict[int, Any],
              train_wall: float, total_wall: float, cap: int = PAPER_CAP) -> dict[str, Any]:
    """Pooled and per-seed statistics of every method, the pairwise interval comparisons and
    the targets' checks, as one JSON-ready dict (what ``markdown_report`` renders)."""
    import torch  # noqa: F401  (loaded, so that describe() records its kernel level)

    from rallysim.eval.stats import summarise_rallies
    from rallysim.numerics import describe

    seeds = sorted(per_seed)
    for s in seeds:  # a bad value names its seed and method, not only the pooled table
        check_lengths(per_seed[s], s, cap)
    methods, by_seed = {}, {}
    for m in METHODS:
        groups = [np.asarray(per_seed[s]["lengths"][m]) for s in seeds]
        methods[m] = summarise_rallies(groups, cap=cap).to_dict()
        by_seed[m] = {}
        for s, g in zip(seeds, groups, strict=True):
            one = summarise_rallies([g], cap=cap)
            by_seed[m][str(s)] = {"mean": asdict(one.mean), "capped": one.capped,
                                  "n_rallies": one.n_rallies,
                                  **{k: asdict(getattr(one, k)) for k in LOSS_KEYS}}
        worst = min(by_seed[m], key=lambda k: by_seed[m][k]["mean"]["value"])
        methods[m]["worst_seed"] = {"seed": int(worst), **by_seed[m][worst]}

    def above(a: str, b: str, key: str = "mean") -> bool:  # a's whole interval above b's
        return methods[a][key]["low"] > methods[b][key]["high"]

    pairs = {f"{a} > {b}": above(a, b) for a in METHODS for b in METHODS if a != b}
    order_ok = above("HRL", "Random High-level") and above("Random High-level", "Monolithic")
    low = [per_seed[s]["low_level"] for s in seeds]
    hrl_seeds = [by_seed["HRL"][str(s)] for s in seeds]
    climbs = {str(s): last_climb(curves[s]["high"]) for s in seeds}
    target = SEED_TARGETS[budget.player]
    checks = {
        f"every_seed_hrl_mean_at_least_{target}": all(v["mean"]["value"] >= target
                                                      for v in hrl_seeds),
        # a high level whose last third of the budget still added more than a tenth of the cap
        # was stopped while climbing: its table row is its budget's, not its method's
        "no_high_level_still_climbing": all(c is None or c <= CLIMB_TOLERANCE * PAPER_CAP
                                            for c in climbs.values()),
        "hrl_above_monolithic": above("HRL", "Monolithic"),
        "hrl_above_random": above("HRL", "Random High-level"),
        # lower early loss: HRL's whole interval below Monolithic's
        "hrl_early_loss_below_monolithic": (methods["HRL"]["early_loss"]["high"]
                                            < methods["Monolithic"]["early_loss"]["low"]),
    }
    if budget.player == "humanlike" and cap >= 1000:  # issue 39: a median rally of 200 hits
        checks["hrl_median_at_least_200"] = methods["HRL"]["median"]["value"] >= 200
    # (last, where current_checks puts it for the runs made before it)
    checks[CAPPED_CHECK] = capped_check({str(s): per_seed[s] for s in seeds}, cap)
    paper = ({"table_vii": PAPER_TABLE_VII, "low_level_reward": PAPER_LOW_REWARD}
             if budget.player == "simple" else None)  # (the paper has no 3-D table)
    return {
        "budget": budget.settings(),
        "player": budget.player,
        "cap": cap,
        # the CPU and numeric settings of the process that summarised (the workers inherit its
        # environment): learning results differ in their bits between CPUs (docs/numerics.md)
        "numerics": describe(),
        "wall_s": {"training": round(train_wall, 1), "total": round(total_wall, 1)},
        "paper": paper,
        "methods": methods,
        "methods_per_seed": by_seed,
        "order_hrl_random_mono_with_disjoint_cis": bool(order_ok),
        "disjoint_above": pairs,
        "checks": checks,
        "low_level": {"per_seed": low, **{k: float(np.mean([r[k] for r in low]))
                                          for k in LOW_SUMMARY[budget.player]}},
        "per_seed": {str(s): per_seed[s] for s in seeds},
        "high_last_climb": climbs,
        "training": {str(s): {stage: {k: c.get(k) for k in (
            "steps", "train_wall_s", "steps_per_s", "decisions_simulated", "final", "warm_start",
            "start")}
            for stage, c in curves[s].items()} for s in seeds},
    }


def _ci(e: dict[str, float], digits: int = 2, scale: float = 1.0) -> str:
    if e["value"] is None or not np.isfinite(e["value"]):
        return "—"  # undefined: no rally of the method got that far
    return (f"{scale * e['value']:.{digits}f} [{scale * e['low']:.{digits}f}, "
            f"{scale * e['high']:.{digits}f}]")


def table_vii(r: dict[str, Any]) -> list[str]:
    """The pooled table, beside the paper's numbers."""
    cap = r.get("cap", PAPER_CAP)
    paper = r["paper"]  # None for the HUMAN-LIKE players: the paper has no 3-D table
    lines = [f"| method | mean rally [95 % CI] | median | IQM [95 % CI] | rallies reaching {cap} "
             "| worst seed: mean |" + (" paper: mean | paper: reaching 50 |" if paper else ""),
             "|---|---|---|---|---|---|" + ("---|---|" if paper else "")]
    for m, s in r["methods"].items():
        w = s["worst_seed"]
        line = (f"| {m} | {_ci(s['mean'])} | {s['median']['value']:.1f} | {_ci(s['iqm'])} | "
                f"{s['capped']} of {s['n_rallies']} ({100 * s['capped'] / s['n_rallies']:.0f} "
                f"%) | {w['mean']['value']:.2f} (seed {w['seed']}) |")
        if paper:
            p = paper["table_vii"][m]
            line += f" {p['mean']:.2f} | {p['capped']} |"
        lines.append(line)
    return lines


def per_seed_table(r: dict[str, Any]) -> list[str]:
    """Each training seed's mean rally per method (95 % CI over its rallies)."""
    cap = r.get("cap", PAPER_CAP)
    lines = [f"| seed | {' | '.join(r['methods'])} | HRL reaching {cap} |",
             "|---|" + "---|" * (len(r["methods"]) + 1)]
    for seed in r["methods_per_seed"]["HRL"]:
        row = [_ci(r["methods_per_seed"][m][seed]["mean"]) for m in r["methods"]]
        h = r["methods_per_seed"]["HRL"][seed]
        lines.append(f"| {seed} | {' | '.join(row)} | {h['capped']} of {h['n_rallies']} |")
    return lines


def losses_table(r: dict[str, Any]) -> list[str]:
    """Where rallies are lost, per method (pooled, 95 % CIs, in %)."""
    lines = ["| method | serve returned (%) | first return missed (%) | lost before hit 2 (%) | "
             "miss rate per hit after (%) |", "|---|---|---|---|---|"]
    for m, s in r["methods"].items():
        lines.append(f"| {m} | " + " | ".join(
            _ci(s[k], 2 if k == "later_miss_rate" else 1, 100.0) for k in LOSS_KEYS) + " |")
    return lines


def low_level_table(r: dict[str, Any]) -> list[str]:
    """Each seed's low level on fresh serves (deterministic policy)."""
    per_seed = r["low_level"]["per_seed"]
    if r.get("player", "simple") == "humanlike":
        lines = ["| seed | mean episode reward | hit rate | mean angle error | mean speed error |",
                 "|---|---|---|---|---|"]
        for seed, low in zip(r["per_seed"], per_seed, strict=True):
            lines.append(f"| {seed} | {low['mean_reward']:.3f} | {low['hit_rate']:.3f} | "
                         f"{low['mean_angle_error']:.2f}° | "
                         f"{low['mean_abs_speed_error']:.3f} |")
        return lines
    follows = all("goal_correlation" in low for low in per_seed)  # (older runs lack it)
    head = "| seed | mean episode reward | hit rate | landed in | median landing error |"
    lines = [head + (" goal correlation (reachable goals) |" if follows else ""),
             "|---|---|---|---|---|" + ("---|" if follows else "")]
    for seed, low in zip(r["per_seed"], per_seed, strict=True):
        lines.append(f"| {seed} | {low['mean_reward']:.3f} | {low['hit_rate']:.3f} | "
                     f"{low['in_rate']:.3f} | {low['median_error']:.2f} m |"
                     + (f" {number_cell(low['goal_correlation'], 3)} |" if follows else ""))
    return lines


def report_tables(r: dict[str, Any]) -> list[str]:
    """Table VII, the per-seed means, where rallies are lost and the low level per seed, each
    under its caption (the report's body; docs/results.md renders the same)."""
    return [
        *table_vii(r),
        "",
        "Per training seed (mean rally, 95 % CI over its rallies):",
        "",
        *per_seed_table(r),
        "",
        "Where rallies are lost (pooled, 95 % CIs):",
        "",
        *losses_table(r),
        "",
        "The low level per seed (deterministic policy, fresh serves):",
        "",
        *low_level_table(r),
    ]


def numerics_line(r: dict[str, Any]) -> str:
    """Which CPU and numeric settings the run used (docs/numerics.md), in one sentence."""
    n = r.get("numerics")
    if n is None:
        return "Numerics: not recorded (a run from before they were)."
    settings = ", ".join(f"`{k}={v}`" for k, v in n["environment"].items()) or "none set"
    levels = "".join(f"{name}: {value}; " for name, value in (
        ("torch's kernels", n.get("torch_cpu_capability")),
        ("NumPy's SIMD", ", ".join(n.get("numpy_simd", [])))) if value)
    return (f"Numerics: CPU {n['cpu']} ({'with' if n['avx512'] else 'without'} AVX-512); "
            f"{levels}{'pinned' if n['pinned'] else 'not pinned'} "
            f"(`rallysim.numerics.PINNED`); variables: {settings}.")


def markdown_report(r: dict[str, Any]) -> str:
    """The report of a reproduction: what ran, on which numerics, its tables and checks."""
    b = r["budget"]
    cap = r.get("cap", PAPER_CAP)
    humanlike = r.get("player", "simple") == "humanlike"
    title, method, low_line = (_humanlike_parts if humanlike else _simple_parts)(r)
    pairs = ("Pairs whose intervals are disjoint: "
             + (", ".join(k for k, v in r["disjoint_above"].items() if v) or "none") + ".")
    if not humanlike:  # (the paper has no 3-D table to order)
        pairs = ("The paper's order HRL > Random High-level > Monolithic, with disjoint 95 % "
                 "intervals of the mean: "
                 f"**{'yes' if r['order_hrl_random_mono_with_disjoint_cis'] else 'no'}**. "
                 + pairs)
    lines = [
        title,
        "",
        f"Budget `{b['name']}`: {b['seeds']} training seeds; per seed {method}, the high level "
        f"{b['high_turns']:,} turns, the Monolithic baseline the same total budget; each "
        f"method then played {b['rallies']} evaluation rallies per seed (capped at {cap} "
        f"hits). Wall time {r['wall_s']['total'] / 60:.1f} min (training "
        f"{r['wall_s']['training'] / 60:.1f} min).",
        "",
        numerics_line(r),
        "",
        *report_tables(r),
        "",
        pairs,
        "",
        "Checks: " + ", ".join(f"{k}: **{'yes' if v else 'no'}**"
                               for k, v in current_checks(r).items()) + ".",
        "",
        low_line,
        "",
        f"The cap censors the mean: see `{result_names(cap)['survival']}` for "
        "P(rally length >= k).",
        "Intervals: hierarchical bootstrap (seeds, then rallies), 2,000 replicates.",
        "",
    ]
    return "\n".join(lines)


def _simple_parts(r: dict[str, Any]) -> tuple[str, str, str]:
    """The SIMPLE report's title, low-level method and low-level line."""
    b, low = r["budget"], r["low_level"]
    method = (f"the low level trained {b['low_decisions']:,} decisions"
              + (" after a behaviour-cloning warm start from the scripted controller (not the "
                 "paper's method: PPO from scratch learns to hit but ignores the goal)"
                 if b["warm_start"] == "scripted" else " from scratch (the paper's method)"
                 if b.get("goals", "uniform") == "uniform" else
                 " from scratch on SimpleReturn-v1 (goals the serve makes reachable; no "
                 "teacher anywhere)"))
    low_line = (f"Low level (deterministic policy, {b['low_eval_episodes']} fresh episodes per "
                f"seed): mean episode reward {low['mean_reward']:.3f} (paper about "
                f"{PAPER_LOW_REWARD}; the task's ceiling is about 1.72, see "
                f"`benchmarks/low_level_ceiling.py`), hit rate {low['hit_rate']:.3f}, median "
                f"landing error {low['median_error']:.2f} m.")
    return ("# RallySim reproduction of the paper's Table VII (SIMPLE, cooperative rally)",
            method, low_line)


def _humanlike_parts(r: dict[str, Any]) -> tuple[str, str, str]:
    """The HUMAN-LIKE report's: the low level is the clone of ``AimedSwing``, and the
    Monolithic budget counts the teacher's labelled decisions."""
    b, low = r["budget"], r["low_level"]
    method = ("the low level cloned from the scripted `AimedSwing` with DAgger rounds (not the "
              "paper's method: the paper trained the HUMAN-LIKE low level with PPO, which "
              "misses the target velocity by tens of degrees; the teacher's labelled decisions "
              "count in the Monolithic budget)")
    low_line = (f"Low level (deterministic policy, {b['low_eval_episodes']} fresh serves per "
                f"seed): hit rate {low['hit_rate']:.3f}, mean angle error "
                f"{low['mean_angle_error']:.2f}°, mean speed error "
                f"{low['mean_abs_speed_error']:.3f}.")
    return ("# RallySim's Table VII for the HUMAN-LIKE players (3-D, cooperative rally)",
            method, low_line)


def plot_learning_curves(curves: dict[int, dict[str, Any]], path: Path,
                         player: str = "simple") -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    from rallysim.train.stages import STAGES

    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    # (stage, title, the paper's value to draw, if any)
    panels = [("low", "low level: mean episode reward",
               PAPER_LOW_REWARD if player == "simple" else None),
              ("high", "high level: mean rally length", None),
              ("mono", "Monolithic: mean rally length", None)]
    for ax, (name, title, paper) in zip(axes, panels, strict=True):
        stage = STAGES[name]
        for seed, c in sorted(curves.items()):
            evals = c[name]["evals"]
            ax.plot([e["steps"] for e in evals], [e[stage.score_key] for e in evals],
                    marker="o", label=f"seed {seed}")
        if paper is not None:
            ax.axhline(paper, ls="--", c="grey", label="paper (Fig. 6)")
        ax.set_title(title)
        ax.set_xlabel(stage.unit)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)


def plot_survival(results: dict[str, Any], path: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(figsize=(7, 4.5))
    for m, s in results["methods"].items():
        ax.step(s["survival_k"], s["survival"], where="post", label=m)
        ax.fill_between(s["survival_k"], s["survival_low"], s["survival_high"], step="post",
                        alpha=0.2)
    ax.set_xlabel("rally length k (hits)")
    ax.set_ylabel("P(rally length >= k)")
    cap = results.get("cap", PAPER_CAP)
    ax.set_title(f"Survival of rallies (95 % bootstrap bands; cap {cap})")
    if cap > 200:
        ax.set_xscale("symlog", linthresh=10)
    ax.set_ylim(0, 1.02)
    ax.grid(alpha=0.3)
    ax.legend()
    fig.tight_layout()
    fig.savefig(path, dpi=110)
    plt.close(fig)
