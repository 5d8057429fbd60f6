"""Issue 37's before/after: the throughput benchmarks run on two revisions of the package, in
turn, on one machine.

Run: ``python benchmarks/side_by_side.py [--before ff11adb] [--rounds 2] [--quick]
[--json PATH]``

The revision ``--before`` is checked out into a temporary git worktree; each round runs
``rally_throughput.py`` and ``humanlike_throughput.py`` (these files, from the working tree)
first against that revision's ``src`` and then against the working tree's, each in a fresh
Python process with the package's ``src`` first on ``sys.path``. Old and new alternate so
that a slower minute of a shared machine slows both; compare within a row, best against
best. The JSON keeps every run.
"""

from __future__ import annotations

import argparse
import json
import os
import platform
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parents[1]
BENCHMARKS = ("rally_throughput.py", "humanlike_throughput.py")
# the rows compared: (benchmark, key in its JSON, label)
ROWS = (
    ("rally_throughput.py", "low-level SimpleReturnVectorEnv, random (reference)",
     "SimpleReturnVectorEnv, N = 256, random"),
    ("rally_throughput.py", "rally SimpleRallyVectorEnv, random",
     "SimpleRallyVectorEnv, 256 rallies, random"),
    ("rally_throughput.py", "rally ceiling: raw mj_step of its model",
     "(ceiling) raw mj_step of the rally's model, 5 per decision"),
    ("rally_throughput.py", "rally ceiling: its Game.step alone",
     "(ceiling) the rally's Game.step alone, 256 rallies"),
    ("rally_throughput.py", "rally RallyTask + scripted controllers",
     "RallyTask + scripted controllers, 256 rallies"),
    ("rally_throughput.py", "turn decisions/s",
     "SimpleRallyTurnVectorEnv, scripted low level (decisions inside turns)"),
    ("humanlike_throughput.py", "ours_64", "HumanLikeReturnVectorEnv, N = 64, random"),
    ("humanlike_throughput.py", "ours_256", "HumanLikeReturnVectorEnv, N = 256, random"),
    ("humanlike_throughput.py", "bodies_256",
     "(ceiling) HumanLikeBodies.physics_step alone, N = 256"),
    ("humanlike_throughput.py", "single", 'gym.make("RallySim/HumanLikeReturn-v0")'),
)


def run(script: str, src: Path, quick: bool) -> dict[str, float]:
    """``script``'s numbers with the package imported from ``src``."""
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "out.json"
        env = {**os.environ, "PYTHONPATH": str(src)}
        cmd = [sys.executable, str(ROOT / "benchmarks" / script), "--json", str(out)]
        subprocess.run(cmd + (["--quick"] if quick else []), check=True, env=env, cwd=tmp,
                       stdout=subprocess.DEVNULL)
        data = json.loads(out.read_text())
    if "rows" in data:  # humanlike_throughput.py: a list of rows with keys and rates
        return {r["key"]: r["decisions_per_s"] for r in data["rows"]
                if r.get("decisions_per_s") is not None}
    return data


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--before", default="ff11adb", help="the revision to compare against")
    p.add_argument("--rounds", type=int, default=2, help="old-then-new runs of each benchmark")
    p.add_argument("--quick", action="store_true", help="the benchmarks' short timings")
    p.add_argument("--json", metavar="PATH", help="write every run to this JSON file")
    args = p.parse_args(argv)
    after = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=ROOT, check=True,
                           capture_output=True, text=True).stdout.strip()
    dirty = subprocess.run(["git", "status", "--porcelain", "src"], cwd=ROOT, check=True,
                           capture_output=True, text=True).stdout.strip()
    runs: dict[str, dict[str, list[dict[str, float]]]] = {}
    with tempfile.TemporaryDirectory() as tmp:
        tree = Path(tmp) / "before"
        subprocess.run(["git", "worktree", "add", "--detach", "-q", str(tree), args.before],
                       cwd=ROOT, check=True)
        try:
            for r in range(args.rounds):
                for script in BENCHMARKS:
                    for side, src in (("before", tree / "src"), ("after", ROOT / "src")):
                        print(f"round {r + 1}: {script} ({side})", file=sys.stderr, flush=True)
                        runs.setdefault(script, {}).setdefault(side, []).append(
                            run(script, src, args.quick))
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(tree)], cwd=ROOT,
                           check=False)
    rows = {}
    print(f"| benchmark (decisions/s) | before ({args.before}) | after ({after}"
          f"{' + changes' if dirty else ''}) | ratio of the best |")
    print("|---|---:|---:|---:|")
    for script, key, label in ROWS:
        before = [run_[key] for run_ in runs[script]["before"] if key in run_]
        now = [run_[key] for run_ in runs[script]["after"] if key in run_]
        if not before or not now:
            continue
        rows[key] = {"label": label, "before": before, "after": now}
        print(f"| {label} | {' / '.join(f'{v:,.0f}' for v in before)} | "
              f"{' / '.join(f'{v:,.0f}' for v in now)} | {max(now) / max(before):.2f}x |")
    if args.json:
        Path(args.json).write_text(json.dumps({
            "before": args.before, "after": after, "after_has_changes": bool(dirty),
            "rounds": args.rounds, "quick": args.quick,
            "machine": {"cpu": _cpu(), "python": platform.python_version()},
            "commands": [f"python benchmarks/{s} --json ..." for s in BENCHMARKS],
            "rows": rows}, indent=2) + "\n")
    return 0


def _cpu() -> str:
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor()


if __name__ == "__main__":
    raise SystemExit(main())
