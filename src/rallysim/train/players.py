"""The players a stage can train: their names in settings and messages and their run folders.

Kept free of MuJoCo and torch so that reading a configuration stays light; what a player
changes inside a stage (its env, teacher, evaluation) lives in that stage's table
(``rallysim.train.stages``).
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path


@dataclass(frozen=True)
class Player:
    """One player model as training names it."""

    name: str  # the value of the ``player`` setting and of ``--player``
    label: str  # as the docs and messages write it
    run_suffix: str  # after the stage in the default run folder, runs/{stage}{suffix}_seed{N}

    def run_folder(self, stage: str, seed: int) -> Path:
        return Path("runs") / f"{stage}{self.run_suffix}_seed{seed}"


PLAYERS: dict[str, Player] = {p.name: p for p in (
    Player("simple", "SIMPLE", ""),
    Player("humanlike", "HUMAN-LIKE", "_humanlike"),
)}
DEFAULT_PLAYER = "simple"
