"""The physics steps of N games of SIMPLE players, compiled once for every N.

One call runs a decision's physics steps (``Game._run``) over the batch's games and players:
the bodies' drive and base (``SimpleBodies``), MuJoCo's ``mj_step`` of the one batched model,
the arm's hard stops, the shuttle's flight (``paper``, ``paper-alg1``, ``aero``:
``rallysim.core.shuttle``), the shuttle in each face's frame, the approach shaping, and the
swept box test that decides hits, net touches and landings, which are applied as the rules
say (``rallysim.core.rules``: ``record_hits``, ``record_net_touches``, ``record_landings``,
``landing_in``), events included. A game out of play, or left out by ``Game.step``'s
``active``, moves its bodies while its shuttle is held (its shot time runs on) and is not
judged.

The arithmetic is the batch's NumPy code's, operation for operation, so that every bit is as
before and environment i of a batch replays a single environment: ``np.minimum(a, b)`` is
``a if a < b else b`` and ``np.maximum(a, b)`` ``a if a > b else b`` (either gives b on a tie),
and the compiled sine and cosine are probed against NumPy's before they are used
(``native.Unavailable`` where they differ: the lanes code of ``Game`` runs instead).

The state is read by name: ``SimpleArrays`` (views of the game's and bodies' arrays, and of
MuJoCo's memory, held in one structref per game), ``SimpleEvents`` (the decision's events) and
``SimpleConstants`` (passed as one record). MuJoCo's ``mj_step`` is looked up in one place,
``_compile``.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any, NamedTuple, get_type_hints

import numpy as np

from rallysim.core import native
from rallysim.core.kernels.numpy_scalars import np_max, np_min
from rallysim.core.kernels.simple_arrays import SimpleArrays
from rallysim.core.shuttle import GRAVITY, RADIUS, AeroShuttle, PaperAlg1Shuttle, PaperShuttle

# flight models (``SimpleConstants.flight``)
PAPER, PAPER_ALG1, AERO = 0, 1, 2
FLIGHTS = {PaperShuttle: PAPER, PaperAlg1Shuttle: PAPER_ALG1, AeroShuttle: AERO}
# net rules (``SimpleConstants.net``), as ``rules.NET_RULES`` names them
NET_CODES = {"rearm": 0, "block": 1, "note": 2}
REARM, BLOCK = NET_CODES["rearm"], NET_CODES["block"]


class SimpleEvents(NamedTuple):
    """The arrays of the decision's ``Events``, in its fields' order."""

    hit: np.ndarray
    hit_speed: np.ndarray
    hit_point: np.ndarray
    hit_velocity: np.ndarray
    net_touch: np.ndarray
    landed: np.ndarray
    land_point: np.ndarray
    land_side: np.ndarray
    land_in: np.ndarray
    approach_good: np.ndarray
    approach_bad: np.ndarray


class SimpleConstants(NamedTuple):
    """The numbers of a game that do not change, each as the NumPy code computes it."""

    base_lo: float  # the base's own-frame x range
    base_hi: float
    inv_dt: float  # 1 / the bodies' dt
    max_rate: float
    drive: float  # inertia / dt
    limit: float  # the arm's hard stops
    face_offset: float
    pivot_z: float
    dt: float  # the physics step
    fall: float  # GRAVITY * dt
    factor: float  # the paper flight's damping factor per step
    flight: int  # PAPER, PAPER_ALG1 or AERO
    window: float  # paper-alg1's window, s
    aero_k: float  # aero's drag constant
    max_decay: float  # aero's largest decay per sub-step
    half_gravity: float  # 0.5 * GRAVITY
    net: int  # the net rule (NET_CODES)
    net_face: float  # net half thickness + the shuttle radius
    full_court: bool
    half_width: float
    half_length: float
    zone_near: float
    zone_far: float
    shaping: bool
    max_hits: int  # the rally hit cap; -1: none


# (the kernel takes the constants as one record: a tuple of numbers costs more per call)
_KINDS = {float: np.float64, int: np.int64, bool: np.bool_}
CONSTANTS_DTYPE = np.dtype([(name, _KINDS[kind])
                            for name, kind in get_type_hints(SimpleConstants).items()])


def as_record(numbers: SimpleConstants) -> np.ndarray:
    """``numbers`` as a (1,) record array of ``CONSTANTS_DTYPE`` (read by name in the kernel)."""
    record = np.zeros(1, CONSTANTS_DTYPE)
    for name, value in numbers._asdict().items():
        record[name] = value
    return record


def constants(game: Any) -> SimpleConstants:
    """``game``'s constants (its bodies are ``SimpleBodies``)."""
    b, flight, court = game.bodies, game.flight, game.court
    dt = game.dt
    kind = FLIGHTS[type(flight)]
    lo, hi = b.base_range
    return SimpleConstants(
        base_lo=float(lo), base_hi=float(hi), inv_dt=1.0 / b.dt, max_rate=float(b.max_rate),
        drive=b.inertia / b.dt, limit=float(b.limit), face_offset=float(b.face_offset),
        pivot_z=float(b.pivot_z), dt=dt, fall=GRAVITY * dt,
        factor=float(getattr(flight, "factor", 0.0)), flight=kind,
        window=float(PaperAlg1Shuttle.window), aero_k=float(getattr(flight, "k", 0.0)),
        max_decay=float(AeroShuttle.max_decay_per_substep), half_gravity=0.5 * GRAVITY,
        net=NET_CODES[game.rules.net], net_face=court.net_half_thickness + RADIUS,
        full_court=bool(game.rules.full_court), half_width=float(court.half_width),
        half_length=float(court.half_length), zone_near=float(court.paper_zone_near),
        zone_far=float(court.paper_zone_far), shaping=bool(game.shaping),
        max_hits=-1 if game.max_hits is None else int(game.max_hits))


