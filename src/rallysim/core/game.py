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
        for f in fields(self):
            getattr(self, f.name).fill(0)


class Game:
    """N batched games with P in {1, 2} players each, on one shuttle model.

    The players are ``bodies`` (default: SIMPLE players); every rule here works through the
    ``PlayerBodies`` protocol, so another player model shares the whole rulebook.

    ``rearm_on_net`` reproduces the original rally's net rule (a net touch re-arms both players);
    ``shaping`` counts the low-level task's approach steps before each player's first hit.
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
        # Boxes of the swept test, one column each: P faces (in their own frames), net, floor.
        half = self.bodies.face_half + RADIUS
        net_lo, net_hi = rules.net_box(self.court, RADIUS)
        floor_lo, floor_hi = rules.floor_box()
        self._lo = np.stack([-half] * p + [net_lo, floor_lo])
        self._hi = np.stack([half] * p + [net_hi, floor_hi])
        self._fwd = self.bodies.forward  # (N, P)
        self._own_buf = np.zeros((n, p, 3))
        self._q = np.zeros((n, p + 2, 3))  # tested points at the end of the step
        self._q0 = np.zeros((n, p + 2, 3))  # ... and at its start
        self._gap = np.zeros((n, p))  # |base x - shuttle x| for shaping

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
        if not finite.all():
            bad = np.flatnonzero(~finite.reshape(len(finite), -1).all(axis=1))
            raise ValueError(f"actions must be finite; got NaN or inf for game(s) "
                             f"{bad[:10].tolist()}")
        self.bodies.set_actions(actions)
        self.events.clear()
        frozen = None if active is None or active.all() else np.flatnonzero(~active)
        if frozen is not None:
            self._active[:] = active
            saved = self._snapshot(frozen)
        for _ in range(PHYSICS_STEPS_PER_DECISION):
            self._physics_step()
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

    def _own_into(self, world: np.ndarray, out: np.ndarray) -> None:
        """(N, 3) world positions -> (N, P, 3) ``out`` in each player's own frame."""
        out[:] = world[:, None, :]
        out[..., 0] *= self._fwd
        out[..., 1] *= self._fwd

    def _observe_shuttle(self) -> None:
        """Fill ``self._q`` for the current state: the shuttle in each face's frame (normal,
        across, along the arm) in columns [0, P), and in the world in the net and floor columns."""
        own, q, P = self._own_buf, self._q, self.n_players
        self._own_into(self.shuttle.pos, own)
        self.bodies.to_face_frame(own, q[:, :P])
        q[:, P] = self.shuttle.pos
        q[:, P + 1] = self.shuttle.pos

    def _refresh(self) -> None:
        self._observe_shuttle()
        self._gap = np.abs(self._own_buf[..., 0] - self.bodies.base_x)

    def _physics_step(self) -> None:
        b, sh, ev, P = self.bodies, self.shuttle, self.events, self.n_players
        live = self.in_play & self._active
        p0 = sh.pos.copy()
        v0 = sh.vel.copy()
        q0, self._q = self._q, self._q0
        self._q0 = q0
        b.physics_step()
        self.flight.advance(sh, PHYSICS_DT)
        if not live.all():  # landed (or held) shuttles stay put until their env is reset
            sh.pos[~live] = p0[~live]
            sh.vel[~live] = v0[~live]
        self._observe_shuttle()

        if self.shaping:
            gap = np.abs(self._own_buf[..., 0] - b.base_x)
            good = b.base_moved & (gap < self._gap)
            todo = live[:, None] & ~self.has_hit
            ev.approach_good += good & todo
            ev.approach_bad += ~good & todo
            self._gap = gap

        # One swept test for everything: the faces (in their frames), the net and the floor.
        met, t = rules.segment_box_entry(q0, self._q, self._lo, self._hi)
        hit = met[:, :P] & self.armed & live[:, None]
        if hit.any():
            self._apply_hits(hit, t[:, :P], p0)
            self._observe_shuttle()
            met2, t2 = rules.segment_box_entry(q0[:, P:], self._q[:, P:], self._lo[P:],
                                               self._hi[P:])
            met[:, P:], t[:, P:] = met2, t2

        touched = met[:, P] & live
        if touched.any():
            self._apply_net(touched, t[:, P], p0)

        landed = met[:, P + 1] & live
        if landed.any():
            idx = np.flatnonzero(landed)
            point = p0[idx] + t[idx, P + 1, None] * (sh.pos[idx] - p0[idx])
            point[:, 2] = 0.0
            side = (point[:, 0] > 0).astype(np.int64)
            ev.landed[idx] = True
            ev.land_point[idx] = point
            ev.land_side[idx] = side
            ev.land_in[idx] = rules.landing_in(self.court, np.abs(point[:, 0]), point[:, 1],
                                               self.flight.full_court)
            self.in_play[idx] = False
            self.armed[idx] = False
            sh.vel[idx] = 0.0

    def _apply_hits(self, hit: np.ndarray, t: np.ndarray, p0: np.ndarray) -> None:
        """Shuttles met by an armed face leave as the bodies' shot rule says (SIMPLE: at twice
        the face centre's velocity, SPEC §5), from the point of contact."""
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
        self.has_hit[env, player] = True
        self.armed[env, player] = False
        if self.n_players == 2:
            self.armed[env, 1 - player] = True
        self.last_hitter[env] = player
        self.hits[env] += 1
        self.net_touched[env] = False

    def _apply_net(self, touched: np.ndarray, t: np.ndarray, p0: np.ndarray) -> None:
        sh, ev = self.shuttle, self.events
        idx = np.flatnonzero(touched)
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
                self._observe_shuttle()
        elif self.rearm_on_net and self.n_players == 2:
            self.armed[first] = True
