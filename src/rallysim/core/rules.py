"""The rulebook (docs/reference.md §3-7): the rule set, serve, swept overlap tests, net, landing,
in/out, arming and scoring.

Functions over batched arrays, shared by every player model and every API view: ``start_rally``
and the ``record_*`` functions change a ``RallyState`` in place, the others return new arrays.
``Game`` runs the physics and calls them (docs/design.md lists which rule lives where).
Positions are metres; a player's *own frame* is the world frame for player 0 and the world
rotated 180 degrees about z for player 1 (``FORWARD[p]`` is the sign that maps x and y between
them).
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass
from typing import Any

import numpy as np

from rallysim.core.court import Court
from rallysim.core.shuttle import ShuttleModel
from rallysim.core.state import SERVE, RallyState

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


# -- the rally's state (rallysim.core.state) ----------------------------------------------------
def start_rally(state: RallyState, envs: np.ndarray, receiver: np.ndarray) -> None:
    """A serve in games ``envs`` toward ``receiver`` (len(envs),): in play, only the receiver
    armed, nobody has hit, no net touch."""
    state.in_play[envs] = True
    state.armed[envs] = False
    state.armed[envs, receiver] = True
    state.has_hit[envs] = False
    state.last_hitter[envs] = SERVE
    state.hits[envs] = 0
    state.net_touched[envs] = False


def record_hits(state: RallyState, env: np.ndarray, player: np.ndarray) -> None:
    """``player`` hit the shuttle in games ``env`` (distinct): it is disarmed and, with two
    players, its opponent armed (the turn passes); the shot is counted and the net touch of
    the last shot forgotten."""
    state.has_hit[env, player] = True
    state.armed[env, player] = False
    if state.armed.shape[1] == 2:
        state.armed[env, 1 - player] = True
    state.last_hitter[env] = player
    state.hits[env] += 1
    state.net_touched[env] = False


def record_net_touches(state: RallyState, envs: np.ndarray, rule_set: Rules) -> np.ndarray:
    """The shuttle met the net in games ``envs``. Returns those where it is the first touch
    since the last shot (the touch events); under the re-arm rule both players are armed there.
    (Blocking the shuttle is physics: ``Game`` moves it.)"""
    first = envs[~state.net_touched[envs]]
    state.net_touched[envs] = True
    if rule_set.net == NET_REARM:
        state.armed[first] = True
    return first


def record_landings(state: RallyState, envs: np.ndarray) -> None:
    """The shuttle landed in games ``envs``: play stops there, nobody may hit."""
    state.in_play[envs] = False
    state.armed[envs] = False


def landing_side(point: np.ndarray) -> np.ndarray:
    """The player (0 or 1) whose half holds each world landing ``point`` (k, 3)."""
    return in_far_half(point[:, 0]).astype(np.int64)


def in_far_half(x: Any) -> Any:
    """Whether world ``x`` (an array, or one number) is in player 1's half."""
    return x > 0


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
    generator lets every environment draw from its own stream."""
    n = len(receiver)
    if n == 1:  # one game: the same operations on Python floats
        return _sample_serve_one(u.reshape(4).tolist(), float(FORWARD[receiver[0]]))
    x0 = SERVE_X[0] + u[:, 0] * (SERVE_X[1] - SERVE_X[0])
    z0 = SERVE_Z[0] + u[:, 1] * (SERVE_Z[1] - SERVE_Z[0])
    t = (x0 - SERVE_X[0]) / (SERVE_X[1] - SERVE_X[0])
    phi_lo = SERVE_ELEVATION_NEAR[0] + t * (SERVE_ELEVATION_FAR[0] - SERVE_ELEVATION_NEAR[0])
    phi = phi_lo + u[:, 2] * (SERVE_ELEVATION_NEAR[1] - phi_lo)
    s_lo = SERVE_SPEED_NEAR[0] + t * (SERVE_SPEED_FAR[0] - SERVE_SPEED_NEAR[0])
    s_hi = SERVE_SPEED_NEAR[1] + t * (SERVE_SPEED_FAR[1] - SERVE_SPEED_NEAR[1])
    s = s_lo + u[:, 3] * (s_hi - s_lo)
    f = FORWARD[receiver]
    pos = np.stack([f * x0, np.zeros(n), z0], axis=1)
    vel = SERVE_SPEED_SCALE * s[:, None] * np.stack([-f * np.cos(phi), np.zeros(n), np.sin(phi)], 1)
    return pos, vel


def _sample_serve_one(u: list[float], f: float) -> tuple[np.ndarray, np.ndarray]:
    """``sample_serve`` of one game (uniforms ``u``, receiver's ``FORWARD`` ``f``) on Python
    floats: (1, 3) arrays."""
    x0 = SERVE_X[0] + u[0] * (SERVE_X[1] - SERVE_X[0])
    z0 = SERVE_Z[0] + u[1] * (SERVE_Z[1] - SERVE_Z[0])
    t = (x0 - SERVE_X[0]) / (SERVE_X[1] - SERVE_X[0])
    (near_lo, near_hi), (far_lo, _) = map(float, SERVE_ELEVATION_NEAR), SERVE_ELEVATION_FAR
    phi_lo = near_lo + t * (float(far_lo) - near_lo)
    phi = phi_lo + u[2] * (near_hi - phi_lo)
    s_lo = SERVE_SPEED_NEAR[0] + t * (SERVE_SPEED_FAR[0] - SERVE_SPEED_NEAR[0])
    s_hi = SERVE_SPEED_NEAR[1] + t * (SERVE_SPEED_FAR[1] - SERVE_SPEED_NEAR[1])
    speed = SERVE_SPEED_SCALE * (s_lo + u[3] * (s_hi - s_lo))
    return (np.array([[f * x0, 0.0, z0]]),
            np.array([[speed * (-f * float(np.cos(phi))), speed * 0.0,
                       speed * float(np.sin(phi))]]))


def segment_box_entry(
    q0: np.ndarray, q1: np.ndarray, lo: np.ndarray, hi: np.ndarray
) -> tuple[np.ndarray, np.ndarray]:
    """Swept overlap of points moving from ``q0`` to ``q1`` (…, 3) against boxes [lo, hi] (…, 3).

    Returns ``(hit, t)``: whether the segment meets the box, and the fraction of the segment at
    which it enters (0 when it starts inside). A sphere against a box is this test against the box
    grown by the radius, which is conservative by at most (sqrt(3) - 1) r at the box's corners.
    """
    d = q1 - q0
    # Zero components become a tiny signed step: the slab then spans (-inf, inf) or nothing.
    np.copyto(d, np.where(d >= 0.0, 1e-12, -1e-12), where=np.abs(d) < 1e-12)
    inv = 1.0 / d
    ta = (lo - q0) * inv
    tb = (hi - q0) * inv
    near = np.minimum(ta, tb)
    far = np.maximum(ta, tb)
    # Elementwise over the 3 axes: NumPy's reductions along a short axis cost far more
    # (docs/design.md).
    t_enter = np.maximum(np.maximum(near[..., 0], near[..., 1]), np.maximum(near[..., 2], 0.0))
    t_exit = np.minimum(np.minimum(far[..., 0], far[..., 1]), far[..., 2])
    hit = (t_enter <= t_exit) & (t_enter <= 1.0)
    return hit, t_enter


def segment_box_entry_one(q0: tuple, q1: tuple, lo: list, hi: list) -> tuple[list, list]:
    """``segment_box_entry`` of one game's points (each an (x, y, z) of Python numbers) against
    their boxes (``lo``, ``hi``: lists of 3 numbers each), the same operations on Python
    floats: (hit, t) as lists, one value per point. (np.minimum(a, b) is ``a if a < b else
    b``, np.maximum(a, b) ``a if a > b else b``: either gives b on a tie.)"""
    hits, ts = [], []
    for p0, p1, box_lo, box_hi in zip(q0, q1, lo, hi, strict=True):
        near, far = [], []
        for a, b, low, high in zip(p0, p1, box_lo, box_hi, strict=True):
            d = b - a
            if abs(d) < 1e-12:
                d = 1e-12 if d >= 0.0 else -1e-12
            inv = 1.0 / d
            ta, tb = (low - a) * inv, (high - a) * inv
            near.append(ta if ta < tb else tb)
            far.append(ta if ta > tb else tb)
        (n0, n1, n2), (f0, f1, f2) = near, far
        m01 = n0 if n0 > n1 else n1
        m2 = n2 if n2 > 0.0 else 0.0
        t_enter = m01 if m01 > m2 else m2
        f01 = f0 if f0 < f1 else f1
        t_exit = f01 if f01 < f2 else f2
        hits.append(t_enter <= t_exit and t_enter <= 1.0)
        ts.append(t_enter)
    return hits, ts


# How far outside a box (per axis) a segment must stay for ``apart``: far above the rounding
# error of the slab arithmetic on positions of metres, so that segment_box_entry misses it too.
APART_MARGIN = 1e-6


def grown(lo: np.ndarray, hi: np.ndarray) -> tuple[tuple, tuple]:
    """Boxes' (lo, hi) (..., 3), as Python numbers grown by ``APART_MARGIN``, for ``apart``."""
    return ((np.asarray(lo) - APART_MARGIN).tolist(), (np.asarray(hi) + APART_MARGIN).tolist())


def apart(q0: tuple, q1: tuple, lo: list, hi: list) -> bool:
    """Whether the segment q0 -> q1 of one game ((x, y, z) Python numbers) stays outside the
    box ``grown(lo, hi)`` on one side of some axis, so that ``segment_box_entry`` finds no hit
    (its entry fraction there is negative or above 1). A single game skips most physics steps'
    box tests with it; a batch nearly always has a game near some box. (Written out for the
    three axes, x and z first, which separate most often: this runs every physics step.)"""
    (x0, y0, z0), (x1, y1, z1), (lx, ly, lz), (hx, hy, hz) = q0, q1, lo, hi
    return ((x0 > hx and x1 > hx) or (x0 < lx and x1 < lx) or (z0 > hz and z1 > hz)
            or (z0 < lz and z1 < lz) or (y0 > hy and y1 > hy) or (y0 < ly and y1 < ly))


def step_apart_with(apart: Callable) -> Callable:
    """``step_apart`` built on ``apart`` (a compiled kernel builds it on a compiled ``apart``,
    ``rallysim.core.one_humanlike``)."""

    def step_apart(f0: tuple, f1: tuple, w0: tuple, w1: tuple, top: float, net_lo: Any,
                   net_hi: Any, face_lo: Any, face_hi: Any) -> bool:
        """Whether one game's shuttle stayed apart from the floor (above ``top``), the net
        and the face (``apart`` of their grown boxes) during a physics step from ``f0``,
        ``w0`` to ``f1``, ``w1`` (``f``: in the face's frame, ``w``: in the world)."""
        return (w0[2] > top and w1[2] > top and apart(w0, w1, net_lo, net_hi)
                and apart(f0, f1, face_lo, face_hi))

    return step_apart


step_apart = step_apart_with(apart)


def net_box(court: Court, radius: float) -> tuple[np.ndarray, np.ndarray]:
    """The net as an axis-aligned box grown by the shuttle radius (world frame)."""
    lo = np.array([-court.net_half_thickness - radius, -court.net_half_span - radius, -BIG])
    hi = np.array([court.net_half_thickness + radius, court.net_half_span + radius,
                   court.net_top + radius])
    return lo, hi


def floor_box() -> tuple[np.ndarray, np.ndarray]:
    """Everything below the floor, as a box: a shuttle has landed when its centre enters it."""
    return np.array([-BIG, -BIG, -BIG]), np.array([BIG, BIG, 0.0])


def landing_in(court: Court, depth: np.ndarray, y: np.ndarray, full_court: bool) -> np.ndarray:
    """Whether a landing at ``depth`` metres beyond the net (receiver's side) and ``y`` is in.

    ``full_court`` judges the whole half court (realistic); otherwise the original builds'
    trigger box x in [0.386, 6.658] is used."""
    in_y = np.abs(y) <= court.half_width
    if full_court:
        return in_y & (depth > 0.0) & (depth <= court.half_length)
    return in_y & (depth >= court.paper_zone_near) & (depth <= court.paper_zone_far)
