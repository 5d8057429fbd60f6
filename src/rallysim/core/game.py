"""N games at once: apply actions, run the physics steps of one decision, judge them by the rules.

``Game`` owns the shuttle and the turn state; ``SimpleBodies`` owns the players. Views (the
Gymnasium and PettingZoo envs) turn ``Game`` state and ``Events`` into observations and rewards.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

import numpy as np

from rallysim.core import rules
from rallysim.core.bodies import PlayerBodies, SimpleBodies
from rallysim.core.court import Court
from rallysim.core.lanes import ARRAYS, SCALARS, ArrayLanes, Ops, ScalarLanes
from rallysim.core.shuttle import RADIUS, ShuttleState, make_shuttle_model

PHYSICS_DT = 0.02
PHYSICS_STEPS_PER_DECISION = 5


SEED_MAX = 2**63 - 1


def validate_seed(seed: Any) -> int | None:
    """A seed: None or a non-negative integer (NumPy's and Gymnasium's requirement), checked
    before any stream restarts."""
    if seed is None:
        return None
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or not (
            0 <= seed <= SEED_MAX):
        raise ValueError(f"seed must be None or an integer in [0, 2**63 - 1], got {seed!r}")
    return int(seed)


@dataclass
class Events:
    """What happened during one decision, per environment (and per player where it says P)."""

    hit: np.ndarray  # (N, P) bool: the player hit the shuttle
    hit_speed: np.ndarray  # (N, P) racket face speed at the hit, m/s
    hit_point: np.ndarray  # (N, P, 3) world position of the shuttle at the hit
    net_touch: np.ndarray  # (N,) bool: first net touch since the last shot
    landed: np.ndarray  # (N,) bool: the shuttle's centre dropped below z = 0
    land_point: np.ndarray  # (N, 3) world landing point
    land_side: np.ndarray  # (N,) int: the player whose half it landed in
    land_in: np.ndarray  # (N,) bool: inside that half's court (paper trigger box or full half)
    approach_good: np.ndarray  # (N, P) physics steps the base closed in on the shuttle (shaping)
    approach_bad: np.ndarray  # (N, P) physics steps it did not

    @classmethod
    def empty(cls, n: int, p: int) -> Events:
        return cls(
            hit=np.zeros((n, p), bool), hit_speed=np.zeros((n, p)), hit_point=np.zeros((n, p, 3)),
            net_touch=np.zeros(n, bool), landed=np.zeros(n, bool), land_point=np.zeros((n, 3)),
            land_side=np.zeros(n, np.int64), land_in=np.zeros(n, bool),
            approach_good=np.zeros((n, p), np.int64), approach_bad=np.zeros((n, p), np.int64),
        )

    def clear(self) -> None:
        for name in _EVENT_FIELDS:
            getattr(self, name).fill(0)


_EVENT_FIELDS = tuple(f.name for f in fields(Events))


class Game:
    """N batched games with P in {1, 2} players each, on one shuttle model.

    The players are ``bodies`` (default: SIMPLE players); every rule here works through the
    ``PlayerBodies`` protocol, so another player model shares the whole rulebook.

    ``rearm_on_net`` reproduces the original rally's net rule (a net touch re-arms both players);
    ``shaping`` counts the low-level task's approach steps before each player's first hit.

    The physics steps run on lanes (``rallysim.core.lanes``): NumPy arrays over a batch, Python
    numbers for one game of one player (``ops``), with the same rule code for both.
    """

    def __init__(self, n_envs: int, n_players: int = 1, shuttle: str = "paper",
                 seed: int | None = None, shaping: bool = False,
                 rearm_on_net: bool = False, bodies: PlayerBodies | None = None) -> None:
        self.n_envs, self.n_players = n_envs, n_players
        self.court = Court.from_mjcf()
        self.flight = make_shuttle_model(shuttle, PHYSICS_DT)
        self.bodies: PlayerBodies = bodies or SimpleBodies(n_envs, n_players, PHYSICS_DT)
        if (self.bodies.n_envs, self.bodies.n_players) != (n_envs, n_players):
            raise ValueError("bodies must hold n_envs x n_players players")
        self.shuttle = ShuttleState.zeros(n_envs)
        # One stream per environment, so that environment i of a batch seeded s replays a
        # single environment seeded s + i (Gymnasium's convention for vector seeds).
        seed = validate_seed(seed)
        self.rngs = [np.random.default_rng(None if seed is None else seed + i)
                     for i in range(n_envs)]
        self.shaping, self.rearm_on_net = shaping, rearm_on_net
        n, p = n_envs, n_players
        self.in_play = np.zeros(n, bool)
        self._active = np.ones(n, bool)
        self.armed = np.zeros((n, p), bool)
        self.has_hit = np.zeros((n, p), bool)
        self.last_hitter = np.full(n, -1)  # -1: the serve
        self.hits = np.zeros(n, np.int64)
        self.net_touched = np.zeros(n, bool)
        self.events = Events.empty(n, p)
        # Boxes of the swept test, one column each: P faces (in their own frames), net, floor;
        # and as Python numbers grown for rules.apart.
        half = self.bodies.face_half + RADIUS
        net_lo, net_hi = rules.net_box(self.court, RADIUS)
        floor_lo, floor_hi = rules.floor_box()
        self._lo = np.stack([-half] * p + [net_lo, floor_lo])
        self._hi = np.stack([half] * p + [net_hi, floor_hi])
        self._face_apart = rules.grown(-half, half)
        self._net_apart = rules.grown(net_lo, net_hi)
        self._floor_top = rules.grown(floor_lo, floor_hi)[1][2]  # (x and y: unbounded)
        self._fwd = self.bodies.forward  # (N, P)
        self._q = np.zeros((n, p + 2, 3))  # tested points at the end of the step
        self._gap = np.zeros((n, p))  # |base x - shuttle x| for shaping
        # The lanes backend (rallysim.core.lanes): one game of one player runs its physics steps
        # on Python numbers.
        self.ops: Ops = SCALARS if (n, p) == (1, 1) else ARRAYS
        self._views: dict[str, np.ndarray] | None = None
        self._vectors: dict[str, np.ndarray] | None = None
        self._array_lanes: ArrayLanes | None = None
        self._events_written = False  # events other than the approach counts since the clear

    # -- episodes -------------------------------------------------------------------------------
    def seed(self, envs: np.ndarray, seed: int | None) -> None:
        """Restart the random streams of ``envs``: env ``envs[j]`` gets ``seed + j``."""
        seed = validate_seed(seed)
        for j, e in enumerate(np.asarray(envs)):
            self.rngs[e] = np.random.default_rng(None if seed is None else seed + j)

    def seed_each(self, seeds: list[int]) -> None:
        """Restart env e's random stream at ``seeds[e]`` (a vector env's per-env seeds)."""
        for e, s in enumerate(seeds):
            self.seed(np.array([e]), s)

    def reset(self, envs: np.ndarray, receiver: np.ndarray | int = 0,
              base_x: np.ndarray | None = None, theta: np.ndarray | float = 0.0,
              **body: Any) -> None:
        """Serve a new shuttle in ``envs`` (indices) toward ``receiver``; place the players at
        own-frame ``base_x`` (len(envs), P), arms at ``theta`` (``body``: further keywords of
        the bodies' own ``reset``)."""
        envs = np.asarray(envs, dtype=np.int64)
        k = len(envs)
        receiver = np.broadcast_to(np.asarray(receiver, np.int64), (k,))
        if base_x is None:
            base_x = np.full((k, self.n_players), -2.7)
        self.bodies.reset(envs, base_x, theta, **body)
        u = np.stack([self.rngs[e].random(rules.SERVE_DRAWS) for e in envs])
        self.launch(envs, *rules.sample_serve(u, receiver))
        self.in_play[envs] = True
        self.armed[envs] = False
        self.armed[envs, receiver] = True
        self.has_hit[envs] = False
        self.last_hitter[envs] = -1
        self.hits[envs] = 0
        self.net_touched[envs] = False

    def launch(self, envs: np.ndarray, pos: np.ndarray, vel: np.ndarray) -> None:
        """Put shuttles in flight in ``envs`` from world ``pos`` at ``vel`` (each (len(envs),
        3)): the serve, or a task's own serve or fed shot in its place."""
        self.shuttle.pos[envs], self.shuttle.vel[envs] = pos, vel
        mask = np.zeros(self.n_envs, bool)
        mask[envs] = True
        self.shuttle.shot(mask)
        self._refresh()

    # -- one decision ---------------------------------------------------------------------------
    def step(self, actions: np.ndarray, active: np.ndarray | None = None) -> Events:
        """Hold ``actions`` (N, P, 3) in [-1, 1] for one decision; return its events.

        ``active`` (N,) bool, optional: games left out are held still (bodies and shuttle keep
        their state and nothing happens to them), so a batch can wait on some of its games.
        Non-finite actions raise ``ValueError`` before anything moves: MuJoCo would reset the
        whole batch's state on them, not only the offending game's."""
        finite = np.isfinite(actions)
        if np.count_nonzero(finite) != finite.size:
            bad = np.flatnonzero(~finite.reshape(len(finite), -1).all(axis=1))
            raise ValueError(f"actions must be finite; got NaN or inf for game(s) "
                             f"{bad[:10].tolist()}")
        self.bodies.set_actions(actions)
        if self._events_written:  # hits, net touches and landings are rare: clear after one
            self.events.clear()
            self._events_written = False
        else:
            self.events.approach_good.fill(0)
            self.events.approach_bad.fill(0)
        frozen = None if active is None or active.all() else np.flatnonzero(~active)
        if frozen is not None:
            self._active[:] = active
            saved = self._snapshot(frozen)
        self._run(PHYSICS_STEPS_PER_DECISION)
        if frozen is not None:
            self._restore(frozen, saved)
            self._active[:] = True
        return self.events

    def _snapshot(self, envs: np.ndarray) -> tuple:
        sh = self.shuttle
        return (self.bodies.snapshot(envs), sh.pos[envs].copy(), sh.vel[envs].copy(),
                sh.shot_time[envs].copy())

    def _restore(self, envs: np.ndarray, saved: tuple) -> None:
        sh = self.shuttle
        bodies, sh.pos[envs], sh.vel[envs], sh.shot_time[envs] = saved
        self.bodies.restore(envs, bodies)
        self._refresh()

    def _refresh(self) -> None:
        """Recompute what the next physics step starts from (the shuttle in the faces' frames,
        the shaping's gaps) after the state was set by hand."""
        g = self._lanes(self.ops)
        own = self._observe(g, self.ops)
        g.gap = abs(own[0] - g.body.base_x)
        self._store(g)

    # -- physics steps, on lanes (rallysim.core.lanes) ------------------------------------------

    def lane_views(self) -> dict[str, np.ndarray]:
        """Every array a physics step reads or writes, as (N, 1) (per game) or (N, P) views
        (the shuttle's vectors: ``vector_views``); made once (a copy of the game makes its
        own: ``__getstate__``)."""
        if self._views is None:
            sh, ev, q, p = self.shuttle, self.events, self._q, self.n_players
            self._views = {
                "shot_speed": sh.shot_speed[:, None], "shot_time": sh.shot_time[:, None],
                "in_play": self.in_play[:, None], "active": self._active[:, None],
                "armed": self.armed, "has_hit": self.has_hit, "qx": q[:, :p, 0],
                "qy": q[:, :p, 1], "qz": q[:, :p, 2], "gap": self._gap,
                "good": ev.approach_good, "bad": ev.approach_bad, "fwd": self._fwd}
        return self._views

    def vector_views(self) -> dict[str, np.ndarray]:
        """The shuttle's position and velocity as vector lanes: (3, N, 1) views (made once)."""
        if self._vectors is None:
            pos, vel = self.shuttle.vectors()
            self._vectors = {"pos": pos, "vel": vel}
        return self._vectors

    def __getstate__(self) -> dict[str, Any]:
        return {**self.__dict__, "_views": None, "_vectors": None, "_array_lanes": None}

    def _lanes(self, ops: Ops) -> ArrayLanes | ScalarLanes:
        """The lanes of the current state: read into Python numbers for one game; over a
        batch, views of the arrays (made once, like ``lane_views``)."""
        if ops.scalar:
            g = ScalarLanes.load(self.lane_views(), self.vector_views())
        elif self._array_lanes is None:
            g = self._array_lanes = ArrayLanes(**self.lane_views(), **self.vector_views())
        else:
            return self._array_lanes
        g.body = self.bodies.lanes(ops)
        return g

    # lanes a physics step changes besides the vectors (the others change only in array code:
    # hits, net, landing)
    _moving = ("shot_time", "qx", "qy", "qz", "gap", "good", "bad")

    def _store(self, g: ArrayLanes | ScalarLanes) -> None:
        """Scalar lanes back to the arrays, before array code reads them (array lanes are the
        arrays)."""
        if g.scalar:
            g.store(self.lane_views(), self._moving, self.vector_views())
            self.bodies.store_lanes(g.body)

    def _reload(self, g: ArrayLanes | ScalarLanes) -> None:
        """Scalar lanes from the arrays again, after array code changed them."""
        if g.scalar:
            g.reload(self.lane_views(), self.vector_views())

    def _run(self, steps: int) -> None:
        ops = self.ops
        g = self._lanes(ops)
        for _ in range(steps):
            self._step_lanes(g, ops)
        self._store(g)

    def _physics_step(self) -> None:
        self._run(1)

    def _observe(self, g: Any, ops: Ops) -> tuple:
        """Put the shuttle in each face's frame (normal, across, along the arm) into the lanes
        ``qx, qy, qz`` (and, over a batch, into the net's and floor's columns of the tested
        points); return it in each player's own frame."""
        px, py, pz = g.pos
        own = (g.fwd * px, g.fwd * py, pz)
        g.qx, g.qy, g.qz = self.bodies.face_frame(g.body, own, ops)
        if not ops.scalar:
            pos, P = self.shuttle.pos, self.n_players
            self._q[:, P] = pos
            self._q[:, P + 1] = pos
        return own

    def _step_lanes(self, g: Any, ops: Ops) -> None:
        """One physics step: the bodies move, the shuttle flies, then one swept test for
        everything (the faces in their frames, the net, the floor) decides what happened."""
        P = self.n_players
        live = g.in_play & g.active
        held = not ops.all(live)
        if held:
            p0, v0 = ops.copies(*g.pos), ops.copies(*g.vel)
        q0 = self._points(g, ops, keep=True)
        self.bodies.step_lanes(g.body, ops)
        self.flight.fly(g, PHYSICS_DT, ops)
        if held:  # landed (or held) shuttles stay put until their env is reset
            for vector, old in ((g.pos, p0), (g.vel, v0)):
                for k in range(3):
                    vector[k] = ops.where(live, vector[k], old[k])
        own = self._observe(g, ops)
        if self.shaping:
            self._shape(g, own[0], live)
        if held and not ops.any(live):  # nothing in play: what the tests find would be ignored
            return

        tested = self._swept(q0, self._points(g, ops), ops)
        if tested is None:  # one game, apart from every box
            return
        met, t = tested
        start = self._start_positions(q0)
        read = ops.read
        hit = read(met[:, :P]) & g.armed & live
        if ops.any(hit):
            self._store(g)
            self._apply_hits(_cells(hit), t[:, :P], start)
            self._reload(g)
            self._observe(g, ops)
            met[:, P:], t[:, P:] = self._swept(q0, self._points(g, ops), ops, first=P)

        touched = read(met[:, P:P + 1]) & live
        landed = read(met[:, P + 1:]) & live
        if ops.any(touched):
            self._store(g)
            self._apply_net(_cells(touched), t[:, P], start)
            self._reload(g)
            if self.flight.net_blocks:  # (only a blocking net moves the shuttle)
                self._observe(g, ops)
        if ops.any(landed):
            self._store(g)
            self._land(_cells(landed), t[:, P + 1], start)
            self._reload(g)

    def _points(self, g: Any, ops: Ops, keep: bool = False) -> Any:
        """The points the swept test takes, now: over a batch (N, P + 2, 3) (the shuttle in
        each face's frame, then twice in the world, for the net and the floor; a copy to
        ``keep`` it past the next ``_observe``), for one game the face's and the world's
        (x, y, z) numbers."""
        if ops.scalar:
            return (g.qx, g.qy, g.qz), tuple(g.pos)
        return self._q.copy() if keep else self._q

    def _start_positions(self, q0: Any) -> np.ndarray:
        """(N, 3) world positions of the shuttles at the step's start, from its ``_points``."""
        if isinstance(q0, np.ndarray):
            return q0[:, self.n_players]
        return np.array([q0[1]])

    def _swept(self, q0: Any, q1: Any, ops: Ops, first: int = 0) -> tuple | None:
        """``rules.segment_box_entry`` of the points from ``q0`` to ``q1`` (``_points``)
        against the boxes from column ``first`` on: (met, t), each (N, P + 2 - first). One
        game whose shuttle stays apart from every box (``rules.apart``) skips the test: None."""
        if ops.scalar:
            (f0, w0), (f1, w1) = q0, q1
            if first == 0 and self._apart(f0, f1, w0, w1):
                return None
            q0, q1 = np.array([[f0, w0, w0]]), np.array([[f1, w1, w1]])
        return rules.segment_box_entry(q0[:, first:], q1[:, first:], self._lo[first:],
                                       self._hi[first:])

    def _apart(self, f0: tuple, f1: tuple, w0: tuple, w1: tuple) -> bool:
        """Whether one game's shuttle stayed apart (``rules.apart``) from the floor, the net
        and the face during the step (``f``: in the face's frame, ``w``: in the world)."""
        top = self._floor_top
        return (w0[2] > top and w1[2] > top and rules.apart(w0, w1, *self._net_apart)
                and rules.apart(f0, f1, *self._face_apart))

    def _shape(self, g: Any, own_x: Any, live: Any) -> None:
        """Count the physics steps each base closed in on the shuttle (x distance), before the
        player's first hit."""
        gap = abs(own_x - g.body.base_x)
        todo = live ^ (live & g.has_hit)  # live and not has_hit, without a NumPy call more
        good = g.body.base_moved & (gap < g.gap) & todo
        g.good += good
        g.bad += todo ^ good  # todo and not good
        g.gap = gap

    def _land(self, landed: np.ndarray, t: np.ndarray, p0: np.ndarray) -> None:
        """Shuttles whose centre crossed z = 0 (``landed`` (N,), at fraction ``t`` of the
        step from ``p0``) land: the point, side and in/out are recorded and play stops."""
        sh, ev = self.shuttle, self.events
        self._events_written = True
        idx = np.flatnonzero(landed)
        t = t.reshape(-1)
        point = p0[idx] + t[idx, None] * (sh.pos[idx] - p0[idx])
        point[:, 2] = 0.0
        ev.landed[idx] = True
        ev.land_point[idx] = point
        ev.land_side[idx] = (point[:, 0] > 0).astype(np.int64)
        ev.land_in[idx] = rules.landing_in(self.court, np.abs(point[:, 0]), point[:, 1],
                                           self.flight.full_court)
        self.in_play[idx] = False
        self.armed[idx] = False
        sh.vel[idx] = 0.0

    def _apply_hits(self, hit: np.ndarray, t: np.ndarray, p0: np.ndarray) -> None:
        """Shuttles met by an armed face leave as the bodies' shot rule says (SIMPLE: at twice
        the face centre's velocity, SPEC §5), from the point of contact."""
        b, sh, ev = self.bodies, self.shuttle, self.events
        self._events_written = True
        env, player = np.nonzero(hit)
        # one hitter per shuttle: the first in player order (only one is armed in a rally)
        env, first = np.unique(env, return_index=True)
        player = player[first]
        tk = t[env, player]
        racket = b.racket_velocity(env, player, tk)
        shot = b.shot_velocity(racket)
        f = self._fwd[env, player]
        shot[:, 0] *= f  # own frame -> world
        shot[:, 1] *= f
        at = p0[env] + tk[:, None] * (sh.pos[env] - p0[env])
        sh.vel[env] = shot
        sh.pos[env] = at + sh.vel[env] * (1.0 - tk)[:, None] * PHYSICS_DT
        mask = np.zeros(self.n_envs, bool)
        mask[env] = True
        sh.shot(mask)
        ev.hit[env, player] = True
        ev.hit_speed[env, player] = np.linalg.norm(racket, axis=1)
        ev.hit_point[env, player] = at
        self.has_hit[env, player] = True
        self.armed[env, player] = False
        if self.n_players == 2:
            self.armed[env, 1 - player] = True
        self.last_hitter[env] = player
        self.hits[env] += 1
        self.net_touched[env] = False

    def _apply_net(self, touched: np.ndarray, t: np.ndarray, p0: np.ndarray) -> None:
        """Net touches (``touched`` (N,), at fraction ``t`` of the step from ``p0``): noted, and
        for a blocking net the shuttle stops against it."""
        sh, ev = self.shuttle, self.events
        self._events_written = True
        idx = np.flatnonzero(touched)
        t = t.reshape(-1)
        first = idx[~self.net_touched[idx]]
        ev.net_touch[first] = True
        self.net_touched[idx] = True
        if self.flight.net_blocks:
            # Blocked: a shuttle moving into the net stops against the face it reached and
            # drops on that side (one that already rests against it just falls).
            side = np.where(p0[idx, 0] < 0, -1.0, 1.0)
            into = side * (sh.pos[idx, 0] - p0[idx, 0]) < 0
            idx, side = idx[into], side[into]
            if len(idx):
                at = p0[idx] + t[idx, None] * (sh.pos[idx] - p0[idx])
                at[:, 0] = side * (self.court.net_half_thickness + RADIUS)
                sh.pos[idx] = at
                sh.vel[idx, 0] = 0.0
        elif self.rearm_on_net and self.n_players == 2:
            self.armed[first] = True


def _cells(lane: Any) -> np.ndarray:
    """A lane as its (N, 1) or (N, P) array (a scalar lane: one game, one player)."""
    return lane if isinstance(lane, np.ndarray) else np.array([[lane]])
