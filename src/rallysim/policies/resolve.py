"""Former entry points of policy resolution, each one line over ``registry.resolve`` (the one
implementation); kept while callers move to the registry."""

from __future__ import annotations

from rallysim.policies.registry import PRETRAINED, load_network, pretrained_prefix, resolve
from rallysim.policies.types import HighLevel, LowLevel, Policy

ROLES = ("low", "high", "mono")
__all__ = ["PRETRAINED", "ROLES", "load_network", "pretrained_prefix"]


def humanlike_low_level(spec: str) -> Policy:
    return resolve(spec, "low", "humanlike")


def low_level_policy(spec: str, seed: int = 0) -> Policy:
    return resolve(spec, "low", "simple", seed)


def rally_low_level(spec: str, seed: int = 0) -> LowLevel:
    return resolve(spec, "rally_low", "simple", seed)


def high_level_policy(spec: str, seed: int = 0) -> HighLevel:
    return resolve(spec, "high", "simple", seed)


def mono_policy(spec: str, seed: int = 0) -> Policy:
    return resolve(spec, "mono", "simple", seed)