def arrays(game: Any) -> SimpleArrays:
    """Views of ``game``'s arrays (made anew in a copy of the game: some are MuJoCo's)."""
    b, sh, st = game.bodies, game.shuttle, game.state
    return SimpleArrays(
        theta=b.theta, omega=b.omega, torque=b.torque, mocap=b.mocap, base_x=b.base_x,
        theta0=b._theta0, base_moved=b.base_moved, base_step=b._base_step, target=b.target,
        neg_limit=b._neg_limit, torque_limit=b.torque_limit, fwd=b.forward, motion=sh.motion,
        shot_speed=sh.shot_speed, shot_time=sh.shot_time, in_play=st.in_play,
        active=game._active, armed=st.armed, has_hit=st.has_hit, last_hitter=st.last_hitter,
        hits=st.hits, net_touched=st.net_touched, q=game._q, q0=np.empty_like(game._q),
        gap=game._gap, lo=game._lo, hi=game._hi)


def fits(game: Any) -> bool:
    """Whether this kernel runs ``game``'s steps: SIMPLE bodies (not a subclass, which may
    change their motion) with one of the flight models it knows."""
    from rallysim.core.bodies import SimpleBodies  # (bodies imports rules, which is light)

    return type(game.bodies) is SimpleBodies and type(game.flight) in FLIGHTS


