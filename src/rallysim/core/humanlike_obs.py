"""The HUMAN-LIKE player's observation (docs/reference.md §10), without the goal.

Every value is in the observing player's own frame (it stands at x < 0 facing +x) and scaled to
[-1, 1] by a fixed affine map (then clipped by the task). The 82 values:

| index | value | raw range mapped to [-1, 1] |
|---|---|---|
| 14 b + 0-2 | body b's velocity (its joint's point) | [-15, 15] m/s |
| 14 b + 3-5 | body b's angular velocity | [-40, 40] rad/s |
| 14 b + 6-8 | body b's joint position relative to the hips centre | [-1.5, 1.5] m |
| 14 b + 9-12 | body b's orientation quaternion w, x, y, z (w >= 0) | as is |
| 14 b + 13 | body b's joint torque magnitude, a fraction f of its group's maximum | 2 f - 1 |
| 70-72 | shuttle position | x, y in [-10, 10], [-5, 5] m; z in [0, 12] m |
| 73-75 | shuttle velocity | [-30, 30] m/s |
| 76-78 | player (hips centre) position | as the shuttle position |
| 79-81 | racket head (face centre) position | as the shuttle position |

Bodies b = 0-4 are the spine, chest, right upper arm, right lower arm and right hand. Positions
of the shuttle, hips and racket share one map (``simple_obs``'s), so that a policy can compare
them directly.
"""

from __future__ import annotations

import numpy as np

from rallysim.core.game import Game
from rallysim.core.humanlike import HumanLikeBodies
from rallysim.core.layout import Layout
from rallysim.core.simple_obs import POSITION_CENTRE, POSITION_SCALE, SHUTTLE_SPEED_SCALE

BODIES = ("spine", "chest", "upper_arm", "lower_arm", "hand")
N_BODIES = len(BODIES)
BODY_OBS_SIZE = 14
PLAYER_OBS = Layout((*((body, BODY_OBS_SIZE) for body in BODIES), ("shuttle_position", 3),
                     ("shuttle_velocity", 3), ("hips_position", 3), ("racket_position", 3)))
PLAYER_OBS_SIZE = PLAYER_OBS.size  # 82
BODY_SPEED_SCALE = 15.0  # m/s: the hand of a full-speed swing
BODY_RATE_SCALE = 40.0  # rad/s: joints are capped at 30 (50 when limp)
BODY_OFFSET_SCALE = 1.5  # m: the hand reaches 1.2 m from the hips
SHUTTLE = slice(PLAYER_OBS["shuttle_position"].start, PLAYER_OBS["shuttle_velocity"].stop)
HIPS = PLAYER_OBS["hips_position"]
RACKET = PLAYER_OBS["racket_position"]
SHUTTLE_POSITION = PLAYER_OBS["shuttle_position"]
SHUTTLE_VELOCITY = PLAYER_OBS["shuttle_velocity"]


def player_observations(game: Game) -> np.ndarray:
    """(N, P, 82) float64 observations of every HUMAN-LIKE player, own frame, scaled (not yet
    clipped). ``game.bodies`` must be ``HumanLikeBodies``."""
    b: HumanLikeBodies = game.bodies  # type: ignore[assignment]
    if (game.n_envs, game.n_players) == (1, 1):
        return _player_observation_one(game, b)
    return _player_observations_arrays(game, b)


def _player_observations_arrays(game: Game, b: HumanLikeBodies) -> np.ndarray:
    """``player_observations`` as array code over the batch."""
    n, p = game.n_envs, game.n_players
    out = np.empty((n, p, PLAYER_OBS_SIZE))
    body = out[..., :N_BODIES * BODY_OBS_SIZE].reshape(n, p, N_BODIES, BODY_OBS_SIZE)
    vel, ang, rel, quat = b.body_states()
    np.divide(vel, BODY_SPEED_SCALE, out=body[..., 0:3])
    np.divide(ang, BODY_RATE_SCALE, out=body[..., 3:6])
    np.divide(rel, BODY_OFFSET_SCALE, out=body[..., 6:9])
    body[..., 9:13] = quat
    np.subtract(2.0 * b.body_effort(), 1.0, out=body[..., 13])
    flip = b.flip  # x and y change sign in player 1's frame, z does not
    np.multiply(game.shuttle.pos[:, None, :], flip, out=out[..., SHUTTLE_POSITION])
    np.multiply(game.shuttle.vel[:, None, :], flip, out=out[..., SHUTTLE_VELOCITY])
    out[..., SHUTTLE_VELOCITY] /= SHUTTLE_SPEED_SCALE
    out[..., HIPS] = b.hips_position()
    out[..., RACKET] = b.face_centre()
    for positions in (out[..., SHUTTLE_POSITION], out[..., HIPS], out[..., RACKET]):
        positions -= POSITION_CENTRE  # normalise_position, in place
        positions /= POSITION_SCALE
    return out


def _player_observation_one(game: Game, b: HumanLikeBodies) -> np.ndarray:
    """``player_observations`` of one player (N = P = 1) computed on Python floats, the same
    operations in the same order (each NumPy call would cost more than its arithmetic)."""
    values = []
    for v in b.body_states_one():
        values += (v[0] / BODY_SPEED_SCALE, v[1] / BODY_SPEED_SCALE, v[2] / BODY_SPEED_SCALE,
                   v[3] / BODY_RATE_SCALE, v[4] / BODY_RATE_SCALE, v[5] / BODY_RATE_SCALE,
                   v[6] / BODY_OFFSET_SCALE, v[7] / BODY_OFFSET_SCALE,
                   v[8] / BODY_OFFSET_SCALE, v[9], v[10], v[11], v[12], 2.0 * v[13] - 1.0)
    f = b._forward_one  # flip: (f, f, 1.0)
    x, y, z, vx, vy, vz = game.shuttle.motion[:, 0].tolist()
    fx, fy, fz = b.face_position_one()
    values += _normalised(x * f, y * f, z * 1.0)
    values += (vx * f / SHUTTLE_SPEED_SCALE, vy * f / SHUTTLE_SPEED_SCALE,
               vz * 1.0 / SHUTTLE_SPEED_SCALE)
    values += _normalised(*b.hips[0, 0].tolist(), b.hips_height)
    values += _normalised(fx * f, fy * f, fz * 1.0)
    return np.array(values).reshape(1, 1, PLAYER_OBS_SIZE)


def _normalised(x: float, y: float, z: float) -> tuple[float, float, float]:
    """``normalise_position`` of one own-frame position, on floats."""
    (cx, cy, cz), (sx, sy, sz) = _CENTRE, _SCALE
    return (x - cx) / sx, (y - cy) / sy, (z - cz) / sz


_CENTRE, _SCALE = POSITION_CENTRE.tolist(), POSITION_SCALE.tolist()


def opponent_positions(game: Game) -> np.ndarray:
    """(N, 2, 3) each player's opponent's hips position in the player's own frame."""
    hips = game.bodies.hips_position()  # (N, 2, 3), each in its own frame
    opp = hips[:, ::-1].copy()
    opp[..., :2] *= -1.0  # the opponent's own frame turned 180 degrees about z
    return opp
