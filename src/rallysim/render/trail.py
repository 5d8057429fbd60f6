"""A fading trail of the shuttle's recent positions, drawn as extra geoms of a rendered scene.

Frames come one per decision (0.1 s), when a fast shuttle travels a metre or more, so the trail
joins its points with thin rods as well as marking them with spheres: it reads as a streak. The
newest parts are the widest and brightest; the spheres also fade out (alpha). The rods fade
in colour instead, toward the hall's wall, because transparent geoms cost the software
rasteriser far more than opaque ones (docs/rendering.md gives the measured costs).
"""

from __future__ import annotations

from collections import deque

import mujoco
import numpy as np

from rallysim.core.shuttle import RADIUS

TRAIL_LENGTH = 15
_MAX_ALPHA = 0.6
_MIN_ALPHA = 0.08
_OLD_RGB = np.array([0.55, 0.62, 0.72], np.float32)  # the rods fade toward the hall wall
_EYE3 = np.eye(3).ravel()


class ShuttleTrail:
    """The last ``length`` distinct shuttle positions and their drawing."""

    def __init__(self, length: int = TRAIL_LENGTH, rgb: tuple[float, float, float] = (1, 1, 1)):
        if length < 0:
            raise ValueError(f"trail length must be >= 0, got {length}")
        self.length = length
        self.rgb = np.asarray(rgb, dtype=np.float32)
        self.points: deque[np.ndarray] = deque(maxlen=max(length, 1))

    def reset(self) -> None:
        self.points.clear()

    def push(self, pos: np.ndarray) -> None:
        """Record a shuttle position; a repeat of the last one (a shuttle at rest, a frame
        rendered twice) adds nothing, so the trail fades only while the shuttle moves."""
        if self.length == 0:
            return
        p = np.array(pos, dtype=np.float64)
        if self.points and np.array_equal(self.points[-1], p):
            return
        self.points.append(p)

    def geoms_needed(self) -> int:
        return 2 * len(self.points)

    def draw(self, scene: mujoco.MjvScene) -> int:
        """Append the trail to ``scene`` (after ``update_scene``); returns the geoms added.

        The newest point is the shuttle itself, already drawn, so it gets no dot."""
        pts = list(self.points)
        n = len(pts)
        if n < 2 or scene.ngeom + self.geoms_needed() > scene.maxgeom:
            return 0
        start = scene.ngeom
        for i in range(n - 1):  # oldest first
            fade = i / (n - 1)  # 0 for the oldest point, -> 1 for the newest
            radius = RADIUS * (0.25 + 0.6 * fade)
            dot = np.append(self.rgb, _MIN_ALPHA + (_MAX_ALPHA - _MIN_ALPHA) * fade)
            self._add(scene, mujoco.mjtGeom.mjGEOM_SPHERE, radius, pts[i], None, dot)
            rod = np.append(_OLD_RGB + (self.rgb - _OLD_RGB) * fade, 1.0)
            self._add(scene, mujoco.mjtGeom.mjGEOM_CYLINDER, 0.4 * radius, pts[i], pts[i + 1],
                      rod)
        return scene.ngeom - start

    @staticmethod
    def _add(scene: mujoco.MjvScene, kind: mujoco.mjtGeom, radius: float, a: np.ndarray,
             b: np.ndarray | None, rgba: np.ndarray) -> None:
        geom = scene.geoms[scene.ngeom]
        size = np.array([radius, radius, radius])
        mujoco.mjv_initGeom(geom, kind, size, a, _EYE3, rgba.astype(np.float32))
        if b is not None:
            mujoco.mjv_connector(geom, kind, radius, a, b)
        geom.emission = 0.4  # keep the trail's colour under the overhead light
        geom.category = mujoco.mjtCatBit.mjCAT_DECOR
        scene.ngeom += 1
