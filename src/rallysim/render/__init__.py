"""Headless rendering of RallySim scenes: frames, videos, strips of stills.

Importing this package picks MuJoCo's OpenGL backend (``MUJOCO_GL``) for machines without a
display, unless the user already chose one: see ``rallysim.render.backend``.
"""

from rallysim.render.backend import active_backend, available_backends, select_backend

select_backend()  # before any renderer exists (and before mujoco, where it is not yet imported)

# ruff: noqa: E402 -- these imports must follow the backend choice
from rallysim.render.record import record_low_level, record_rally
from rallysim.render.scene import SceneRenderer
from rallysim.render.video import write_strip, write_video

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
