"""Scaling out: RallySim's training stages on a Ray cluster with RLlib PPO (new API stack).

Needs the ``ray`` extra (``pip install torch==2.13.0 && pip install 'rallysim[ray]'``). Nothing
here is imported by ``import rallysim``; each module imports Ray itself.

- ``rallysim.rllib.envs``: the envs as RLlib sees them (the low-level task single-agent and
  natively batched; the rally and the turn-based rally multi-agent with one shared policy) and
  their registration under names env runners on any node can build.
- ``rallysim.rllib.ppo_config``: ``TrainConfig`` -> RLlib ``PPOConfig``.
- ``rallysim.rllib.module``: the PPO RLModule (RLlib's default, log-std started like SB3's).
- ``rallysim.rllib.export``: RLModule actor -> RallySim's safetensors + JSON policy format.
- ``rallysim.rllib.runner``: ``train_stage_rllib``, the counterpart of
  ``rallysim.train.runner.train_stage``.
"""

from __future__ import annotations

import importlib.util

INSTALL_HINT = "pip install torch==2.13.0 && pip install 'rallysim[ray]'"


def missing_packages() -> list[str]:
    """The packages of the ``ray`` extra that are not installed (empty: all there)."""
    return [m for m in ("ray", "torch", "yaml") if importlib.util.find_spec(m) is None]


def require_ray() -> None:
    """Raise ``ImportError`` naming the extra when Ray RLlib (or torch) is missing."""
    missing = missing_packages()
    if missing:
        raise ImportError(f"the RLlib backend needs the ray extra (missing: {', '.join(missing)}):"
                          f" install rallysim[ray], e.g. {INSTALL_HINT}")
