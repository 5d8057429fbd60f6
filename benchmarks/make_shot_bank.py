"""Record the shot bank shipped in ``rallysim/assets/data/rally_shots.npy``.

Run: ``python benchmarks/make_shot_bank.py``. Scripted players rally with goals ~ U[2, 6] m;
every hit's shuttle state at the end of its decision (position, velocity: 6 floats) is kept,
turned so that the shot flies toward player 0. The low-level task's ``incoming="mixed"`` option
serves from this bank half the time, so that a low level trains on the balls a rally brings.
"""

from __future__ import annotations

from pathlib import Path

import numpy as np

from rallysim.core.tasks.rally import RallyConfig, RallyTask
from rallysim.policies import ScriptedController

OUT = Path(__file__).resolve().parents[1] / "src/rallysim/assets/data/rally_shots.npy"


def record(n_shots: int = 4096, n_rallies: int = 128, seed: int = 7) -> np.ndarray:
    task = RallyTask(n_rallies, RallyConfig(), seed=seed)
    task.reset(np.arange(n_rallies))
    controller = ScriptedController()
    rng = np.random.default_rng(seed)
    goals = rng.uniform(2.0, 6.0, (n_rallies, 2))
    shots: list[np.ndarray] = []
    while len(shots) < n_shots:
        obs = task.observe().reshape(-1, 20)
        _, term, trunc, info = task.step(controller(obs, goals.reshape(-1)).reshape(-1, 2, 3))
        for e, p in zip(*np.nonzero(info["hit"]), strict=True):
            pos, vel = task.game.shuttle.pos[e].copy(), task.game.shuttle.vel[e].copy()
            if p == 0:  # make every shot fly toward player 0 (x < 0)
                pos[:2] *= -1
                vel[:2] *= -1
            if task.game.in_play[e]:
                shots.append(np.concatenate([pos, vel]))
        done = term | trunc
        if done.any():
            task.reset(np.flatnonzero(done))
        goals[task.turn_started] = rng.uniform(2.0, 6.0, task.turn_started.sum())
    return np.asarray(shots[:n_shots], np.float64)


def main() -> None:
    bank = record()
    OUT.parent.mkdir(parents=True, exist_ok=True)
    np.save(OUT, bank, allow_pickle=False)
    speed = np.linalg.norm(bank[:, 3:], axis=1)
    size = OUT.stat().st_size / 1024
    print(f"{len(bank)} shots -> {OUT} ({size:.0f} KiB); x {bank[:, 0].min():.2f}.."
          f"{bank[:, 0].max():.2f} m, speed {speed.min():.1f}..{speed.max():.1f} m/s")


if __name__ == "__main__":
    main()
