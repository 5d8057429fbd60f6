"""The arrays of a batch's state that its compiled steps (``rallysim.core.kernels.step``) read
by name, one named tuple per player kind, in a module of their own: the structures that hold
them (``rallysim.core.kernels.state``) need their names when they are defined.

Every kind's arrays begin with the same fields (those the shared steps read), in the same
order; its own follow."""

from __future__ import annotations

from typing import NamedTuple

import numpy as np


class SimpleArrays(NamedTuple):
    """Every array of a SIMPLE batch's state the steps read or write ((N, P) unless said
    otherwise)."""

    # -- read by the shared steps
    fwd: np.ndarray  # own x = fwd * world x
    base_x: np.ndarray  # own-frame base x
    base_moved: np.ndarray  # bool: the base moved in the last physics step
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
    gap: np.ndarray  # |base x - shuttle x| (own frame) after the last physics step
    lo: np.ndarray  # (P + 2, 3) the tested boxes: the faces (own frames), the net, the floor
    hi: np.ndarray
    trace_gap: np.ndarray  # ``GameTrace``'s arrays, written every physics step
    trace_moved: np.ndarray
    trace_live: np.ndarray
    trace_has_hit: np.ndarray
    # -- SIMPLE's own
    theta: np.ndarray  # arm angles (MuJoCo's qpos)
    omega: np.ndarray  # arm rates (qvel)
    torque: np.ndarray  # arm drive (ctrl)
    mocap: np.ndarray  # (N, P, 3) world base positions (mocap_pos)
    theta0: np.ndarray  # arm angles at the start of the last physics step
    base_step: np.ndarray  # metres per physics step (the movement action)
    target: np.ndarray  # arm target angles
    neg_limit: np.ndarray  # -torque_limit
    torque_limit: np.ndarray


class HumanLikeArrays(NamedTuple):
    """Every array of a HUMAN-LIKE batch's state the steps read or write
    (``HumanLikeBodies``; (N, P, ...) unless said otherwise)."""

    # -- read by the shared steps (as in ``SimpleArrays``)
    fwd: np.ndarray
    base_x: np.ndarray  # (a view of the hips' x)
    base_moved: np.ndarray
    motion: np.ndarray
    shot_speed: np.ndarray
    shot_time: np.ndarray
    in_play: np.ndarray
    active: np.ndarray
    armed: np.ndarray
    has_hit: np.ndarray
    last_hitter: np.ndarray
    hits: np.ndarray
    net_touched: np.ndarray
    q: np.ndarray
    q0: np.ndarray
    gap: np.ndarray
    lo: np.ndarray
    hi: np.ndarray
    trace_gap: np.ndarray
    trace_moved: np.ndarray
    trace_live: np.ndarray
    trace_has_hit: np.ndarray
    # -- HUMAN-LIKE's own (``rallysim.core.humanlike_step``'s physics step)
    mass: np.ndarray  # MuJoCo's sparse joint-space inertia (data.M)
    m_index: np.ndarray  # (N, P, 8, 8) indices into it
    qpos: np.ndarray  # (N, P, 8)
    qvel: np.ndarray
    ctrl: np.ndarray
    bias: np.ndarray
    target: np.ndarray
    torque_limit: np.ndarray
    side: np.ndarray  # (N, P, 8) int8: servos saturated at +-limit
    face0: np.ndarray  # (N, P, 3) world face centre at the last step's start
    face: np.ndarray  # (N, P, 3) world face centre (MuJoCo's site_xpos)
    mat: np.ndarray  # (N, P, 3, 3) the face site's rotation (site_xmat)
    hips: np.ndarray  # (N, P, 2) own-frame hips x, y
    hips_step: np.ndarray
    hips_velocity: np.ndarray
    mocap: np.ndarray
    body_constants: np.ndarray  # ``HumanLikeBodies._constants``
