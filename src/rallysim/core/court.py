"""Court geometry (docs/reference.md §3), read once from ``assets/court.xml`` so every dimension
lives there."""

from __future__ import annotations

from dataclasses import dataclass
from functools import lru_cache

import mujoco

from rallysim.assets import asset_path


@dataclass(frozen=True)
class Court:
    """Dimensions in metres, in the world frame (net plane x = 0, player 0 at x < 0)."""

    half_length: float  # floor spans x in [-half_length, half_length]
    half_width: float  # floor spans y in [-half_width, half_width]
    net_half_thickness: float
    net_top: float
    net_half_span: float  # the net spans y in [-net_half_span, net_half_span]
    paper_zone_near: float  # the original builds' landing trigger, as a depth beyond the net
    paper_zone_far: float

    @classmethod
    def from_mjcf(cls) -> Court:
        return _load_court()


@lru_cache(maxsize=1)
def _load_court() -> Court:
    model = mujoco.MjModel.from_xml_path(str(asset_path("court.xml")))

    def geom(name: str) -> tuple:
        gid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_GEOM, name)
        return model.geom_pos[gid], model.geom_size[gid]

    _, floor = geom("floor")
    net_pos, net_size = geom("net")
    sid = mujoco.mj_name2id(model, mujoco.mjtObj.mjOBJ_SITE, "paper_landing_zone")
    zone_x, zone_half = float(model.site_pos[sid][0]), float(model.site_size[sid][0])
    return Court(
        half_length=float(floor[0]),
        half_width=float(floor[1]),
        net_half_thickness=float(net_size[0]),
        net_top=float(net_pos[2] + net_size[2]),
        net_half_span=float(net_size[1]),
        paper_zone_near=zone_x - zone_half,
        paper_zone_far=zone_x + zone_half,
    )
