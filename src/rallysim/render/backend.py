"""Choose MuJoCo's headless OpenGL backend before anything renders.

MuJoCo reads ``MUJOCO_GL`` once, when ``mujoco`` is first imported, and on Linux falls back to
GLFW, which needs a display. Without a GPU, Mesa's software rasteriser (llvmpipe) works through
either OSMesa or EGL, equally fast on the 2-core development machines (both run llvmpipe);
OSMesa comes first there because it needs no device at all. With a GPU render node, EGL renders
on the GPU while OSMesa never does, so EGL comes first. A backend the user chose (``MUJOCO_GL``
set) is never overridden.
"""

from __future__ import annotations

import ctypes.util
import glob
import importlib
import os
import sys

HEADLESS_BACKENDS = ("osmesa", "egl")
_LIBRARIES = {"osmesa": "OSMesa", "egl": "EGL"}
_GL_CONTEXT_MODULE = "mujoco.rendering.classic.gl_context"


def _has_gpu() -> bool:
    return bool(glob.glob("/dev/dri/renderD*") or glob.glob("/dev/nvidia[0-9]*"))


def available_backends() -> list[str]:
    """Headless backends whose shared library the dynamic loader can find, fastest first."""
    order = ("egl", "osmesa") if _has_gpu() else HEADLESS_BACKENDS
    return [b for b in order if ctypes.util.find_library(_LIBRARIES[b])]


def _preferred() -> str | None:
    # PyOpenGL binds to one platform for the whole process; a platform the user already
    # pinned decides the MuJoCo backend too, or MuJoCo's import of it would fail.
    pinned = os.environ.get("PYOPENGL_PLATFORM", "").lower()
    if pinned in HEADLESS_BACKENDS:
        return pinned
    found = available_backends()
    return found[0] if found else None


def select_backend() -> str:
    """Set ``MUJOCO_GL`` to the fastest working headless backend unless the user set it.

    Returns the backend in force ("glfw" means MuJoCo's default, which needs a display)."""
    user = os.environ.get("MUJOCO_GL", "").strip().lower()
    if user:
        return user
    choice = _preferred()
    if choice is None:
        return "glfw"
    os.environ["MUJOCO_GL"] = choice
    gl_context = sys.modules.get(_GL_CONTEXT_MODULE)
    if gl_context is not None and getattr(gl_context, "_MUJOCO_GL", choice) != choice:
        # ``mujoco`` was imported (by the simulator core) before this module, while
        # MUJOCO_GL was unset: re-run its backend selection with the variable now set.
        importlib.reload(gl_context)
    return choice


def active_backend() -> str:
    """The backend MuJoCo's renderer uses in this process."""
    gl_context = sys.modules.get(_GL_CONTEXT_MODULE)
    name = getattr(gl_context, "_MUJOCO_GL", None) or os.environ.get("MUJOCO_GL", "")
    return name or "glfw"
