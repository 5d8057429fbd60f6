"""The SIMPLE player's observation (SPEC §6-7), shared by the low-level task and the rally.

Every value is in the observing player's own frame and scaled to [-1, 1] by a fixed affine map
(then clipped, so observations always lie in the declared bounds). The 16 values:

| index | value | raw range mapped to [-1, 1] |
|---|---|---|
| 0-2 | base centre position x, y, z | x, y in [-10, 10], [-5, 5] m; z in [0, 12] m |
| 3-6 | arm orientation quaternion w, x, y, z | unit quaternion, as is |
| 7-9 | racket face centre velocity | [-8, 8] m/s (the face tops out at 7.42 m/s) |
| 10-12 | shuttle position | as the base position |
| 13-15 | shuttle velocity | [-30, 30] m/s (serves reach 27.5 m/s) |

Positions share one map so that a policy can compare the base and the shuttle directly.
"""

from __future__ import annotations

import numpy as np

from rallysim.core.game import Game

POSITION_CENTRE = np.array([0.0, 0.0, 6.0])
POSITION_SCALE = np.array([10.0, 5.0, 6.0])
FACE_SPEED_SCALE = 8.0
SHUTTLE_SPEED_SCALE = 30.0
PLAYER_OBS_SIZE = 16
TARGET_DEPTH_RANGE = (2.0, 6.0)  # SPEC §6/§8: goals are landing depths beyond the net


def normalise_position(p: np.ndarray) -> np.ndarray:
    return (p - POSITION_CENTRE) / POSITION_SCALE


def depth_from_action(action: np.ndarray) -> np.ndarray:
    """A high level's action a in [-1, 1] (clipped) -> the goal depth 4 + 2a metres (M,), the
    original's mapping."""
    return 4.0 + 2.0 * np.clip(np.asarray(action).reshape(-1), -1.0, 1.0)


def normalise_depth(depth: np.ndarray) -> np.ndarray:
    lo, hi = TARGET_DEPTH_RANGE
    return (np.asarray(depth) - 0.5 * (lo + hi)) / (0.5 * (hi - lo))


def player_observations(game: Game) -> np.ndarray:
    """(N, P, 16) float64 observations of every player, own frame, scaled (not yet clipped)."""
    b, sh = game.bodies, game.shuttle
    n, p = game.n_envs, game.n_players
    out = np.empty((n, p, PLAYER_OBS_SIZE))
    base = np.zeros((n, p, 3))
    base[..., 0] = b.base_x
    base[..., 2] = b.base_z
    out[..., 0:3] = normalise_position(base)
    out[..., 3:7] = b.arm_quaternion()
    out[..., 7:10] = b.face_velocity() / FACE_SPEED_SCALE
    fwd = b.forward[..., None]
    flip = np.array([1.0, 1.0, 0.0])  # x and y change sign in player 1's frame, z does not
    own_pos = sh.pos[:, None, :] * (1.0 - flip + flip * fwd)
    own_vel = sh.vel[:, None, :] * (1.0 - flip + flip * fwd)
    out[..., 10:13] = normalise_position(own_pos)
    out[..., 13:16] = own_vel / SHUTTLE_SPEED_SCALE
    return out
