"""Frames per second of RallySim's headless renderer, per OpenGL backend and image size.

Run: ``python benchmarks/render_speed.py [--frames N] [--repeats R] [--backends osmesa,egl]``

Each backend runs in its own subprocess (MuJoCo binds its OpenGL backend once per process, at
import). Two rates per image size, for the SIMPLE low-level scene (one player) on the "side"
camera:

raw
    ``mujoco.Renderer.update_scene`` + ``Renderer.render()`` on the renderer's model: building
    the scene, rasterising it, reading the pixels back and copying them out as a fresh (H, W, 3)
    uint8 array. What MuJoCo's own renderer costs for this model.
render(game)
    ``SceneRenderer.render(game, env_index, target_depth, hud_text)``: copying the state of one
    environment out of a ``Game``, kinematics, the scene, a full 15-point shuttle trail, the
    target marker, rasterising, read-back, and the two-line HUD burned into the frame. Frames
    cycle through 64 environments of a ``Game`` played by the scripted controller, so that
    every frame shows a different state and the trail moves.

Each figure is the median of ``--repeats`` timed runs of ``--frames`` frames after a warm-up
(``time.perf_counter``, wall clock). The table gives the ratio of render(game) to the target of
200 frames/s. The machine's 1-minute load average is printed: other processes on a 2-core
machine slow a software rasteriser down directly.
"""

from __future__ import annotations

import argparse
import json
import os
import statistics
import subprocess
import sys
import time

SIZES = ((320, 240), (640, 360), (1280, 720))
TARGET_FPS = 200.0
N_ENVS = 64


def _time(fn, frames: int, repeats: int) -> float:
    """Median frames/s of ``repeats`` runs of ``frames`` calls of ``fn(i)``."""
    for i in range(10):  # warm-up: llvmpipe compiles its shaders on first use
        fn(i)
    rates = []
    for _ in range(repeats):
        start = time.perf_counter()
        for i in range(frames):
            fn(i)
        rates.append(frames / (time.perf_counter() - start))
    return statistics.median(rates)


def _played_game():
    """64 environments of the low-level task, 12 decisions into their episodes (mid-flight)."""
    import numpy as np

    from rallysim.envs.simple_return_v0 import SimpleReturnVectorEnv
    from rallysim.policies.scripted import ScriptedController

    env = SimpleReturnVectorEnv(N_ENVS, seed=0, autoreset_mode="same_step")
    controller = ScriptedController()
    obs, _ = env.reset(seed=0)
    for _ in range(12):
        obs, *_ = env.step(controller.act_return(obs))
    return env.task.game, np.asarray(env.task.goal)


def worker(frames: int, repeats: int) -> dict:
    """Measure in this process, with the backend MUJOCO_GL names."""
    from rallysim.render import SceneRenderer, active_backend

    game, goals = _played_game()
    hud = "episode 3/10   t = 1.2 s   reward +1.004\ntarget 4.43 m   hit at 7.4 m/s"
    rows = []
    for width, height in SIZES:
        with SceneRenderer(1, width, height, "side") as view:
            raw = view.renderer  # the mujoco.Renderer underneath, for the raw figure

            def raw_frame(i: int, raw=raw, view=view) -> None:
                raw.update_scene(view.data, "side")
                raw.render()

            def full_frame(i: int, view=view) -> None:
                e = i % N_ENVS
                view.render(game, e, float(goals[e]), hud)

            view.set_state(game, 0, float(goals[0]))
            rows.append({"width": width, "height": height,
                         "raw": _time(raw_frame, frames, repeats),
                         "full": _time(full_frame, frames, repeats)})
    return {"backend": active_backend(), "rows": rows}


def _run_backend(backend: str, frames: int, repeats: int) -> dict | None:
    env = {**os.environ, "MUJOCO_GL": backend}
    env.pop("PYOPENGL_PLATFORM", None)  # let MuJoCo's backend module pick PyOpenGL's platform
    cmd = [sys.executable, __file__, "--worker", "--frames", str(frames), "--repeats",
           str(repeats)]
    proc = subprocess.run(cmd, env=env, capture_output=True, text=True, check=False)
    if proc.returncode != 0:
        print(f"backend {backend}: failed\n{proc.stderr.strip()[-2000:]}", file=sys.stderr)
        return None
    return json.loads(proc.stdout.strip().splitlines()[-1])


def _table(results: list[dict]) -> str:
    lines = ["| backend | size | raw frames/s | render(game) frames/s | render(game) / 200 |",
             "|---|---|---:|---:|---:|"]
    for res in results:
        for row in res["rows"]:
            lines.append(f"| {res['backend']} | {row['width']}x{row['height']} | "
                         f"{row['raw']:.0f} | {row['full']:.0f} | "
                         f"{row['full'] / TARGET_FPS:.2f} |")
    return "\n".join(lines)


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--frames", type=int, default=300)
    parser.add_argument("--repeats", type=int, default=5)
    parser.add_argument("--backends", default=None,
                        help="comma-separated (default: every headless backend found)")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.worker:
        print(json.dumps(worker(args.frames, args.repeats)))
        return 0

    from rallysim.render.backend import available_backends

    backends = args.backends.split(",") if args.backends else available_backends()
    if not backends:
        print("no headless OpenGL backend found (install libosmesa6 or libegl1 + Mesa)")
        return 1
    results = [r for b in backends if (r := _run_backend(b, args.frames, args.repeats))]
    load = os.getloadavg()[0] if hasattr(os, "getloadavg") else float("nan")
    print(f"RallySim render speed: SIMPLE scene, 'side' camera, {os.cpu_count()} CPUs, "
          f"1-min load average {load:.2f} at the end, LP_NUM_THREADS="
          f"{os.environ.get('LP_NUM_THREADS', 'unset')}\n")
    print(_table(results))
    return 0 if results else 1


if __name__ == "__main__":
    sys.exit(main())
