"""One training run's record, kept the same way by both backends (``rallysim.train.runner`` for
SB3, ``rallysim.rllib.runner`` for RLlib).

- ``config.yaml`` (``write_config``): the resolved configuration, when the run starts;
- the curve: one row per evaluation (``evals``: ``steps``, ``wall_s`` and the stage's numbers)
  and per update (SB3: ``rollouts``, RLlib: ``iterations``), the final evaluation and the
  throughput; ``decisions`` and ``train_wall_s`` mark where a resumable run stood at its last
  checkpoint (``mark``), which a resumed run continues from (``adopt``);
- ``curve.json`` (``write_curve``): written last and in one step, so that its presence marks a
  finished run (``finished``, which ``reproduce`` asks);
- the evaluation and checkpoint schedule (``eval_due``, ``checkpoint_due``), every
  ``eval.every`` and ``checkpoint_every`` units of the budget;
- progress lines: evaluations and resume notes, labelled with the stage and seed and counted in
  the stage's budget unit (decisions, turns, player-decisions).

Training wall time excludes evaluations: ``train_wall`` is the time since ``start_clock`` less
the time spent in ``evaluate``.
"""

from __future__ import annotations

import json
import math
import time
from pathlib import Path
from typing import Any

import yaml

from rallysim.policies.types import Policy
from rallysim.train import stages
from rallysim.train.checkpoint import atomic_write, json_default
from rallysim.train.config import TrainConfig
from rallysim.train.progress import Say

CURVE = "curve.json"


def finished(out: Path, budget: int) -> dict[str, Any] | None:
    """The curve of a run in ``out`` that finished at least ``budget`` units, or None."""
    path = Path(out) / CURVE
    if not path.is_file():
        return None
    curve = json.loads(path.read_text())
    return curve if curve.get("steps", 0) >= budget else None


class RunLog:
    """The record of one run of ``config`` into ``out``; ``updates`` names its per-update rows,
    ``label`` prefixes its lines, ``say`` is where they go (None: nowhere), ``extra`` are
    fields the curve starts with (the backend's)."""

    def __init__(self, config: TrainConfig, out: Path, updates: str, label: str | None = None,
                 say: Say | None = None, extra: dict[str, Any] | None = None) -> None:
        self.config, self.out, self.updates = config, Path(out), updates
        self.stage = stages.of(config)
        self.label = label or f"[{config.stage} seed {config.seed}]"
        self.say = say
        self.curve: dict[str, Any] = {"stage": config.stage, **(extra or {}), "evals": [],
                                      updates: []}
        self.eval_wall = 0.0
        self.start = time.perf_counter()
        self.next_eval = self.next_ckpt = math.inf

    @property
    def unit(self) -> str:
        return self.stage.unit

    # --- the record ----------------------------------------------------------------------
    def write_config(self, extra: dict[str, Any] | None = None) -> None:
        doc = {**self.config.to_dict(), **(extra or {})}
        (self.out / "config.yaml").write_text(yaml.safe_dump(doc, sort_keys=False))

    def adopt(self, curve: dict[str, Any]) -> None:
        """Continue the curve saved with a checkpoint (a resumed run)."""
        curve.setdefault("evals", [])
        curve.setdefault(self.updates, [])
        self.curve = curve

    def start_clock(self) -> None:
        """Start timing training (continuing a resumed run's time) and schedule the next
        evaluation and checkpoint after the decisions already done."""
        self.start = time.perf_counter() - self.curve.get("train_wall_s", 0.0)
        self.eval_wall = 0.0
        done = self.curve.get("decisions", 0)
        every = self.config.eval.every or math.inf
        self.next_eval = (done // every + 1) * every if every < math.inf else math.inf
        interval = self.config.checkpoint_every
        self.next_ckpt = (done // interval + 1) * interval

    def train_wall(self) -> float:
        return time.perf_counter() - self.start - self.eval_wall

    def record_update(self, row: dict[str, Any]) -> None:
        self.curve[self.updates].append(row)

    def mark(self, done: int) -> None:
        """Where the run stands, saved with its checkpoint."""
        self.curve["decisions"] = int(done)
        self.curve["train_wall_s"] = round(self.train_wall(), 2)

    # --- schedule ------------------------------------------------------------------------
    def eval_due(self, done: int) -> bool:
        """Whether an evaluation is due after ``done`` units (then the next is scheduled)."""
        if done < self.next_eval:
            return False
        while self.next_eval <= done:
            self.next_eval += self.config.eval.every
        return True

    def checkpoint_due(self, done: int) -> bool:
        if done < self.next_ckpt:
            return False
        while self.next_ckpt <= done:
            self.next_ckpt += self.config.checkpoint_every
        return True

    # --- evaluations and the end ---------------------------------------------------------
    def evaluate(self, done: int, act: Policy) -> dict[str, Any]:
        """Evaluate ``act`` with the stage's numbers, add the row to the curve and say it."""
        t = time.perf_counter()
        result = self.stage.evaluate(self.config, act)
        row = {"steps": int(done), "wall_s": round(self.train_wall(), 2), **result}
        self.eval_wall += time.perf_counter() - t
        self.curve["evals"].append(row)
        self.line(f"{int(done):>10,} {self.unit}: {self.stage.headline(self.config, result)}")
        return row

    def evaluation_at(self, done: int) -> dict[str, Any] | None:
        """The last evaluation if it was made at ``done`` units (the final one then need not
        be made again), else None."""
        evals = self.curve["evals"]
        return evals[-1] if evals and evals[-1]["steps"] == done else None

    def finish(self, final: dict[str, Any], done: int,
               decisions_simulated: int | None = None) -> dict[str, Any]:
        """Close the curve: the final evaluation, the units done and the throughput."""
        curve = self.curve
        curve["final"] = final
        curve["steps"] = int(done)
        curve["train_wall_s"] = round(self.train_wall(), 2)
        curve["steps_per_s"] = round(curve["steps"] / max(curve["train_wall_s"], 1e-9), 1)
        if decisions_simulated is not None:
            curve["decisions_simulated"] = decisions_simulated
        return curve

    def write_curve(self) -> None:
        # written last, in one step: a curve.json marks the stage as trained
        data = json.dumps(self.curve, indent=1, default=json_default).encode()
        atomic_write(self.out / CURVE, data, "curve")

    def policy_metadata(self, done: int, final: dict[str, Any] | None,
                        extra: dict[str, Any] | None = None) -> dict[str, Any]:
        """What an exported policy's JSON records about the run that made it."""
        config = self.config
        meta: dict[str, Any] = {"stage": config.stage, "player": config.player,
                                "seed": config.seed, "steps": int(done),
                                "budget_unit": self.unit, **(extra or {})}
        if final is not None:
            meta["final"] = final
        meta["config"] = config.to_dict()
        if (mapping := self.stage.goal_mapping(config)) is not None:
            meta["goal_mapping"] = mapping
        return meta

    # --- lines ---------------------------------------------------------------------------
    def line(self, text: str) -> None:
        """``text`` after the run's label, where the run's lines go."""
        if self.say is not None:
            self.say(f"{self.label} {text}")

    def resume_note(self, checkpoint: Path, done: int) -> str:
        return (f"resuming {self.config.stage} from {checkpoint.name} "
                f"({done:,} {self.unit} done)")

    def restart_note(self, removed: int) -> str:
        return (f"restarting {self.config.stage}: removed {removed} checkpoint(s) of the "
                "previous run")
