"""Wall time and peak memory of ``rallysim reproduce``, its whole process tree counted.

Run: ``python benchmarks/reproduce_cost.py [--budget quick|default|smoke] [--out DIR]``

The reproduction runs in a subprocess; every 0.5 s this script sums the resident memory
(``VmRSS`` of ``/proc/PID/status``) of that process and all its descendants (the training
workers), keeping the peak. Targets (issue 4): 20 min and 4 GB for the default budget.
"""

from __future__ import annotations

import argparse
import subprocess
import sys
import tempfile
import time
from pathlib import Path


def tree_rss_mib(root: int) -> float:
    """Summed VmRSS of ``root`` and its descendants, MiB (Linux /proc)."""
    children: dict[int, list[int]] = {}
    rss: dict[int, float] = {}
    for entry in Path("/proc").iterdir():
        if not entry.name.isdigit():
            continue
        try:
            status = (entry / "status").read_text()
        except OSError:
            continue
        fields = dict(line.split(":", 1) for line in status.splitlines() if ":" in line)
        pid, ppid = int(entry.name), int(fields.get("PPid", "0").strip())
        children.setdefault(ppid, []).append(pid)
        rss[pid] = float(fields.get("VmRSS", "0 kB").split()[0]) / 1024
    total, todo = 0.0, [root]
    while todo:
        pid = todo.pop()
        total += rss.get(pid, 0.0)
        todo += children.get(pid, [])
    return total


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--budget", default="quick", choices=("default", "quick", "smoke"))
    parser.add_argument("--out", help="results folder (default: a temporary one)")
    args = parser.parse_args()
    with tempfile.TemporaryDirectory() as tmp:
        out = args.out or str(Path(tmp) / "results")
        cmd = [sys.executable, "-m", "rallysim.cli", "reproduce", "--budget", args.budget,
               "--out", out]
        start = time.perf_counter()
        proc = subprocess.Popen(cmd, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
        peak = 0.0
        while proc.poll() is None:
            peak = max(peak, tree_rss_mib(proc.pid))
            time.sleep(0.5)
        wall = time.perf_counter() - start
        if proc.returncode != 0:
            sys.exit(f"reproduce failed with exit code {proc.returncode}")
    limit = {"default": 20 * 60}.get(args.budget)
    print("| budget | wall | peak RSS, whole process tree | targets |")
    print("|---|---:|---:|---|")
    verdict = (f"{'PASS' if wall <= limit else 'FAIL'} (<= 20 min), "
               if limit else "") + f"{'PASS' if peak <= 4096 else 'FAIL'} (<= 4 GB)"
    print(f"| {args.budget} | {wall / 60:.1f} min | {peak:,.0f} MiB | {verdict} |")


if __name__ == "__main__":
    main()
