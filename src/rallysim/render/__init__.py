"""Headless rendering of RallySim scenes: frames, videos, strips of stills.

Importing this package picks MuJoCo's OpenGL backend (``MUJOCO_GL``) for machines without a
display, unless the user already chose one: see ``rallysim.render.backend``.

The drawing modules (``scene``, ``model``, ``players``, ``viewer``, ...) never import the env
views, which create their renderers through them. The recorders, which play envs, live in
``rallysim.render.record`` and are not imported here, so that an env view's renderer never
brings ``rallysim.envs`` back.
"""

from __future__ import annotations

from rallysim.render.backend import active_backend, available_backends, select_backend

select_backend()  # before any renderer exists (and before mujoco, where it is not yet imported)

# ruff: noqa: E402 -- these imports must follow the backend choice
from rallysim.render.scene import SceneRenderer
from rallysim.render.video import write_strip, write_video

__all__ = [
    "SceneRenderer",
    "active_backend",
    "available_backends",
    "select_backend",
    "write_strip",
    "write_video",
]
