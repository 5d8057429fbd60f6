"""Fingerprints of tiny seeded training runs under each numeric setting: do they repeat on
another CPU?

Run: ``python benchmarks/numerics_fingerprint.py`` (about 80 s on 2 cores) to print and write
this machine's fingerprints; ``--check docs/data/numerics_fingerprint.json`` to compare them
with the committed ones (another machine's), setting by setting and stage by stage.

Each stage (low, high over the shipped low level, mono) trains a few thousand decisions from
seed 0 in a fresh process whose environment holds the setting (NumPy reads its setting when it
loads, so it cannot be changed from inside a process); the fingerprint is the SHA-256 of the
exported weights. Settings: ``native`` (nothing set), ``pinned`` (``rallysim.numerics.PINNED``,
the tests' setting) and ``candidate`` (``rallysim.numerics.TRAINING_CANDIDATE``). Equal
fingerprints on two CPUs under a setting mean that setting makes training bit-identical there
(docs/numerics.md).
"""

from __future__ import annotations

import argparse
import hashlib
import json
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from rallysim import numerics

SMALL = ["ppo.n_envs=32", "ppo.n_steps=16", "ppo.batch_size=256", "eval.episodes=16",
         "checkpoint_every=1024"]
STAGES = {
    "low": ["low", "--budget", "16384", "--set", "seed=0", *SMALL],
    "high": ["high", "--budget", "2048", "--set", "seed=0", "ppo.n_envs=32", "ppo.n_steps=8",
             "ppo.batch_size=64", "eval.episodes=16", "checkpoint_every=1024",
             "low_policy=pretrained"],
    "mono": ["mono", "--budget", "16384", "--set", "seed=0", *SMALL],
}
SETTINGS = {"native": {}, "pinned": numerics.PINNED, "candidate": numerics.TRAINING_CANDIDATE}


def fingerprint(stage: str, setting: dict[str, str], work: Path) -> tuple[str, float]:
    """The stage's exported weights' SHA-256 (first 16 hex digits) and the run's seconds."""
    env = {k: v for k, v in os.environ.items() if k not in numerics.VARIABLES}
    env.update(setting)
    out = work / stage
    start = time.perf_counter()
    subprocess.run([sys.executable, "-m", "rallysim.cli", "train", *STAGES[stage], "--quiet",
                    "--out", str(out)], env=env, check=True, capture_output=True)
    digest = hashlib.sha256((out / "policy.safetensors").read_bytes()).hexdigest()[:16]
    return digest, time.perf_counter() - start


def measure() -> dict:
    result: dict = {"numerics": numerics.describe(), "settings": {}}
    for name, setting in SETTINGS.items():
        row = {}
        for stage in STAGES:
            with tempfile.TemporaryDirectory() as tmp:
                digest, seconds = fingerprint(stage, setting, Path(tmp))
            row[stage] = digest
            print(f"{name:9s} {stage:4s} {digest}  ({seconds:.0f} s)", flush=True)
        result["settings"][name] = {"environment": setting, "fingerprints": row}
    return result


def main() -> int:
    p = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    p.add_argument("--check", type=Path, help="a committed fingerprint file to compare with")
    p.add_argument("--out", type=Path, default=Path("numerics_fingerprint.json"))
    args = p.parse_args()
    result = measure()
    args.out.write_text(json.dumps(result, indent=1) + "\n")
    print(f"wrote {args.out}")
    if args.check is None:
        return 0
    other = json.loads(args.check.read_text())
    print(f"against {args.check} ({other['numerics']['cpu']}):")
    for name, row in result["settings"].items():
        theirs = other["settings"].get(name, {}).get("fingerprints", {})
        same = [stage for stage, digest in row["fingerprints"].items()
                if theirs.get(stage) == digest]
        print(f"  {name}: {len(same)} of {len(row['fingerprints'])} stages identical "
              f"({', '.join(same) or 'none'})")
    return 0


if __name__ == "__main__":
    sys.exit(main())
