"""Where a SIMPLE player can meet an incoming shuttle, and how deep its shots from there land.

``ShotPlanner`` predicts the shuttle with the paper flight model in closed form and, for a fan
of hit elevations, finds the meeting: when the falling shuttle passes the height at which a
full-speed swing's face centre would strike it at that elevation, where the base must stand
for that, and whether the base can get there in time. A full-speed shot from each meeting lands
at a known depth, so the planner also gives the depths a serve makes *reachable*
(``reachable_depths``): the scripted controller aims with it, and the low-level evaluation
scores goal following over the goals it says can be reached.

Everything is read from the 16-value SIMPLE player observation (``rallysim.core.simple_obs``),
batched over N players.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from rallysim.core.bodies import SimpleBodies, player_geometry
from rallysim.core.game import PHYSICS_DT
from rallysim.core.shuttle import GRAVITY, PaperShuttle
from rallysim.core.simple_obs import (
    PLAYER_OBS,
    POSITION_CENTRE,
    POSITION_SCALE,
    SHUTTLE_SPEED_SCALE,
)

BASE_X = PLAYER_OBS["base_position"].start
# base x (own frame, m) across the base's range [-6.5, -1.0] from which a player may meet a shot
BASES = (-6.5, -5.5, -4.5, -3.5, -2.7, -2.0, -1.5, -1.0)


@dataclass(frozen=True)
class Meetings:
    """The candidate meetings of N players with their shuttles, (N, E) arrays over the
    planner's E elevations."""

    t_hit: np.ndarray  # seconds until the face centre should pass the shuttle
    x_hit: np.ndarray  # shuttle x at the meeting (own frame)
    base_needed: np.ndarray  # base centre x that puts the face centre there
    usable: np.ndarray  # the shuttle falls through the hit height on the player's own side
    makeable: np.ndarray  # that base x is in range and the base gets there in time
    depth: np.ndarray  # landing depth of a full-speed shot from there (m beyond the net)

    @property
    def feasible(self) -> np.ndarray:
        return self.usable & self.makeable


@dataclass(frozen=True)
class PlayerState:
    """What the planner reads from N player observations (metres, seconds, radians)."""

    base_x: np.ndarray  # (N,)
    theta: np.ndarray  # (N,) arm angle
    pos: np.ndarray  # (N, 3) shuttle position
    vel: np.ndarray  # (N, 3) shuttle velocity

    @classmethod
    def from_observations(cls, observations: np.ndarray) -> PlayerState:
        obs = np.asarray(observations, dtype=np.float64)
        quaternion = obs[:, PLAYER_OBS["arm_quaternion"]]  # a turn about y: (w, 0, y, 0)
        return cls(base_x=obs[:, BASE_X] * POSITION_SCALE[0] + POSITION_CENTRE[0],
                   theta=2.0 * np.arctan2(quaternion[:, 2], quaternion[:, 0]),
                   pos=obs[:, PLAYER_OBS["shuttle_position"]] * POSITION_SCALE + POSITION_CENTRE,
                   vel=obs[:, PLAYER_OBS["shuttle_velocity"]] * SHUTTLE_SPEED_SCALE)