def _steps_with(njit: Callable, mj_step: Callable, sin: Callable, cos: Callable
                ) -> tuple[Callable, Callable]:
    """The compiled steps and ``refresh``, calling MuJoCo's ``mj_step`` (of model and data
    addresses) and the probed sine and cosine. The helpers are inlined where they are called,
    and those run per game take only the arrays they use: a call that takes the state's tuple
    of arrays would count a reference to each of them."""
    inline = njit(inline="always")

    lower, upper = inline(np_max), inline(np_min)

    @inline
    def clip(a, lo, hi):
        return upper(lower(a, lo), hi)  # np.minimum(np.maximum(a, lo), hi)

    @inline
    def drive_bodies(a, k, n, p):
        """``SimpleBodies.step_lanes`` before MuJoCo's step: the base slides, the arm's drive
        torque is set (the rate that reaches the target within the step, capped, then
        torque-limited)."""
        for e in range(n):
            for j in range(p):
                theta = a.theta[e, j]
                a.theta0[e, j] = theta
                old = a.base_x[e, j]
                x = clip(old + a.base_step[e, j], k.base_lo, k.base_hi)
                a.base_moved[e, j] = x != old
                a.base_x[e, j] = x
                a.mocap[e, j, 0] = a.fwd[e, j] * x
                w = clip((a.target[e, j] - theta) * k.inv_dt, -k.max_rate, k.max_rate)
                w = (w - a.omega[e, j]) * k.drive
                a.torque[e, j] = clip(w, a.neg_limit[e, j], a.torque_limit[e, j])

    @inline
    def hard_stops(a, k, n, p):
        """The arm's hard stops (the drive can overshoot its target when its torque is low)."""
        for e in range(n):
            for j in range(p):
                theta = a.theta[e, j]
                if abs(theta) > k.limit:
                    a.theta[e, j] = clip(theta, -k.limit, k.limit)
                    a.omega[e, j] = 0.0

    @inline
    def substeps(a, k, n):
        """aero's sub-steps this step: from the fastest shuttle of the whole batch (held ones
        too), as ``AeroShuttle.fly`` takes them."""
        if k.flight != AERO:
            return 1
        largest = 0.0
        m = a.motion
        for e in range(n):
            vx, vy, vz = m[3, e], m[4, e], m[5, e]
            s = (vx * vx + vz * vz) + vy * vy
            if e == 0 or s > largest or s != s:
                largest = s
        count = math.ceil(k.aero_k * math.sqrt(largest) * k.dt / k.max_decay)
        return max(1, count)

    @inline
    def fly(m, shot_time_a, shot_speed_a, k, e, count):
        """One game's shuttle (``m``: the motion) through one physics step
        (``ShuttleModel.fly``)."""
        px, py, pz, vx, vy, vz = m[0, e], m[1, e], m[2, e], m[3, e], m[4, e], m[5, e]
        dt = k.dt
        if k.flight == AERO:
            h = dt / count
            half = k.half_gravity * h
            for _ in range(count):
                vz -= half
                d = 1.0 + h * k.aero_k * math.sqrt((vx * vx + vz * vz) + vy * vy)
                vx /= d
                vy /= d
                vz /= d
                vz -= half
                px += vx * h
                py += vy * h
                pz += vz * h
            shot_time = shot_time_a[e] + dt
        else:
            vz -= k.fall
            f = k.factor
            vx *= f
            vy *= f
            vz *= f
            px += vx * dt
            py += vy * dt
            pz += vz * dt
            shot_time = shot_time_a[e] + dt
            if k.flight == PAPER_ALG1 and shot_time < k.window:
                # the speed forced to s0 (1 - t), direction kept
                speed = math.sqrt((vx * vx + vy * vy) + vz * vz)
                target = shot_speed_a[e] * (1.0 - shot_time)
                r = target / speed if speed > 0 else 0.0
                vx *= r
                vy *= r
                vz *= r
        shot_time_a[e] = shot_time
        m[0, e], m[1, e], m[2, e], m[3, e], m[4, e], m[5, e] = px, py, pz, vx, vy, vz

    @inline
    def observe(q, m, fwd, theta_a, base_x, k, e, p):
        """``Game._observe`` of one game: the shuttle (``m``: the motion) in each face's frame
        (normal, across, along the arm) and in the world, into the tested points ``q``."""
        px, py, pz = m[0, e], m[1, e], m[2, e]
        fo = k.face_offset
        for j in range(p):
            f = fwd[e, j]
            theta = theta_a[e, j]
            s, c = sin(theta), cos(theta)
            dx = f * px - base_x[e, j] - fo * s
            dz = pz - k.pivot_z - fo * c
            q[e, j, 0] = dx * c - dz * s
            q[e, j, 1] = f * py
            q[e, j, 2] = dx * s + dz * c
        for c in range(p, p + 2):
            q[e, c, 0], q[e, c, 1], q[e, c, 2] = px, py, pz

    @inline
    def entry(q0, q, lo, hi, e, c):
        """``rules.segment_box_entry`` of column ``c`` of game ``e``, from ``q0`` to ``q``
        against the box [lo[c], hi[c]]: (met, t)."""
        n0 = n1 = n2 = f0 = f1 = f2 = 0.0
        for axis in range(3):
            x0 = q0[e, c, axis]
            d = q[e, c, axis] - x0
            if abs(d) < 1e-12:
                d = 1e-12 if d >= 0.0 else -1e-12
            inv = 1.0 / d
            ta = (lo[c, axis] - x0) * inv
            tb = (hi[c, axis] - x0) * inv
            near = ta if ta < tb else tb
            far = ta if ta > tb else tb
            if axis == 0:
                n0, f0 = near, far
            elif axis == 1:
                n1, f1 = near, far
            else:
                n2, f2 = near, far
        m01 = n0 if n0 > n1 else n1
        m2 = n2 if n2 > 0.0 else 0.0
        t_enter = m01 if m01 > m2 else m2
        f01 = f0 if f0 < f1 else f1
        t_exit = f01 if f01 < f2 else f2
        return (t_enter <= t_exit) and (t_enter <= 1.0), t_enter

    @inline
    def below_cap(hits, k, e):
        return k.max_hits < 0 or hits[e] < k.max_hits

    @inline
    def apply_hit(a, ev, k, e, j, t, p):
        """``Game._apply_hits`` of player ``j`` of game ``e`` at fraction ``t`` of the step:
        the shuttle leaves at twice the face centre's velocity from the point of contact;
        ``rules.record_hits``."""
        th0 = a.theta0[e, j]
        th = th0 + t * (a.theta[e, j] - th0)
        w = a.omega[e, j]
        fo = k.face_offset
        rx, ry, rz = fo * w * cos(th), 0.0, -fo * w * sin(th)  # the racket, own frame
        f = a.fwd[e, j]
        vx, vy, vz = 2.0 * rx * f, 2.0 * ry * f, 2.0 * rz
        m = a.motion
        for axis, v in ((0, vx), (1, vy), (2, vz)):
            start = a.q0[e, p, axis]
            at = start + t * (m[axis, e] - start)
            m[3 + axis, e] = v
            m[axis, e] = at + v * (1.0 - t) * k.dt
            ev.hit_point[e, j, axis] = at
        a.shot_speed[e] = math.sqrt((vx * vx + vy * vy) + vz * vz)
        a.shot_time[e] = 0.0
        ev.hit[e, j] = True
        ev.hit_speed[e, j] = math.sqrt((rx * rx + ry * ry) + rz * rz)
        ev.hit_velocity[e, j, 0], ev.hit_velocity[e, j, 1] = rx, ry
        ev.hit_velocity[e, j, 2] = rz
        a.has_hit[e, j] = True
        a.armed[e, j] = False
        if p == 2:
            a.armed[e, 1 - j] = True
        a.last_hitter[e] = j
        a.hits[e] += 1
        a.net_touched[e] = False

    @inline
    def apply_net(a, ev, k, e, t, p):
        """``Game._apply_net`` of game ``e`` (``rules.record_net_touches``); a blocking net
        stops a shuttle moving into it against the face it reached."""
        if not a.net_touched[e]:
            ev.net_touch[e] = True
            if k.net == REARM:
                for j in range(p):
                    a.armed[e, j] = True
        a.net_touched[e] = True
        if k.net == BLOCK:
            m = a.motion
            x0 = a.q0[e, p, 0]
            side = -1.0 if x0 < 0 else 1.0
            if side * (m[0, e] - x0) < 0:
                for axis in range(3):
                    start = a.q0[e, p, axis]
                    m[axis, e] = start + t * (m[axis, e] - start)
                m[0, e] = side * k.net_face
                m[3, e] = 0.0
            observe(a.q, m, a.fwd, a.theta, a.base_x, k, e, p)

    @inline
    def land(a, ev, k, e, t, p):
        """``Game._land`` of game ``e``: the point, side and in/out; ``rules.record_landings``;
        the shuttle stops."""
        m = a.motion
        x0, y0 = a.q0[e, p, 0], a.q0[e, p, 1]
        x = x0 + t * (m[0, e] - x0)
        y = y0 + t * (m[1, e] - y0)
        ev.landed[e] = True
        ev.land_point[e, 0], ev.land_point[e, 1], ev.land_point[e, 2] = x, y, 0.0
        ev.land_side[e] = 1 if x > 0 else 0
        depth = abs(x)
        inside = abs(y) <= k.half_width
        if k.full_court:
            inside = inside and depth > 0.0 and depth <= k.half_length
        else:
            inside = inside and depth >= k.zone_near and depth <= k.zone_far
        ev.land_in[e] = inside
        a.in_play[e] = False
        for j in range(p):
            a.armed[e, j] = False
        m[3, e] = 0.0
        m[4, e] = 0.0
        m[5, e] = 0.0

    @njit
    def judge_contacts(a, ev, k, e, p, hitter, t_hit):
        """What a game's contacts do (``Game._judge``, after the swept test found some): a
        hit by ``hitter`` at ``t_hit`` (none: -1), after which the net and the floor are tested
        again from the step's start to the shuttle's new place; then the net and the floor.
        A hit that reaches the cap ends the judging of the rally. (Rare: not inlined.)"""
        if hitter >= 0:
            apply_hit(a, ev, k, e, hitter, t_hit, p)
            observe(a.q, a.motion, a.fwd, a.theta, a.base_x, k, e, p)
            if not below_cap(a.hits, k, e):
                return
        touched, t_net = entry(a.q0, a.q, a.lo, a.hi, e, p)
        landed, t_floor = entry(a.q0, a.q, a.lo, a.hi, e, p + 1)
        if touched:
            apply_net(a, ev, k, e, t_net, p)
        if landed:
            land(a, ev, k, e, t_floor, p)

    @inline
    def step(model, data, a, ev, k, n, p):
        """One physics step of the batch (``Game._step_lanes``)."""
        m, q, q0, lo, hi = a.motion, a.q, a.q0, a.lo, a.hi
        fwd, theta, base_x, armed = a.fwd, a.theta, a.base_x, a.armed
        shot_time, shot_speed, in_play, active = a.shot_time, a.shot_speed, a.in_play, a.active
        has_hit, moved, gaps, hits = a.has_hit, a.base_moved, a.gap, a.hits
        good_a, bad_a = ev.approach_good, ev.approach_bad
        for e in range(n):  # the points the swept test starts from
            for c in range(p):
                for axis in range(3):
                    q0[e, c, axis] = q[e, c, axis]
            for c in range(p, p + 2):
                for axis in range(3):
                    q0[e, c, axis] = m[axis, e]
        drive_bodies(a, k, n, p)
        mj_step(model, data)
        hard_stops(a, k, n, p)
        count = substeps(a, k, n)
        for e in range(n):
            live = in_play[e] and active[e]
            if live:
                fly(m, shot_time, shot_speed, k, e, count)
            else:  # a held shuttle stays put (its shot time runs on) until its env is reset
                px, py, pz, vx, vy, vz = m[0, e], m[1, e], m[2, e], m[3, e], m[4, e], m[5, e]
                fly(m, shot_time, shot_speed, k, e, count)
                m[0, e], m[1, e], m[2, e], m[3, e], m[4, e], m[5, e] = px, py, pz, vx, vy, vz
            observe(q, m, fwd, theta, base_x, k, e, p)
            if k.shaping:  # the steps each base closed in on the shuttle before a first hit
                px = m[0, e]
                for j in range(p):
                    gap = abs(fwd[e, j] * px - base_x[e, j])
                    todo = live and not has_hit[e, j]
                    good = moved[e, j] and gap < gaps[e, j] and todo
                    good_a[e, j] += good
                    bad_a[e, j] += todo and not good
                    gaps[e, j] = gap
            if not (live and below_cap(hits, k, e)):
                continue
            # the swept test: the first armed player met hits; the net; the floor
            hitter, t_hit = -1, 0.0
            for j in range(p):
                met, t = entry(q0, q, lo, hi, e, j)
                if met and armed[e, j]:
                    hitter, t_hit = j, t
                    break
            if hitter >= 0:
                judge_contacts(a, ev, k, e, p, hitter, t_hit)
                continue
            touched, _ = entry(q0, q, lo, hi, e, p)
            landed, _ = entry(q0, q, lo, hi, e, p + 1)
            if touched or landed:
                judge_contacts(a, ev, k, e, p, -1, 0.0)

    @njit
    def steps_of(model, data, a, events, constants, steps):
        """``steps`` physics steps of the batch, from and to its arrays (``events``: the
        arrays of ``SimpleEvents``, as a plain tuple, which costs a call less; ``constants``:
        a record of ``CONSTANTS_DTYPE``)."""
        ev = SimpleEvents(*events)
        k = constants[0]
        n, p = a.theta.shape
        for _ in range(steps):
            step(model, data, a, ev, k, n, p)

    @njit
    def refresh(a, constants):
        """What the next physics step starts from, after the state was set by hand
        (``Game._refresh``): the shuttle in each face's frame and the shaping's gaps."""
        k = constants[0]
        n, p = a.theta.shape
        m, fwd, base_x = a.motion, a.fwd, a.base_x
        for e in range(n):
            observe(a.q, m, fwd, a.theta, base_x, k, e, p)
            for j in range(p):
                a.gap[e, j] = abs(fwd[e, j] * m[0, e] - base_x[e, j])

    return steps_of, refresh


