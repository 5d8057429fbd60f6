"""The physics steps of N games, written once for every player kind and batch size, compiled.

One call runs a decision's physics steps (``Game._run``) over the batch's games and players:
the players' motion around MuJoCo's step of the one batched model (each kind's own: SIMPLE in
``rallysim.core.kernels.simple``, HUMAN-LIKE in ``rallysim.core.kernels.humanlike``), the
shuttle's flight (``paper``, ``paper-alg1``, ``aero``: ``rallysim.core.shuttle``), the shuttle in
each face's frame, and the swept box test that decides hits, net touches and landings, which
are applied as the rules say, events included; and the trace a task may read of each physics
step (``GameTrace``). A game out of play, or left out by ``Game.step``'s ``active``, moves its
bodies while its shuttle is held (its shot time runs on) and is not judged.

A player kind gives four compiled pieces (``Pieces``): its motion, the face's frame, the racket's
velocity at a hit and the shot that velocity makes. Everything else is here, once.

The arithmetic is NumPy's for these formulas, operation for operation, so that the bits do not
depend on the batch size: environment i of a batch replays a single environment seeded s + i.
The state is read by name: the kind's arrays (held in one structref per game,
``rallysim.core.kernels.state``), ``GameEvents`` (the decision's events) and ``GameConstants``
(one record).
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple, get_type_hints

import numpy as np

from rallysim.core import native
from rallysim.core.kernels.numpy_scalars import norm3
from rallysim.core.shuttle import (
    FLIGHT_FIELDS,
    RADIUS,
    AeroShuttle,
    PaperAlg1Shuttle,
    PaperShuttle,
    flight_with,
)
from rallysim.core.state import SERVE

# the flight models the steps fly (``ShuttleModel.code``)
FLIGHTS = (PaperShuttle, PaperAlg1Shuttle, AeroShuttle)
# net rules (``GameConstants.net``), as ``rules.NET_RULES`` names them
NET_CODES = {"rearm": 0, "block": 1, "note": 2}
REARM, BLOCK = NET_CODES["rearm"], NET_CODES["block"]


class GameEvents(NamedTuple):
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


class GameTrace(NamedTuple):
    """What a task may need of every physics step of a decision, besides its events (the
    low-level task's approach shaping reads it): rows are the decision's physics steps."""

    gap: np.ndarray  # (S + 1, N, P) own-frame |shuttle x - base x|: at the start, after each
    moved: np.ndarray  # (S, N, P) bool: the base moved in the step
    live: np.ndarray  # (S, N) bool: in play and not held (judged) in the step
    has_hit: np.ndarray  # (S, N, P) bool: the player had hit in this rally before the step's
    # judging


class GameConstants(NamedTuple):
    """The numbers of a game that do not change, each as the NumPy code computes it. The
    bodies' own are those of SIMPLE players (``rallysim.core.kernels.simple``); a HUMAN-LIKE
    game reads only ``inv_dt`` of them (its others are in its arrays)."""

    # the flight's (``shuttle.FLIGHT_FIELDS``)
    dt: float  # the physics step
    fall: float  # GRAVITY * dt
    factor: float  # the paper flight's damping factor per step
    flight: int  # ``ShuttleModel.code``
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
    max_hits: int  # the rally hit cap; -1: none
    inv_dt: float  # 1 / the bodies' dt
    base_lo: float  # SIMPLE: the base's own-frame x range
    base_hi: float
    max_rate: float
    drive: float  # inertia / dt
    limit: float  # the arm's hard stops
    face_offset: float
    pivot_z: float
    shot_factor: float  # a hit's shuttle velocity / the face's


# (the kernel takes the constants as one record: a tuple of numbers costs more per call)
_KINDS = {float: np.float64, int: np.int64, bool: np.bool_}
CONSTANTS_DTYPE = np.dtype([(name, _KINDS[kind])
                            for name, kind in get_type_hints(GameConstants).items()])
assert GameConstants._fields[:len(FLIGHT_FIELDS)] == FLIGHT_FIELDS


def constants(game: Any, **body: float) -> np.ndarray:
    """``game``'s constants, with the bodies' own ``body`` (the rest 0), as a (1,) record
    array of ``CONSTANTS_DTYPE`` (read by name in the kernel)."""
    flight, court, dt = game.flight, game.court, game.dt
    numbers = dict.fromkeys(GameConstants._fields, 0.0)
    numbers.update(flight.numbers(dt))
    numbers.update(
        net=NET_CODES[game.rules.net], net_face=court.net_half_thickness + RADIUS,
        full_court=bool(game.rules.full_court), half_width=float(court.half_width),
        half_length=float(court.half_length), zone_near=float(court.paper_zone_near),
        zone_far=float(court.paper_zone_far),
        max_hits=-1 if game.max_hits is None else int(game.max_hits), inv_dt=1.0 / game.bodies.dt,
        **body)
    record = np.zeros(1, CONSTANTS_DTYPE)
    for name, value in numbers.items():
        record[name] = value
    return record


class Pieces(NamedTuple):
    """What a player kind gives the steps, each compiled to be inlined:

    - ``move(model, data, a, k, n, p)``: every player's motion through one physics step,
      MuJoCo's step of the whole model included;
    - ``face_point(a, k, e, j, x, y, z)``: the own-frame point (x, y, z) in the frame of
      player j's face (the box of ``lo[j]``, ``hi[j]``), as (x, y, z);
    - ``racket(a, k, e, j, t)``: the own-frame velocity of that face at fraction t of the step;
    - ``shot(k, x, y, z)``: the own-frame velocity a shuttle leaves at, hit by a face moving
      so.
    """

    move: Callable
    face_point: Callable
    racket: Callable
    shot: Callable


def steps_with(njit: Callable, pieces: Pieces) -> tuple[Callable, Callable, Callable]:
    """The compiled steps, ``refresh`` and ``restart`` of games of the kind of ``pieces``. The
    helpers are inlined where they are called, and those run per game take only the arrays
    they use."""
    inline = njit(inline="always")
    speed = inline(norm3)
    move, face_point, racket, shot = pieces
    substeps, fly = flight_with(njit)

    @inline
    def observe(a, k, e, p):
        """The shuttle in each face's frame and in the world, into the tested points ``q``."""
        m, q = a.motion, a.q
        px, py, pz = m[0, e], m[1, e], m[2, e]
        for j in range(p):
            f = a.fwd[e, j]
            q[e, j, 0], q[e, j, 1], q[e, j, 2] = face_point(a, k, e, j, f * px, f * py, pz)
        for c in range(p, p + 2):
            q[e, c, 0], q[e, c, 1], q[e, c, 2] = px, py, pz

    @inline
    def start_from(a, k, e, p):
        """What game ``e``'s next physics step starts from after its state was set by hand:
        the shuttle in each face's frame and each base's x-distance to it."""
        observe(a, k, e, p)
        m = a.motion
        for j in range(p):
            a.gap[e, j] = abs(a.fwd[e, j] * m[0, e] - a.base_x[e, j])

    @inline
    def entry(q0, q, lo, hi, e, c):
        """The swept overlap test (docs/reference.md §6) of column ``c`` of game ``e``: where
        the segment from ``q0`` to ``q`` enters the box [lo[c], hi[c]] (slabs, each axis's
        entry and exit; a segment that starts inside enters at 0): (met, t)."""
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
        """Player ``j`` of game ``e`` hits at fraction ``t`` of the step: the shuttle leaves
        as the kind's ``shot`` says from the point of contact. The hitter is disarmed and,
        with two players, its opponent armed (the turn passes); the shot is counted and the
        net touch of the last shot forgotten."""
        rx, ry, rz = racket(a, k, e, j, t)  # own frame
        sx, sy, sz = shot(k, rx, ry, rz)
        f = a.fwd[e, j]
        vx, vy, vz = sx * f, sy * f, sz
        m = a.motion
        for axis, v in ((0, vx), (1, vy), (2, vz)):
            start = a.q0[e, p, axis]
            at = start + t * (m[axis, e] - start)
            m[3 + axis, e] = v
            m[axis, e] = at + v * (1.0 - t) * k.dt
            ev.hit_point[e, j, axis] = at
        a.shot_speed[e] = speed(vx, vy, vz)
        a.shot_time[e] = 0.0
        ev.hit[e, j] = True
        ev.hit_speed[e, j] = speed(rx, ry, rz)
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
        """A net touch of game ``e``: an event where it is the first since the last shot, when
        under the re-arm rule both players are armed; a blocking net stops a shuttle moving
        into it against the face it reached."""
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
            observe(a, k, e, p)

    @inline
    def land(a, ev, k, e, t, p):
        """Game ``e``'s shuttle lands: the point, the side (the half it landed in) and in/out
        (inside the half's width, and within the full half court or the original's trigger
        box, docs/reference.md §7); play stops there, nobody may hit, the shuttle stops."""
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
        """What a game's contacts do, after the swept test found some: a hit by ``hitter`` at
        ``t_hit`` (none: -1), after which the net and the floor are tested again from the
        step's start to the shuttle's new place; then the net and the floor. A hit that
        reaches the cap ends the judging of the rally. (Rare: not inlined.)"""
        if hitter >= 0:
            apply_hit(a, ev, k, e, hitter, t_hit, p)
            observe(a, k, e, p)
            if not below_cap(a.hits, k, e):
                return
        touched, t_net = entry(a.q0, a.q, a.lo, a.hi, e, p)
        landed, t_floor = entry(a.q0, a.q, a.lo, a.hi, e, p + 1)
        if touched:
            apply_net(a, ev, k, e, t_net, p)
        if landed:
            land(a, ev, k, e, t_floor, p)

    @inline
    def step(model, data, a, ev, k, n, p, s):
        """One physics step of the batch: the bodies move, the shuttles fly, then one swept
        test for everything (the faces in their frames, the net, the floor) decides what
        happened."""
        m, q, q0, lo, hi = a.motion, a.q, a.q0, a.lo, a.hi
        fwd, base_x, armed = a.fwd, a.base_x, a.armed
        shot_time, shot_speed, in_play, active = a.shot_time, a.shot_speed, a.in_play, a.active
        has_hit, moved, gaps, hits = a.has_hit, a.base_moved, a.gap, a.hits
        for e in range(n):  # the points the swept test starts from
            for c in range(p):
                for axis in range(3):
                    q0[e, c, axis] = q[e, c, axis]
            for c in range(p, p + 2):
                for axis in range(3):
                    q0[e, c, axis] = m[axis, e]
        move(model, data, a, k, n, p)
        count = substeps(m, k, n)
        for e in range(n):
            live = in_play[e] and active[e]
            if live:
                (m[0, e], m[1, e], m[2, e], m[3, e], m[4, e], m[5, e], shot_time[e]) = fly(
                    m[0, e], m[1, e], m[2, e], m[3, e], m[4, e], m[5, e], shot_time[e],
                    shot_speed[e], k, count)
            else:  # a held shuttle stays put (its shot time runs on) until its env is reset
                shot_time[e] = shot_time[e] + k.dt
            observe(a, k, e, p)
            # the trace: each base's x-distance to the shuttle, its motion, the hit state
            px = m[0, e]
            a.trace_live[s, e] = live
            for j in range(p):
                if s == 0:
                    a.trace_gap[0, e, j] = gaps[e, j]
                gap = abs(fwd[e, j] * px - base_x[e, j])
                a.trace_gap[s + 1, e, j] = gap
                a.trace_moved[s, e, j] = moved[e, j]
                a.trace_has_hit[s, e, j] = has_hit[e, j]
                gaps[e, j] = gap
            if not (live and below_cap(hits, k, e)):
                continue
            # the swept test: the first armed player met hits; the net; the floor
            hitter, t_hit = -1, 0.0
            for j in range(p):
                if armed[e, j]:  # (only an armed player's face is tested)
                    met, t = entry(q0, q, lo, hi, e, j)
                    if met:
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
        """``steps`` physics steps of the batch (at most the trace's rows), from and to its
        arrays (``events``: the arrays of ``GameEvents``, as a plain tuple, which costs a call
        less; ``constants``: a record of ``CONSTANTS_DTYPE``)."""
        ev = GameEvents(*events)
        k = constants[0]
        n, p = a.fwd.shape
        for s in range(steps):
            step(model, data, a, ev, k, n, p, s)

    @njit
    def restart(a, constants, envs, receiver, pos, vel):
        """Rallies start in games ``envs``: each shuttle is served from world ``pos`` at ``vel``
        (each (k, 3)) toward ``receiver`` (k,): in play, only the receiver armed, nobody has
        hit, no shot counted, no net touch; the shot's speed and time are set, and what the
        next physics step starts from is recomputed for these games (``refresh``)."""
        k = constants[0]
        p = a.fwd.shape[1]
        m = a.motion
        for i in range(envs.shape[0]):
            e = envs[i]
            for axis in range(3):
                m[axis, e], m[3 + axis, e] = pos[i, axis], vel[i, axis]
            a.shot_speed[e] = speed(vel[i, 0], vel[i, 1], vel[i, 2])
            a.shot_time[e] = 0.0
            a.in_play[e] = True
            for j in range(p):
                a.armed[e, j] = j == receiver[i]
                a.has_hit[e, j] = False
            a.last_hitter[e] = SERVE
            a.hits[e] = 0
            a.net_touched[e] = False
            start_from(a, k, e, p)

    @njit
    def refresh(a, constants):
        """What the next physics step starts from, after the state was set by hand
        (``Game._refresh``): the shuttle in each face's frame and the bases' x-distances to
        it."""
        k = constants[0]
        n, p = a.fwd.shape
        for e in range(n):
            start_from(a, k, e, p)

    return steps_of, refresh, restart


class Compiled(NamedTuple):
    """A kind's compiled functions, called from Python (each cached across processes)."""

    state: Callable  # the kind's arrays -> the structref the steps read
    steps: Callable
    refresh: Callable
    restart: Callable


def compile_kind(pieces: Pieces, make_state: Callable) -> Compiled:
    """The steps of a kind with ``pieces`` compiled by Numba and cached (``native.jit``)."""
    numba = native.numba_module()
    steps, refresh, restart = steps_with(numba.njit, pieces)
    return Compiled(make_state, native.jit(steps.py_func), native.jit(refresh.py_func),
                    native.jit(restart.py_func))


class GameKernel:
    """The compiled steps of one game object (``Game``): its kind's compiled functions
    (``compiled``, a ``native.Kernel`` of ``Compiled``), its constants (``constants(game)``),
    and its arrays' structref (made on first use, and anew in a copy:
    ``Game.__getstate__``). A kind subclasses it with ``arrays`` and ``body_constants``."""

    compiled: native.Kernel

    def __init__(self, game: Any) -> None:
        self._set_constants(game)
        self._state: Any = None
        self._addresses = (0, 0)  # its MuJoCo model's and data's (made with ``_state``)

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_state": None, "_addresses": (0, 0)}

    def arrays(self, game: Any) -> tuple:
        """Views of ``game``'s arrays, as the kind's named tuple (``shared`` and its own)."""
        raise NotImplementedError

    @staticmethod
    def shared(game: Any) -> dict[str, np.ndarray]:
        """The arrays every kind's named tuple begins with (those the shared steps read)."""
        b, sh, st = game.bodies, game.shuttle, game.state
        return dict(
            fwd=b.forward, base_x=b.base_x, base_moved=b.base_moved, motion=sh.motion,
            shot_speed=sh.shot_speed, shot_time=sh.shot_time, in_play=st.in_play,
            active=game._active, armed=st.armed, has_hit=st.has_hit,
            last_hitter=st.last_hitter, hits=st.hits, net_touched=st.net_touched, q=game._q,
            q0=np.empty_like(game._q), gap=game._gap, lo=game._lo, hi=game._hi,
            trace_gap=game.trace.gap, trace_moved=game.trace.moved, trace_live=game.trace.live,
            trace_has_hit=game.trace.has_hit)

    def body_constants(self, game: Any) -> dict[str, float]:
        """The bodies' own ``GameConstants``."""
        return {}

    def _set_constants(self, game: Any) -> None:
        self._record = constants(game, **self.body_constants(game))
        # (a game's hit cap is an attribute that may be set between decisions)
        self._max_hits = game.max_hits

    def functions(self) -> Compiled:
        """The kind's compiled functions (built, or loaded from the cache, on first use)."""
        return self.compiled.get()

    def state(self, game: Any) -> Any:
        """The structref of ``game``'s arrays (``arrays``), made once."""
        if self._state is None:
            self._state = self.functions().state(self.arrays(game))
            b = game.bodies
            self._addresses = b.model._address, b.data._address
        return self._state

    def prepare(self, game: Any) -> None:
        """What the kind's bodies must do before a compiled call reads them."""

    def refresh(self, game: Any) -> None:
        """``Game._refresh``: the shuttle in each face's frame and the bases' x-distances."""
        self.prepare(game)
        self.functions().refresh(self.state(game), self._record)

    def restart(self, game: Any, envs: np.ndarray, receiver: np.ndarray, pos: np.ndarray,
                vel: np.ndarray) -> None:
        """Serves in ``envs`` of ``game`` toward ``receiver`` from ``pos`` at ``vel``."""
        self.prepare(game)
        self.functions().restart(self.state(game), self._record, envs, receiver, pos, vel)

    def run(self, game: Any, steps: int) -> None:
        """``steps`` physics steps of ``game``."""
        if game.max_hits != self._max_hits:
            self._set_constants(game)
        self.prepare(game)
        ev = game.events
        state = self.state(game)
        model, data = self._addresses
        self.functions().steps(
            model, data, state,
            (ev.hit, ev.hit_speed, ev.hit_point, ev.hit_velocity, ev.net_touch, ev.landed,
             ev.land_point, ev.land_side, ev.land_in),
            self._record, steps)
