"""The rulebook (docs/reference.md §3-7): the rule set, serve, the tested boxes and scoring.

Functions over batched arrays, shared by every player model and every API view, returning new
arrays. The start of a rally and what happens within a physics step (the swept overlap test,
hits, net touches, landings, in/out and arming) are the compiled steps'
(``rallysim.core.kernels.step``); docs/design.md lists which rule lives where.
Positions are metres; a player's *own frame* is the world frame for player 0 and the world
rotated 180 degrees about z for player 1 (``FORWARD[p]`` is the sign that maps x and y between
them).
"""

from __future__ import annotations

import functools
from dataclasses import dataclass
from typing import Any

import numpy as np

from rallysim.core import native
from rallysim.core.court import Court
from rallysim.core.shuttle import ShuttleModel

FORWARD = np.array([1.0, -1.0])  # own-frame x (and y) = FORWARD[p] * world x (and y)
BIG = 1e9  # "unbounded" for box sides; finite so that 0 * BIG stays 0

# docs/reference.md §4.3: the machine serve, in the receiver's own frame.
SERVE_X = (1.0, 6.0)
SERVE_Z = (1.0, 1.5)
SERVE_ELEVATION_NEAR = (np.radians(45.0), np.radians(60.0))  # x0 = 1
SERVE_ELEVATION_FAR = (np.radians(15.0), np.radians(60.0))  # x0 = 6
SERVE_SPEED_NEAR = (2.0, 3.0)
SERVE_SPEED_FAR = (4.0, 5.5)
SERVE_SPEED_SCALE = 5.0


SERVE_DRAWS = 4  # uniforms one serve consumes

# What a net touch does (``Rules.net``).
NET_REARM = "rearm"  # both players are armed again, the shuttle flies on (the original game)
NET_BLOCK = "block"  # the shuttle stops against the net and drops (a real shuttle: aero)
NET_NOTE = "note"  # only noted (one player: nobody to re-arm)
NET_RULES = (NET_REARM, NET_BLOCK, NET_NOTE)


@dataclass(frozen=True)
class Rules:
    """The rule set of one game, derived once (``derive``) from its shuttle model and player
    count: what a net touch does, and which region of a half court is in."""

    net: str  # one of NET_RULES
    full_court: bool  # in/out on the full half court; False: the original builds' trigger box

    def __post_init__(self) -> None:
        if self.net not in NET_RULES:
            raise ValueError(f"unknown net rule {self.net!r}; valid: {', '.join(NET_RULES)}")

    @classmethod
    def derive(cls, flight: ShuttleModel, n_players: int) -> Rules:
        """A net that blocks the shuttle (``flight.net_blocks``: aero) stops it; otherwise two
        players are both re-armed by a touch, as in the original game, and one player's touch
        is only noted. The court region is the flight model's (``flight.full_court``)."""
        net = NET_BLOCK if flight.net_blocks else NET_REARM if n_players == 2 else NET_NOTE
        return cls(net=net, full_court=flight.full_court)

    @property
    def net_blocks(self) -> bool:
        return self.net == NET_BLOCK


def landing_side(point: np.ndarray) -> np.ndarray:
    """The player (0 or 1) whose half holds each world landing ``point`` (k, 3)."""
    return (point[:, 0] > 0).astype(np.int64)


# -- competitive scoring ------------------------------------------------------------------------
def point_winner(land_side: np.ndarray, land_in: np.ndarray, last_hitter: np.ndarray,
                 server: np.ndarray) -> np.ndarray:
    """Who wins each point that ended in a landing: the opponent of the player at fault. A
    shuttle landing in is the fault of the player whose half it landed in; one landing out is
    the last hitter's (before any hit, the server's)."""
    last = np.where(last_hitter < 0, server, last_hitter)
    return 1 - np.where(land_in, land_side, last)


def game_over(score: np.ndarray, points_to_win: int, win_by: int, max_points: int
              ) -> np.ndarray:
    """Whether each game of ``score`` (k, 2) is over: ``points_to_win`` reached with a lead
    of ``win_by``, or ``max_points`` reached."""
    hi = score.max(axis=1)
    lo = score.min(axis=1)
    return ((hi >= points_to_win) & (hi - lo >= win_by)) | (hi >= max_points)


def sample_serve(u: np.ndarray, receiver: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Serves toward ``receiver`` (n,) players from uniforms ``u`` (n, 4) in [0, 1).

    Returns world-frame positions and velocities, (n, 3) each. Taking uniforms rather than a
    generator lets every environment draw from its own stream. Compiled, for one game as for
    many: a reset costs one call."""
    n = len(receiver)
    pos, vel = np.zeros((n, 3)), np.zeros((n, 3))
    _compiled_serve()(np.ascontiguousarray(u, np.float64).reshape(n, SERVE_DRAWS),
                      FORWARD[np.asarray(receiver, np.int64)], pos, vel)
    return pos, vel


def _serve(u, forward, pos, vel):  # compiled by Numba
    x_lo, x_span = SERVE_X[0], SERVE_X[1] - SERVE_X[0]
    z_lo, z_span = SERVE_Z[0], SERVE_Z[1] - SERVE_Z[0]
    near_lo, near_hi, far_lo = SERVE_ELEVATION_NEAR[0], SERVE_ELEVATION_NEAR[1], \
        SERVE_ELEVATION_FAR[0]
    for i in range(u.shape[0]):
        x0 = x_lo + u[i, 0] * x_span
        z0 = z_lo + u[i, 1] * z_span
        t = (x0 - x_lo) / x_span
        phi_lo = near_lo + t * (far_lo - near_lo)
        phi = phi_lo + u[i, 2] * (near_hi - phi_lo)
        s_lo = SERVE_SPEED_NEAR[0] + t * (SERVE_SPEED_FAR[0] - SERVE_SPEED_NEAR[0])
        s_hi = SERVE_SPEED_NEAR[1] + t * (SERVE_SPEED_FAR[1] - SERVE_SPEED_NEAR[1])
        speed = SERVE_SPEED_SCALE * (s_lo + u[i, 3] * (s_hi - s_lo))
        f = forward[i]
        pos[i, 0], pos[i, 2] = f * x0, z0
        vel[i, 0], vel[i, 1], vel[i, 2] = speed * (-f * np.cos(phi)), speed * 0.0, \
            speed * np.sin(phi)


@functools.cache
def _compiled_serve() -> Any:
    return native.jit(_serve, error_model="numpy")


def net_box(court: Court, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The net as an axis-aligned box grown by the shuttle radius (world frame)."""
    lo = np.array([-court.net_half_thickness - radius, -court.net_half_span - radius, -BIG])
    hi = np.array([court.net_half_thickness + radius, court.net_half_span + radius,
                   court.net_top + radius])
    return lo, hi


def floor_box() -> tuple[np.ndarray, np.ndarray]:
    """Everything below the floor, as a box: a shuttle has landed when its centre enters it."""
    return np.array([-BIG, -BIG, -BIG]), np.array([BIG, BIG, 0.0])