def _observation_with(njit: Callable, sin: Callable, cos: Callable) -> Callable:
    """Player 0's scaled observation in each of N games, compiled: the 16 values of
    ``simple_obs.raw_observation_lanes``, then ``extra[e]``, each mapped by
    ``ArrayOps.observations`` ((x - centre) / scale, clipped into [-1, 1] as ``np.clip`` clips:
    NaN stays NaN), as float32 (N, 17)."""

    # (NumPy's error model: a zero scale gives inf or NaN, as the arrays do)
    @njit(error_model="numpy")
    def observation(theta_a, omega_a, base_x, fwd, m, extra, base_z, fo, centre, scale):
        n = theta_a.shape[0]
        size = 17
        if centre.size != size or scale.size != size:
            raise ValueError("the observation's maps must have one entry per value")
        raw = np.empty(size)
        out = np.empty((n, size), np.float32)
        for e in range(n):
            theta, omega, f = theta_a[e, 0], omega_a[e, 0], fwd[e, 0]
            s, c = sin(theta), cos(theta)
            half = 0.5 * theta
            raw[0], raw[1], raw[2] = base_x[e, 0], 0.0, base_z
            raw[3], raw[4], raw[5], raw[6] = cos(half), 0.0, sin(half), 0.0
            raw[7], raw[8], raw[9] = fo * omega * c, 0.0, -fo * omega * s
            raw[10], raw[11], raw[12] = f * m[0, e], f * m[1, e], m[2, e]
            raw[13], raw[14], raw[15] = f * m[3, e], f * m[4, e], m[5, e]
            raw[16] = extra[e]
            for i in range(size):
                x = (raw[i] - centre[i]) / scale[i]
                if x < -1.0:
                    x = -1.0
                if x > 1.0:
                    x = 1.0
                out[e, i] = x
        return out

    return observation


