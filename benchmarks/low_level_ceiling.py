"""The best mean episode reward any player could reach in ``RallySim/SimpleReturn-v0`` (paper
shuttle), from the game's geometry alone.

Run: ``python benchmarks/low_level_ceiling.py [--serves N]``

A SIMPLE shot leaves at twice the racket face centre's speed, at most 2 x 7 rad/s x 1.06 m =
14.84 m/s, perpendicular to the arm. For each sampled serve, the shuttle's descent is predicted
(the paper flight in closed form); for each hit elevation the face must meet the shuttle where
it crosses that elevation's face height, with the base inside [-6.5, -1] m. The deepest landing
over all elevations at full speed is the serve's *reachable depth*; slower swings land anywhere
shorter. A goal d* ~ U[2, 6] m beyond that depth costs exp(-0.5 (d* - reachable)) at best.
So, with every serve hit (R_hit = 1) and landed perfectly wherever reachable, the mean reward is
at most 1 + E[R_dist] (shaping adds at most +0.001 per physics step before the hit).
"""

from __future__ import annotations

import argparse

import numpy as np

from rallysim.core import rules
from rallysim.policies.scripted import ScriptedController


def reachable_depths(n: int, seed: int = 0) -> np.ndarray:
    """Deepest reachable landing depth (m beyond the net) of ``n`` serves; -inf: unhittable."""
    c = ScriptedController(elevations_deg=(2.0, 80.0), n_elevations=157)
    rng = np.random.default_rng(seed)
    pos, vel = rules.sample_serve(rng.random((n, rules.SERVE_DRAWS)), np.zeros(n, int))
    x, z = c.predict(pos, vel)
    falling = np.diff(np.concatenate([pos[:, 2:3], z], 1), axis=1) < 0
    best = np.full(n, -np.inf)
    rows = np.arange(n)
    for hit_z, hit_dx, shot_range in zip(c.hit_z, c.hit_dx, c.range, strict=True):
        below = (z <= hit_z) & falling
        xh = x[rows, below.argmax(1)]
        base = xh - hit_dx
        ok = below.any(1) & (base <= -1.0) & (base >= -6.5) & (xh < 0)
        best = np.where(ok, np.maximum(best, xh + shot_range), best)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--serves", type=int, default=4000)
    args = parser.parse_args()
    best = reachable_depths(args.serves)
    hittable = np.isfinite(best)
    goals = np.random.default_rng(1).uniform(2.0, 6.0, (args.serves, 64))
    # serves no upward shot can meet may still be hit (R_hit), but never land on a goal
    r_dist = np.exp(-0.5 * np.maximum(0.0, goals - best[:, None])).mean()
    q = np.quantile(best[hittable], [0.1, 0.25, 0.5, 0.75, 0.9])
    print(f"serves sampled: {args.serves}; returnable over the net: {hittable.mean():.3f}")
    print("reachable depth quantiles (10/25/50/75/90 %): " + ", ".join(f"{v:.2f}" for v in q))
    print(f"ceiling of mean R_dist: {r_dist:.3f}")
    print(f"ceiling of mean episode reward: {1.0 + r_dist:.3f} (every serve hit, every "
          "reachable goal met; + at most ~0.02 of shaping)")


if __name__ == "__main__":
    main()
