"""RallySim: a fast MuJoCo simulator for turn-based multi-agent RL with continuous control.

Importing the package registers the Gymnasium environments (``RallySim/SimpleReturn-v0``).
"""

from rallysim.envs.registration import register_envs

__version__ = "0.1.0"

register_envs()

__all__ = ["__version__"]
