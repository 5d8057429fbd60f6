"""The SIMPLE player's observation (docs/reference.md §6-7), shared by the low-level task and the
rally.

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

import functools

import numpy as np

from rallysim.core.bodies import SimpleBodies
from rallysim.core.game import Game
from rallysim.core.kernels import simple as kernels
from rallysim.core.layout import Layout

POSITION_CENTRE = np.array([0.0, 0.0, 6.0])
POSITION_SCALE = np.array([10.0, 5.0, 6.0])
FACE_SPEED_SCALE = 8.0
SHUTTLE_SPEED_SCALE = 30.0
PLAYER_OBS = Layout((("base_position", 3), ("arm_quaternion", 4), ("face_velocity", 3),
                     ("shuttle_position", 3), ("shuttle_velocity", 3)))
PLAYER_OBS_SIZE = PLAYER_OBS.size  # 16
TARGET_DEPTH_RANGE = (2.0, 6.0)  # docs/reference.md §6/§8: goals are landing depths beyond the net


def normalise_depth(depth: np.ndarray) -> np.ndarray:
    lo, hi = TARGET_DEPTH_RANGE
    return (np.asarray(depth) - 0.5 * (lo + hi)) / (0.5 * (hi - lo))


# Each observed value's affine map, (raw - centre) / scale. Subtracting 0 and dividing by 1 are
# exact, so one map over all 16 values gives the numbers of scaling each kind on its own.
PLAYER_OBS_CENTRE = np.array((*POSITION_CENTRE.tolist(), 0.0, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0,
                              *POSITION_CENTRE.tolist(), 0.0, 0.0, 0.0))
PLAYER_OBS_SCALE = np.array((*POSITION_SCALE.tolist(), 1.0, 1.0, 1.0, 1.0,
                             *(FACE_SPEED_SCALE,) * 3, *POSITION_SCALE.tolist(),
                             *(SHUTTLE_SPEED_SCALE,) * 3))
PLAYER_OBS_CENTRE.flags.writeable = PLAYER_OBS_SCALE.flags.writeable = False


def player_observations(game: Game) -> np.ndarray:
    """(N, P, 16) float32 observations of every player, own frame, scaled and clipped into
    [-1, 1] (compiled: ``rallysim.core.kernels.simple``)."""
    return observations(game, np.zeros((game.n_envs, game.n_players, 0)), PLAYER_OBS_CENTRE,
                        PLAYER_OBS_SCALE)


def observations(game: Game, extra: np.ndarray, centre: np.ndarray, scale: np.ndarray,
                 rows: np.ndarray | None = None, out: np.ndarray | None = None) -> np.ndarray:
    """(N, P, 16 + X) float32: every player's 16 values followed by ``extra`` (N, P, X) float64,
    each mapped by (value - centre) / scale and clipped into [-1, 1] (NaN stays NaN); with
    ``rows`` (game indices) and ``out``, only those games' rows of ``out`` are written. The one
    implementation of the SIMPLE observation, for the low-level task and the rally."""
    if not isinstance(game.bodies, SimpleBodies):
        raise TypeError(f"the SIMPLE observation needs SIMPLE players, not "
                        f"{type(game.bodies).__name__}")
    return kernels.observations(game, extra, centre, scale, rows, out)


def observations_with(game: Game, extra: np.ndarray, centre: np.ndarray, scale: np.ndarray
                      ) -> np.ndarray:
    """(N, P, 16 + X) float32: every player's observation, then ``extra`` (N, P, X) mapped by
    (x - ``centre``) / ``scale``, all clipped into [-1, 1] (``PlayerSpec.observe_with``)."""
    return observations(game, extra, *_maps(np.asarray(centre, np.float64).tobytes(),
                                            np.asarray(scale, np.float64).tobytes()))


@functools.cache
def _maps(centre: bytes, scale: bytes) -> tuple[np.ndarray, np.ndarray]:
    """The player's maps followed by ``extra``'s (float64 bytes), made once, read-only as the
    low-level task's are (the compiled observation then serves both with one signature)."""
    maps = (np.concatenate((PLAYER_OBS_CENTRE, np.frombuffer(centre))),
            np.concatenate((PLAYER_OBS_SCALE, np.frombuffer(scale))))
    for m in maps:
        m.flags.writeable = False
    return maps


def opponent_positions(game: Game) -> np.ndarray:
    """(N, 2, 3) each player's opponent's base position in the player's own frame: x and z of
    the opponent's base (its own-frame x turned 180 degrees about z), y 0."""
    b = game.bodies
    opp = np.zeros((game.n_envs, 2, 3))
    opp[..., 0] = -b.base_x[:, ::-1]
    opp[..., 2] = b.base_z
    return opp
