"""Player kinds: ``PLAYERS[name]`` is the frozen ``PlayerSpec`` of each (see ``spec``).

Each module of this package that defines ``PLAYER`` (a ``PlayerSpec``) is a player kind, so a
new kind is one new module here (with its bodies in ``rallysim.core`` and its MJCF asset).
"""

from __future__ import annotations

import importlib
import pkgutil

from rallysim.players.spec import GoalSpec, Layout, PlayerSpec, StartPose


def _discover() -> dict[str, PlayerSpec]:
    found = {}
    for info in sorted(pkgutil.iter_modules(__path__), key=lambda m: m.name):
        spec = getattr(importlib.import_module(f"{__name__}.{info.name}"), "PLAYER", None)
        if isinstance(spec, PlayerSpec):
            found[spec.name] = spec
    return found


PLAYERS: dict[str, PlayerSpec] = _discover()
SIMPLE, HUMANLIKE = PLAYERS["simple"], PLAYERS["humanlike"]


def get_player(player: str | PlayerSpec) -> PlayerSpec:
    """The spec of ``player`` (a name, or a spec passed through)."""
    if isinstance(player, PlayerSpec):
        return player
    try:
        return PLAYERS[player]
    except (KeyError, TypeError):
        raise ValueError(f"unknown player kind {player!r}; valid: "
                         f"{', '.join(map(repr, PLAYERS))}") from None


__all__ = ["HUMANLIKE", "PLAYERS", "SIMPLE", "GoalSpec", "Layout", "PlayerSpec", "StartPose",
           "get_player"]
