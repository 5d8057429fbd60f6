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

from rallysim.core import humanlike_step
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
TARGET_SCALE = 5.0  # m/s: observed target = v* / 5; an option's components must lie in +-5
SHUTTLE = slice(PLAYER_OBS["shuttle_position"].start, PLAYER_OBS["shuttle_velocity"].stop)
HIPS = PLAYER_OBS["hips_position"]
RACKET = PLAYER_OBS["racket_position"]
SHUTTLE_POSITION = PLAYER_OBS["shuttle_position"]
SHUTTLE_VELOCITY = PLAYER_OBS["shuttle_velocity"]


def player_observations(game: Game) -> np.ndarray:
    """(N, P, 82) float64 observations of every HUMAN-LIKE player, own frame, scaled (not yet
    clipped), computed in one compiled loop over the players (``humanlike_step``).
    ``game.bodies`` must be ``HumanLikeBodies``."""
    b: HumanLikeBodies = game.bodies  # type: ignore[assignment]
    b._sync()
    d = b.data
    out = np.empty((game.n_envs, game.n_players, PLAYER_OBS_SIZE))
    humanlike_step.compiled_observations()[1](
        d.xpos, d.xquat, d.cvel, d.subtree_com, b._body_ids, b._hips_ids, b.hips_velocity,
        b.hips, b.torque, b._joint_max_torque, b.forward, b.hips_height, game.shuttle.pos,
        game.shuttle.vel, b._face_pos, _SCALES, out)
    return out


# ``humanlike_step``'s observation layout and maps (its ``observations``' ``s``)
_SCALES = np.array([BODY_SPEED_SCALE, BODY_RATE_SCALE, BODY_OFFSET_SCALE, SHUTTLE_SPEED_SCALE,
                    *POSITION_CENTRE, *POSITION_SCALE])
if (N_BODIES * BODY_OBS_SIZE, *(PLAYER_OBS[k].start for k in (
        "shuttle_position", "shuttle_velocity", "hips_position", "racket_position"))) != (
        70, 70, 73, 76, 79):
    raise RuntimeError("humanlike_step.observations writes another layout")


def observations_with(game: Game, extra: np.ndarray, centre: np.ndarray, scale: np.ndarray
                      ) -> np.ndarray:
    """(N, P, 82 + X) float32: every player's observation, then ``extra`` (N, P, X) mapped by
    (x - ``centre``) / ``scale``, all clipped into [-1, 1] (``PlayerSpec.observe_with``)."""
    out = np.empty((game.n_envs, game.n_players, PLAYER_OBS_SIZE + extra.shape[2]))
    out[..., :PLAYER_OBS_SIZE] = player_observations(game)
    out[..., PLAYER_OBS_SIZE:] = (extra - centre) / scale
    return np.clip(out, -1.0, 1.0).astype(np.float32)


def opponent_positions(game: Game) -> np.ndarray:
    """(N, 2, 3) each player's opponent's hips position in the player's own frame."""
    hips = game.bodies.hips_position()  # (N, 2, 3), each in its own frame
    opp = hips[:, ::-1].copy()
    opp[..., :2] *= -1.0  # the opponent's own frame turned 180 degrees about z
    return opp