class Kernels(NamedTuple):
    """The compiled functions of SIMPLE games."""

    state: Callable  # ``simple_state.make``

    steps: Callable  # ``_steps_with``'s
    refresh: Callable  # ``_steps_with``'s
    observation: Callable  # ``_observation_with``'s


def _compile() -> Kernels:
    """The steps compiled by Numba, calling MuJoCo's C ``mj_step``; ``native.Unavailable``
    where Numba or MuJoCo's library is missing, or where the compiled sine or cosine differ
    from NumPy's on a probe of angles."""
    numba = native.numba_module()
    (mj_step,) = native.mujoco_functions("mj_step")
    sin = numba.njit(lambda x: np.sin(x))
    cos = numba.njit(lambda x: np.cos(x))

    @native.jit  # (cached, as the kernels: the probe runs in every process)
    def sines(angles):
        out = np.empty((2, angles.size))
        for i in range(angles.size):
            out[0, i], out[1, i] = sin(angles[i]), cos(angles[i])
        return out

    # whole turns of the arm, densely, then angles well beyond its stops
    angles = np.concatenate([np.linspace(-4.0, 4.0, 200_001),
                             np.random.default_rng(0).uniform(-40.0, 40.0, 100_000)])
    if sines(angles).tobytes() != np.stack([np.sin(angles), np.cos(angles)]).tobytes():
        raise native.Unavailable("Numba's sine or cosine differ from NumPy's on this machine")
    steps, refresh = _steps_with(numba.njit, mj_step, sin, cos)
    observation = _observation_with(numba.njit, sin, cos)
    # the functions called from Python, cached across processes (``native.jit``)
    from rallysim.core.kernels import simple_state  # (imports Numba)

    kernels = Kernels(simple_state.make, native.jit(steps.py_func),
                      native.jit(refresh.py_func),
                      native.jit(observation.py_func, error_model="numpy"))
    _dry_run(kernels)
    return kernels


