"""Headless rendering of RallySim scenes: frames, videos, strips of stills.

Importing this package picks MuJoCo's OpenGL backend (``MUJOCO_GL``) for machines without a
display, unless the user already chose one: see ``rallysim.render.backend``.

The drawing modules (``scene``, ``model``, ``players``, ``viewer``, ...) never import the env
views, which create their renderers through them. The recorders, which play envs, are loaded
on first use (``record_low_level``, ``record_rally``), so importing this package from an env
view never comes back to ``rallysim.envs``.
"""

from __future__ import annotations

from typing import Any

from rallysim.render.backend import active_backend, available_backends, select_backend

select_backend()  # before any renderer exists (and before mujoco, where it is not yet imported)

# ruff: noqa: E402 -- these imports must follow the backend choice
from rallysim.render.scene import SceneRenderer
from rallysim.render.video import write_strip, write_video

_RECORDERS = ("record_low_level", "record_rally")

__all__ = [
    "SceneRenderer",
    "active_backend",
    "available_backends",
    "record_low_level",
    "record_rally",
    "select_backend",
    "write_strip",
    "write_video",
]


def __getattr__(name: str) -> Any:
    if name in _RECORDERS:
        from rallysim.render import record

        return getattr(record, name)
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
