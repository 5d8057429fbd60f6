"""The arrays of a SIMPLE batch's state that its compiled steps (``rallysim.core.kernels.simple``)
read by name, in a module of their own: the structure that holds them
(``rallysim.core.kernels.simple_state``) needs their names when it is defined."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class SimpleArrays(NamedTuple):
    """Every array of the state the steps read or write ((N, P) unless said otherwise)."""

    theta: np.ndarray  # arm angles (MuJoCo's qpos)
    omega: np.ndarray  # arm rates (qvel)
    torque: np.ndarray  # arm drive (ctrl)
    mocap: np.ndarray  # (N, P, 3) world base positions (mocap_pos)
    base_x: np.ndarray  # own-frame base x
    theta0: np.ndarray  # arm angles at the start of the last physics step
    base_moved: np.ndarray  # bool: the base moved in the last physics step
    base_step: np.ndarray  # metres per physics step (the movement action)
    target: np.ndarray  # arm target angles
    neg_limit: np.ndarray  # -torque_limit
    torque_limit: np.ndarray
    fwd: np.ndarray  # own x = fwd * world x
    motion: np.ndarray  # (6, N) shuttle position and velocity
    shot_speed: np.ndarray  # (N,)
    shot_time: np.ndarray  # (N,)
    in_play: np.ndarray  # (N,) bool
    active: np.ndarray  # (N,) bool: not held by ``Game.step``'s ``active``
    armed: np.ndarray  # bool
    has_hit: np.ndarray  # bool
    last_hitter: np.ndarray  # (N,) int
    hits: np.ndarray  # (N,) int
    net_touched: np.ndarray  # (N,) bool
    q: np.ndarray  # (N, P + 2, 3) the tested points: the shuttle in each face's frame, the world
    q0: np.ndarray  # (N, P + 2, 3) scratch: ``q`` at a physics step's start
    gap: np.ndarray  # |base x - shuttle x| (own frame) for the shaping
    lo: np.ndarray  # (P + 2, 3) the tested boxes: the faces (own frames), the net, the floor
    hi: np.ndarray