def _dry_run(kernels: Kernels) -> None:
    """Compile the functions now, for arrays of the types a game's are (the observation's maps
    read-only, as the tasks' are), by calls that run no physics step (so that a failure shows
    here, where the lanes code can take over)."""
    f, b, i = np.zeros((1, 1)), np.zeros((1, 1), bool), np.zeros((1, 1), np.int64)
    f1, b1, i1 = np.zeros(1), np.zeros(1, bool), np.zeros(1, np.int64)
    f3, q, box = np.zeros((1, 1, 3)), np.zeros((1, 3, 3)), np.zeros((3, 3))
    arrays = SimpleArrays(f, f, f, f3, f, f, b, f, f, f, f, f, np.zeros((6, 1)), f1, f1, b1,
                          b1, b, b, i1, i1, b1, q, q, f, box, box)
    state = kernels.state(arrays)
    events = (b, f, f3, f3, b1, b1, np.zeros((1, 3)), i1, b1, i, i)
    kernels.steps(0, 0, state, events, np.zeros(1, CONSTANTS_DTYPE), 0)
    kernels.refresh(kernels.state(arrays._replace(theta=np.zeros((0, 1)))),
                    np.zeros(1, CONSTANTS_DTYPE))
    maps = np.ones(17)
    maps.flags.writeable = False
    kernels.observation(f, f, f, f, np.zeros((6, 1)), f1, 0.0, 0.0, maps, maps)


