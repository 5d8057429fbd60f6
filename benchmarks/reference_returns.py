"""Reference returns of PPO and SAC on every RallySim task, over seeds with 95 % intervals.

Run: ``python benchmarks/reference_returns.py [--seeds 3] [--scale 1.0] [--json PATH]``

What is trained and measured: ``rallysim.train.reference_returns`` (its docstring). The table
in docs/rl-alone.md is rendered from the JSON this writes (``docs/data/reference_returns.json``).
"""

import sys

from rallysim.train.reference_returns import main

if __name__ == "__main__":
    sys.exit(main())