class ShotPlanner:
    """Meetings and full-speed shot depths of a SIMPLE player (see the module docstring)."""

    horizon_steps = 200  # physics steps of shuttle prediction (4 s)

    def __init__(self, elevations_deg: tuple[float, float] = (8.0, 60.0), n_elevations: int = 27,
                 contact_lead: float = 0.1) -> None:
        b = SimpleBodies  # class constants only: no model is built
        geo = player_geometry()
        self.rho, self.pivot_z = geo["face_offset"], geo["pivot_z"]
        self.limit = geo["limit"]
        self.rate = b.max_rate
        self.speed = b.shot_factor * b.max_rate * self.rho  # shot speed of a full-speed swing
        self.base_range = b.base_range
        self.base_speed = b.max_base_speed
        self.factor = PaperShuttle(PHYSICS_DT).factor
        # The face meets the shuttle before its centre line does (by up to its half thickness
        # plus the shuttle radius, 0.19 rad seen from the pivot, less as the shuttle falls into
        # the swing): see docs/deviations.md for how the lead was chosen.
        self.lead = contact_lead
        self.elev = np.radians(np.linspace(*elevations_deg, n_elevations))
        self.align = -self.elev + self.lead  # arm angle when the face centre passes the shuttle
        self.hit_z = self.pivot_z + self.rho * np.cos(self.align)
        self.hit_dx = self.rho * np.sin(self.align)  # face centre x relative to the base
        self.range = np.array([self._shot_range(e, z) for e, z in zip(self.elev, self.hit_z,
                                                                       strict=True)])
        k = np.arange(1, self.horizon_steps + 1)
        self._fk = self.factor**k
        self._k = k
        self.times = k * PHYSICS_DT  # seconds ahead of each predicted step

    def _shot_range(self, elevation: float, z: float) -> float:
        """Horizontal distance of a full-speed shot at ``elevation`` from height ``z``."""
        vx, vz = self.speed * np.cos(elevation), self.speed * np.sin(elevation)
        x = 0.0
        for _ in range(1000):
            vz = (vz - GRAVITY * PHYSICS_DT) * self.factor
            vx *= self.factor
            z_new = z + vz * PHYSICS_DT
            if z_new < 0.0:
                return x + vx * PHYSICS_DT * z / (z - z_new)
            x += vx * PHYSICS_DT
            z = z_new
        return x

    def predict(self, pos: np.ndarray, vel: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """Shuttle x and z (N, K) after k = 1..K physics steps of the paper model (closed form
        of v_k = f (v_{k-1} + g dt), p_k = p_{k-1} + v_k dt)."""
        f, dt, fk, k = self.factor, PHYSICS_DT, self._fk, self._k
        geo_sum = f * (1.0 - fk) / (1.0 - f)  # sum_{j=1..k} f^j
        x = pos[:, 0:1] + dt * vel[:, 0:1] * geo_sum
        g_term = -GRAVITY * dt * f / (1.0 - f) * (k - geo_sum)
        z = pos[:, 2:3] + dt * (vel[:, 2:3] * geo_sum + g_term)
        return x, z

    @staticmethod
    def falling_crossings(pos: np.ndarray, z: np.ndarray, heights: np.ndarray
                          ) -> tuple[np.ndarray, np.ndarray]:
        """Where N shuttles at ``pos`` with predicted heights ``z`` (N, K) fall through each of
        ``heights`` (E,): whether they do, and the first predicted step at or below the height
        while falling (index into K), both (N, E)."""
        falling = np.diff(np.concatenate([pos[:, 2:3], z], axis=1), axis=1) < 0
        below = (z[:, None, :] <= heights[None, :, None]) & falling[:, None, :]
        return below.any(axis=2), below.argmax(axis=2)

    def meetings(self, state: PlayerState) -> Meetings:
        """Every elevation's meeting for N players."""
        x, z = self.predict(state.pos, state.vel)
        has, idx = self.falling_crossings(state.pos, z, self.hit_z)
        t_hit = self.times[idx]
        x_hit = np.take_along_axis(x, idx, axis=1)
        base_needed = x_hit - self.hit_dx[None, :]
        in_range = (base_needed >= self.base_range[0]) & (base_needed <= self.base_range[1])
        in_time = (np.abs(base_needed - state.base_x[:, None])
                   <= self.base_speed * t_hit + 0.05)
        return Meetings(t_hit=t_hit, x_hit=x_hit, base_needed=base_needed,
                        usable=has & (x_hit < 0.0), makeable=in_range & in_time,
                        depth=x_hit + self.range[None, :])

    def meetable(self, pos: np.ndarray, vel: np.ndarray) -> np.ndarray:
        """Whether shuttles at ``pos`` with ``vel`` (N, 3; the receiver's own frame) can be met at
        full speed from one of ``BASES``, (N,)."""
        n = len(pos)
        out = np.zeros(n, bool)
        for base in BASES:
            state = PlayerState(base_x=np.full(n, base), theta=np.zeros(n), pos=pos, vel=vel)
            out |= self.meetings(state).feasible.any(axis=1)
        return out

    def returnable(self, observations: np.ndarray) -> np.ndarray:
        """Whether the shuttles N players have just hit (their observations) can be met by the
        opponent, seen from its own frame (turned about the vertical), (N,)."""
        state = PlayerState.from_observations(observations)
        pos, vel = state.pos.copy(), state.vel.copy()
        pos[:, :2] *= -1.0
        vel[:, :2] *= -1.0
        return self.meetable(pos, vel)

    def reachable_depths(self, observations: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(lo, hi), (N,): the shallowest and deepest landing of a full-speed shot from any
        meeting the player can make, seen from its observations (NaN where there is none)."""
        m = self.meetings(PlayerState.from_observations(observations))
        depth = np.where(m.feasible, m.depth, np.nan)
        none = ~m.feasible.any(axis=1)
        depth[none] = 0.0  # (all-NaN rows would warn; they are set to NaN below)
        lo, hi = np.nanmin(depth, axis=1), np.nanmax(depth, axis=1)
        lo[none] = hi[none] = np.nan
        return lo, hi