# this process's compiled steps, made on first use
Compiled = native.Kernel(lambda: _compile())


class SimpleKernel:
    """The compiled steps of one game object (``Game``): its constants, and its arrays' views
    (made on first use, and anew in a copy: ``Game.__getstate__``)."""

    def __init__(self, game: Any, kernel: str | None = None) -> None:
        self.asked = native.checked_kernel_name(kernel)
        if self.asked == "compiled":
            Compiled.resolve("compiled")  # refused here, not at the first step
        self._set_constants(game)
        self._arrays: Any = None  # ``Kernels.state`` of the game's ``arrays``
        self._addresses = (0, 0)  # its MuJoCo model's and data's (made with ``_arrays``)

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_arrays": None, "_addresses": (0, 0)}

    def _set_constants(self, game: Any) -> None:
        self.constants = constants(game)
        self._record = as_record(self.constants)
        # (a game's shaping and hit cap are attributes that may be set between decisions)
        self._settings = (game.shaping, game.max_hits)

    def functions(self) -> Kernels | None:
        """The compiled functions if they run here (None: the lanes code runs)."""
        return Compiled.resolve(self.asked)

    @property
    def kernel(self) -> str:
        return "python" if self.functions() is None else "compiled"

    def _state(self, game: Any, kernels: Kernels) -> Any:
        if self._arrays is None:
            self._arrays = kernels.state(arrays(game))
            b = game.bodies
            self._addresses = b.model._address, b.data._address
        return self._arrays

    def observation(self, game: Any, extra: np.ndarray, centre: np.ndarray,
                    scale: np.ndarray) -> np.ndarray | None:
        """Player 0's observations followed by ``extra`` (N,), scaled and clipped
        (``_observation_with``), where the compiled functions run and each game has one
        player; else None (the caller's lanes code gives the same bits)."""
        kernels = self.functions()
        if kernels is None or game.n_players != 1:
            return None
        b = game.bodies
        # (only the arrays it reads: each array passed costs the call some time)
        return kernels.observation(b.theta, b.omega, b.base_x, b.forward, game.shuttle.motion,
                                   extra, b.base_z, b.face_offset, centre, scale)

    def refresh(self, game: Any) -> bool:
        """``Game._refresh`` compiled; False where it cannot run here (nothing was done)."""
        kernels = self.functions()
        if kernels is None:
            return False
        kernels.refresh(self._state(game, kernels), self._record)
        return True

    def run(self, game: Any, steps: int) -> bool:
        """``steps`` physics steps of ``game``; False where the compiled steps cannot run
        here (nothing was done)."""
        kernels = self.functions()
        if kernels is None:
            return False
        if (game.shaping, game.max_hits) != self._settings:
            self._set_constants(game)
        ev = game.events
        state = self._state(game, kernels)
        model, data = self._addresses
        kernels.steps(model, data, state,
                      (ev.hit, ev.hit_speed, ev.hit_point, ev.hit_velocity, ev.net_touch,
                       ev.landed, ev.land_point, ev.land_side, ev.land_in, ev.approach_good,
                       ev.approach_bad), self._record, steps)
        return True
