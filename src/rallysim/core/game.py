"""N games at once: apply actions, run the physics steps of one decision, judge them by the rules.

``Game`` owns the shuttle, the rally's state (``RallyState``) and the rule set (``Rules``); the
bodies (``SimpleBodies`` by default) own the players and a serve strategy starts each rally.
The rules that change the state are ``rallysim.core.rules``'s functions; ``Game`` runs the
physics and calls them. Views (the Gymnasium and PettingZoo envs) turn ``Game`` state and
``Events`` into observations and rewards.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from rallysim.core import rules
from rallysim.core.bodies import PlayerBodies, SimpleBodies
from rallysim.core.court import Court
from rallysim.core.events import EventRows, Events
from rallysim.core.kernels import simple
from rallysim.core.lanes import ARRAYS, SCALARS, ArrayLanes, Ops, ScalarLanes
from rallysim.core.one_game import OneGame
from rallysim.core.one_humanlike import OneHumanLikeGame
from rallysim.core.serve import MachineServe, Serve
from rallysim.core.shuttle import RADIUS, ShuttleState, make_shuttle_model
from rallysim.core.state import RallyState

__all__ = ["PHYSICS_DT", "PHYSICS_STEPS_PER_DECISION", "Events", "Game", "validate_seed"]

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


class Game:
    """N batched games with P in {1, 2} players each, on one shuttle model.

    The players are ``bodies`` (default: SIMPLE players); every rule here works through the
    ``PlayerBodies`` protocol, so another player model shares the whole rulebook. ``serve``
    starts each rally (default: the machine serve of docs/reference.md §4.3). The rule set ``rules``
    (``rallysim.core.rules.Rules``) is derived once from the shuttle model and the player
    count. ``shaping`` counts the low-level task's approach steps before each player's first
    hit (``Events.approach_good`` and ``approach_bad``). ``max_hits`` is a rally's hit cap:
    the hit that reaches it ends the judging of that rally until its next serve (no later hit,
    net touch or landing counts, even within the same decision); None: no cap.

    SIMPLE games run their physics steps, judging included, in one compiled kernel for every
    batch size (``rallysim.core.kernels.simple``); other bodies (HUMAN-LIKE, whose motion is
    compiled by the bodies themselves) and SIMPLE games where that kernel cannot be had run on
    lanes (``rallysim.core.lanes``), with the same results.
    """

    def __init__(self, n_envs: int, n_players: int = 1, shuttle: str = "paper",
                 seed: int | None = None, shaping: bool = False,
                 bodies: PlayerBodies | None = None, serve: Serve | None = None,
                 max_hits: int | None = None) -> None:
        self.n_envs, self.n_players = n_envs, n_players
        self.max_hits = max_hits
        self.dt = PHYSICS_DT  # seconds per physics step
        self.court = Court.from_mjcf()
        self.flight = make_shuttle_model(shuttle, PHYSICS_DT)
        self.rules = rules.Rules.derive(self.flight, n_players)
        self.bodies: PlayerBodies = bodies or SimpleBodies(n_envs, n_players, PHYSICS_DT)
        if (self.bodies.n_envs, self.bodies.n_players) != (n_envs, n_players):
            raise ValueError("bodies must hold n_envs x n_players players")
        self.serve: Serve = serve or MachineServe()
        self.shuttle = ShuttleState.zeros(n_envs)
        # One stream per environment, so that environment i of a batch seeded s replays a
        # single environment seeded s + i (Gymnasium's convention for vector seeds).
        seed = validate_seed(seed)
        self.rngs = [np.random.default_rng(None if seed is None else seed + i)
                     for i in range(n_envs)]
        self.shaping = shaping
        n, p = n_envs, n_players
        self.state = RallyState.zeros(n, p)
        self._active = np.ones(n, bool)
        self._new_events = EventRows(n, p)  # each decision's events
        self.events = self._new_events.take()  # the last decision's (``step``'s) events
        # Boxes of the swept test, one column each: P faces (in their own frames), net, floor;
        # and as Python numbers grown for rules.apart.
        half = self.bodies.face_half + RADIUS
        net_lo, net_hi = rules.net_box(self.court, RADIUS)
        floor_lo, floor_hi = rules.floor_box()
        self._lo = np.stack([-half] * p + [net_lo, floor_lo])
        self._hi = np.stack([half] * p + [net_hi, floor_hi])
        self._lo_list, self._hi_list = self._lo.tolist(), self._hi.tolist()
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
        # SIMPLE players: every batch's physics steps compiled (rallysim.core.kernels.simple)
        self._simple: simple.SimpleKernel | None = (
            simple.SimpleKernel(self) if simple.fits(self) else None)
        # one game of one HUMAN-LIKE player with the paper flight: its physics steps fused
        self._one: OneGame | None = None
        if self._simple is None and OneHumanLikeGame.fits(self):
            self._one = OneHumanLikeGame(self)

    @property
    def kernel(self) -> str:
        """What runs this game's rules between physics steps in this process: "compiled" (a
        compiled kernel: ``rallysim.core.kernels.simple``, or one HUMAN-LIKE game's fused steps)
        or "python" (the lanes code)."""
        if self._simple is not None:
            return self._simple.kernel
        return "python" if self._one is None else self._one.kernel_in(self)

    def observation(self, extra: np.ndarray, centre: np.ndarray, scale: np.ndarray
                    ) -> np.ndarray | None:
        """One-player games' observations (``simple_obs.raw_observation_lanes``) followed by
        ``extra`` (N,), mapped by ``centre`` and ``scale`` and clipped into [-1, 1], float32
        (N, 17), where a compiled kernel gives them; else None (``ops.observations`` of the
        lanes gives the same bits)."""
        if self._simple is None:
            return None
        return self._simple.observation(self, extra, centre, scale)

    # -- the rally's state (RallyState), as the game's own arrays --------------------------------
    @property
    def in_play(self) -> np.ndarray:
        return self.state.in_play

    @property
    def armed(self) -> np.ndarray:
        return self.state.armed

    @property
    def has_hit(self) -> np.ndarray:
        return self.state.has_hit

    @property
    def last_hitter(self) -> np.ndarray:
        return self.state.last_hitter

    @property
    def hits(self) -> np.ndarray:
        return self.state.hits

    @property
    def net_touched(self) -> np.ndarray:
        return self.state.net_touched

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
        """Start a rally in ``envs`` (indices): place the players at own-frame ``base_x``
        (len(envs), P), arms at ``theta`` (``body``: further keywords of the bodies' own
        ``reset``), then serve toward ``receiver`` (the game's ``serve``, drawing from each
        env's stream)."""
        envs = np.asarray(envs, dtype=np.int64)
        k = len(envs)
        receiver = np.asarray(receiver, np.int64)
        # (one receiver for all: np.full is several times cheaper than np.broadcast_to)
        receiver = np.full(k, receiver) if receiver.ndim == 0 else np.broadcast_to(receiver, (k,))
        if base_x is None:
            base_x = np.full((k, self.n_players), -2.7)
        self.bodies.reset(envs, base_x, theta, **body)
        self._launch(envs, *self.serve([self.rngs[e] for e in envs], receiver))
        rules.start_rally(self.state, envs, receiver)

    def _launch(self, envs: np.ndarray, pos: np.ndarray, vel: np.ndarray) -> None:
        """Put shuttles in flight in ``envs`` from world ``pos`` at ``vel`` (each (len(envs),
        3))."""
        self.shuttle.pos[envs], self.shuttle.vel[envs] = pos, vel
        mask = np.zeros(self.n_envs, bool)
        mask[envs] = True
        self.shuttle.shot(mask)
        self._refresh()

    # -- one decision ---------------------------------------------------------------------------
    def step(self, actions: np.ndarray, active: np.ndarray | None = None) -> Events:
        """Hold ``actions`` (N, P, 3) in [-1, 1] for one decision; return its events (a new
        ``Events``, never written again).

        ``active`` (N,) bool, optional: games left out are held still (bodies and shuttle keep
        their state and nothing happens to them), so a batch can wait on some of its games.
        Non-finite actions raise ``ValueError`` before anything moves: MuJoCo would reset the
        whole batch's state on them, not only the offending game's."""
        if not self._all_finite(actions):
            bad = np.flatnonzero(~np.isfinite(actions).reshape(len(actions), -1).all(axis=1))
            raise ValueError(f"actions must be finite; got NaN or inf for game(s) "
                             f"{bad[:10].tolist()}")
        self.bodies.set_actions(actions)
        self._bind_events(self._new_events.take())
        frozen = None if active is None or active.all() else np.flatnonzero(~active)
        if frozen is not None:
            self._active[:] = active
            saved = self._snapshot(frozen)
        self._run(PHYSICS_STEPS_PER_DECISION)
        if frozen is not None:
            self._restore(frozen, saved)
            self._active[:] = True
        return self.events

    def _all_finite(self, actions: np.ndarray) -> bool:
        """Whether every action is finite (one game's few: as Python numbers, cheaper)."""
        if self.ops.scalar:
            return all(map(math.isfinite, actions.ravel().tolist()))
        finite = np.isfinite(actions)
        return np.count_nonzero(finite) == finite.size

    def _bind_events(self, events: Events) -> None:
        """Make ``events`` the ones the physics steps write (the approach counts are lanes)."""
        self.events = events
        if self._views is not None:
            self._views["good"] = events.approach_good
            self._views["bad"] = events.approach_bad
        if self._array_lanes is not None:
            self._array_lanes.rebind(good=events.approach_good, bad=events.approach_bad)

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
        if self._simple is not None and self._simple.refresh(self):
            return
        g = self._lanes(self.ops)
        own = self._observe(g, self.ops)
        g.gap = abs(own[0] - g.body.base_x)
        self._store(g, self._observed)

    # -- physics steps, on lanes (rallysim.core.lanes) ------------------------------------------

    def lane_views(self) -> dict[str, np.ndarray]:
        """Every array a physics step reads or writes, as (N, 1) (per game) or (N, P) views
        (the shuttle's vectors: ``vector_views``); made once (a copy of the game makes its
        own: ``__getstate__``), but for the approach counts, which are each decision's new
        events' (``_bind_events``)."""
        if self._views is None:
            sh, ev, q, p, st = self.shuttle, self.events, self._q, self.n_players, self.state
            self._views = {
                "shot_speed": sh.shot_speed[:, None], "shot_time": sh.shot_time[:, None],
                "in_play": st.in_play[:, None], "active": self._active[:, None],
                "armed": st.armed, "has_hit": st.has_hit, "qx": q[:, :p, 0],
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
    _observed = ("qx", "qy", "qz", "gap")  # those ``_refresh`` changes

    def _store(self, g: ArrayLanes | ScalarLanes, names: tuple[str, ...] = _moving) -> None:
        """Scalar lanes ``names`` back to the arrays, before array code reads them (array lanes
        are the arrays)."""
        if g.scalar:
            g.store(self.lane_views(), names, self.vector_views())
            self.bodies.store_lanes(g.body)

    def _reload(self, g: ArrayLanes | ScalarLanes) -> None:
        """Scalar lanes from the arrays again, after array code changed them."""
        if g.scalar:
            g.reload(self.lane_views(), self.vector_views())

    def _run(self, steps: int) -> None:
        if self._simple is not None and self._simple.run(self, steps):
            return
        if self._one is not None:
            self._one.run(self, steps)
        else:
            self._run_lanes(steps)

    def _run_lanes(self, steps: int) -> None:
        """``steps`` physics steps on the lanes of ``ops``, from and to the arrays."""
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
        self._judge(g, ops, q0, live)

    def _judge(self, g: Any, ops: Ops, q0: Any, live: Any) -> None:
        """The end of a physics step (``_step_lanes``): the swept test of the points from
        ``q0`` (``_points`` at the step's start) to the current ones decides the hits, net
        touches and landings of the ``live`` games, which the rules then apply."""
        P = self.n_players
        tested = self._swept(q0, self._points(g, ops), ops)
        if tested is None:  # one game, apart from every box
            return
        met, t = tested
        start = self._start_positions(q0)
        read = ops.read
        live = self._below_cap(live, ops)
        hit = read(met[:, :P]) & g.armed & live
        if ops.any(hit):
            self._store(g)
            self._apply_hits(_cells(hit), t[:, :P], start)
            self._reload(g)
            self._observe(g, ops)
            met[:, P:], t[:, P:] = self._swept(q0, self._points(g, ops), ops, first=P)
            # the hit that reached the cap ended the rally: its shuttle meets nothing more
            live = self._below_cap(live, ops)

        touched = read(met[:, P:P + 1]) & live
        landed = read(met[:, P + 1:]) & live
        if ops.any(touched):
            self._store(g)
            self._apply_net(_cells(touched), t[:, P], start)
            self._reload(g)
            if self.rules.net_blocks:  # (only a blocking net moves the shuttle)
                self._observe(g, ops)
        if ops.any(landed):
            self._store(g)
            self._land(_cells(landed), t[:, P + 1], start)
            self._reload(g)

    def _below_cap(self, live: Any, ops: Ops) -> Any:
        """``live`` left only where the rally has fewer hits than ``max_hits``: several hits
        can fall within one decision, and none may count past the cap."""
        if self.max_hits is None:
            return live
        below = self.state.hits < self.max_hits
        return live & (below.item() if ops.scalar else below[:, None])

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
            # the same test on Python floats (rules.segment_box_entry_one)
            met, t = rules.segment_box_entry_one((f0, w0, w0)[first:], (f1, w1, w1)[first:],
                                                 self._lo_list[first:], self._hi_list[first:])
            return np.array([met]), np.array([t])
        return rules.segment_box_entry(q0[:, first:], q1[:, first:], self._lo[first:],
                                       self._hi[first:])

    def _apart(self, f0: tuple, f1: tuple, w0: tuple, w1: tuple) -> bool:
        """Whether one game's shuttle stayed apart (``rules.apart``) from the floor, the net
        and the face during the step (``f``: in the face's frame, ``w``: in the world)."""
        return rules.step_apart(f0, f1, w0, w1, self._floor_top, *self._net_apart,
                                *self._face_apart)

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
        if self.ops.scalar:  # one game: the same arithmetic on floats, fewer NumPy calls
            self._land_one(t.item(), p0[0].tolist())
            return
        idx = np.flatnonzero(landed)
        t = t.reshape(-1)
        point = p0[idx] + t[idx, None] * (sh.pos[idx] - p0[idx])
        point[:, 2] = 0.0
        ev.landed[idx] = True
        ev.land_point[idx] = point
        ev.land_side[idx] = rules.landing_side(point)
        ev.land_in[idx] = rules.landing_in(self.court, np.abs(point[:, 0]), point[:, 1],
                                           self.rules.full_court)
        rules.record_landings(self.state, idx)
        sh.vel[idx] = 0.0

    def _land_one(self, t: float, p0: list[float]) -> None:
        """``_land`` of one game, whose shuttle landed at fraction ``t`` of the step from
        ``p0``."""
        sh, ev = self.shuttle, self.events
        x, y, _ = (a + t * (b - a) for a, b in zip(p0, sh.pos[0].tolist(), strict=True))
        ev.landed[0] = True
        ev.land_point[0] = x, y, 0.0
        ev.land_side[0] = rules.in_far_half(x)
        ev.land_in[0] = rules.landing_in(self.court, abs(x), y, self.rules.full_court)
        rules.record_landings(self.state, 0)
        sh.vel[0] = 0.0

    def _apply_hits(self, hit: np.ndarray, t: np.ndarray, p0: np.ndarray) -> None:
        """Shuttles met by an armed face leave as the bodies' shot rule says (SIMPLE: at twice
        the face centre's velocity, docs/reference.md §5), from the point of contact."""
        b, sh, ev = self.bodies, self.shuttle, self.events
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
        ev.hit_velocity[env, player] = racket
        rules.record_hits(self.state, env, player)

    def _apply_net(self, touched: np.ndarray, t: np.ndarray, p0: np.ndarray) -> None:
        """Net touches (``touched`` (N,), at fraction ``t`` of the step from ``p0``): noted (and
        acted on, ``rules.record_net_touches``); a blocking net stops the shuttle against it."""
        sh, ev = self.shuttle, self.events
        idx = np.flatnonzero(touched)
        t = t.reshape(-1)
        ev.net_touch[rules.record_net_touches(self.state, idx, self.rules)] = True
        if self.rules.net_blocks:
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


def _cells(lane: Any) -> np.ndarray:
    """A lane as its (N, 1) or (N, P) array (a scalar lane: one game, one player)."""
    return lane if isinstance(lane, np.ndarray) else np.array([[lane]])
