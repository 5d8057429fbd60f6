"""How many of each seed's HRL rallies reach the cap, on many more rallies than ``reproduce``.

``reproduce`` checks that every seed's HRL takes at least 90 % of its 200 evaluation rallies to
the 50-hit cap. On 200 rallies a seed whose rate is 0.92 fails that about one time in eight, and
one at 0.88 passes about one time in four, so the check alone cannot tell a seed short of 0.9
from an unlucky one. This plays ``--rallies`` HRL rallies per training seed of a ``reproduce``
run (``--runs``: its ``runs`` folder) from an evaluation seed that run never used
(2,000,000 + 1,000 x seed), and writes each seed's count of capped rallies and of rallies lost
before the second hit as it finishes (a rerun skips the seeds already in ``--json``).

    python -m experiments.capped_share --runs results/runs --seeds 0,1,2 --json capped.json

docs/results.md ("Where rallies are lost: the first exchange") quotes a run of it on the
10-seed studies under both numeric settings.
"""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

import numpy as np

from rallysim.eval.rally_eval import rally_lengths_turns, rules_for_cap
from rallysim.eval.stats import estimate, mean
from rallysim.policies.registry import resolve

CAP = 50


def share_interval(capped: int, rallies: int, seed: int) -> dict[str, float]:
    """The share ``capped / rallies`` with its 95 % bootstrap interval (rallies resampled; it
    depends on the counts only)."""
    e = estimate([np.repeat([1.0, 0.0], [capped, rallies - capped])], mean, seed=seed)
    return {"value": e.value, "low": e.low, "high": e.high}


def capped_share(runs: Path, seed: int, rallies: int) -> dict:
    """Seed ``seed``'s HRL (``runs/high_seed{seed}`` over ``runs/low_seed{seed}``) on
    ``rallies`` rallies capped at 50 hits."""
    start = time.time()
    low = resolve(str(runs / f"low_seed{seed}" / "policy"), "rally_low", "simple")
    high = resolve(str(runs / f"high_seed{seed}" / "policy"), "high", "simple")
    lengths = np.asarray(rally_lengths_turns(high, low, rallies, 2_000_000 + 1000 * seed,
                                             rules_for_cap(CAP)))
    capped = int((lengths >= CAP).sum())
    return {"rallies": rallies, "capped": capped,
            "capped_share": share_interval(capped, rallies, seed),
            "lost_before_hit_2": int((lengths < 2).sum()), "mean": float(lengths.mean()),
            "wall_s": round(time.time() - start, 1)}


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--runs", type=Path, required=True)
    parser.add_argument("--seeds", default="0,1,2,3,4,5,6,7,8,9")
    parser.add_argument("--rallies", type=int, default=2000)
    parser.add_argument("--json", type=Path, required=True)
    args = parser.parse_args()
    doc = json.loads(args.json.read_text()) if args.json.exists() else {}
    for seed in (int(s) for s in args.seeds.split(",")):
        if str(seed) in doc and doc[str(seed)]["rallies"] == args.rallies:
            continue
        doc[str(seed)] = capped_share(args.runs, seed, args.rallies)
        args.json.write_text(json.dumps(doc, indent=1) + "\n")
        share = doc[str(seed)]["capped_share"]
        print(f"seed {seed}: {doc[str(seed)]['capped']} of {args.rallies} capped "
              f"({share['value']:.3f} [{share['low']:.3f}, {share['high']:.3f}])", flush=True)


if __name__ == "__main__":
    main()
