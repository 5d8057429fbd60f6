"""Player kinds: ``PLAYERS[name]`` is the frozen ``PlayerSpec`` of each (see ``spec``).

A new player kind is one new module here defining its spec, and one entry below."""

from __future__ import annotations

from rallysim.players.humanlike import HUMANLIKE
from rallysim.players.simple import SIMPLE
from rallysim.players.spec import GoalSpec, Layout, PlayerSpec, StartPose

PLAYERS: dict[str, PlayerSpec] = {"simple": SIMPLE, "humanlike": HUMANLIKE}


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
