"""N games at once: apply actions, run the physics steps of one decision, judge them by the rules.

``Game`` owns the shuttle, the rally's state (``RallyState``) and the rule set (``Rules``); the
bodies (``SimpleBodies`` by default) own the players and a serve strategy starts each rally.
The physics steps and everything that changes the rally's state run compiled
(``rallysim.core.kernels``): a decision's steps with their judging, and a rally's start. Tasks
turn ``Game`` state and ``Events`` into observations, rewards and ends.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from rallysim.core import rules
from rallysim.core.bodies import PlayerBodies, SimpleBodies
from rallysim.core.court import Court
from rallysim.core.events import EventRows, Events
from rallysim.core.humanlike import HumanLikeBodies
from rallysim.core.kernels.humanlike import HumanLikeKernel
from rallysim.core.kernels.simple import SimpleKernel
from rallysim.core.kernels.step import FLIGHTS, GameKernel, GameTrace
from rallysim.core.serve import MachineServe, Serve
from rallysim.core.shuttle import RADIUS, ShuttleState, make_shuttle_model
from rallysim.core.state import RallyState
from rallysim.core.streams import Streams

__all__ = ["PHYSICS_DT", "PHYSICS_STEPS_PER_DECISION", "Events", "Game", "GameTrace",
           "validate_seed"]

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

    The players are ``bodies`` (default: SIMPLE players; or ``HumanLikeBodies``). ``serve``
    starts each rally (default: the machine serve of docs/reference.md §4.3). The rule set
    ``rules`` (``rallysim.core.rules.Rules``) is derived once from the shuttle model and the
    player count. ``max_hits`` is a rally's hit cap: the hit that reaches it ends the judging
    of that rally until its next serve (no later hit, net touch or landing counts, even within
    the same decision); None: no cap. ``trace`` holds what a task may need of each physics
    step of the last decision (``GameTrace``: the bases' x-distances to the shuttle, their
    motion, the hit state).

    The physics steps of a decision, judging included, run in one compiled call for every
    batch size (``rallysim.core.kernels.step``), with the players' kind's motion.
    """

    def __init__(self, n_envs: int, n_players: int = 1, shuttle: str = "paper",
                 seed: int | None = None,
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
        kernel = _kernel_kind(self.bodies)
        if type(self.flight) not in FLIGHTS:
            raise ValueError(f"no compiled flight for {type(self.flight).__name__}")
        self.serve: Serve = serve or MachineServe()
        self.shuttle = ShuttleState.zeros(n_envs)
        # One stream per environment, so that environment i of a batch seeded s replays a
        # single environment seeded s + i (Gymnasium's convention for vector seeds).
        self.streams = Streams(n_envs, validate_seed(seed))
        n, p = n_envs, n_players
        self.state = RallyState.zeros(n, p)
        self._active = np.ones(n, bool)
        self.every_env = np.arange(n)  # every game's index (not to be written)
        self._new_events = EventRows(n, p)  # each decision's events
        self.events = self._new_events.take()  # the last decision's (``step``'s) events
        # Boxes of the swept test, one column each: P faces (in their own frames), net, floor.
        half = self.bodies.face_half + RADIUS
        net_lo, net_hi = rules.net_box(self.court, RADIUS)
        floor_lo, floor_hi = rules.floor_box()
        self._lo = np.stack([-half] * p + [net_lo, floor_lo])
        self._hi = np.stack([half] * p + [net_hi, floor_hi])
        self._fwd = self.bodies.forward  # (N, P)
        self._q = np.zeros((n, p + 2, 3))  # tested points at the end of the step
        self._gap = np.zeros((n, p))  # |base x - shuttle x| after the last physics step
        s = PHYSICS_STEPS_PER_DECISION
        self.trace = GameTrace(gap=np.zeros((s + 1, n, p)), moved=np.zeros((s, n, p), bool),
                               live=np.zeros((s, n), bool), has_hit=np.zeros((s, n, p), bool))
        self._kernel: GameKernel = kernel(self)

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
        self.streams.seed(envs, validate_seed(seed))

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
        k, p = len(envs), self.n_players
        one = isinstance(receiver, int) and -p <= receiver < p  # (the tasks' call)
        # (one receiver for all: np.full is several times cheaper than np.broadcast_to)
        receiver = (np.full(k, receiver % p, np.int64) if one
                    else np.array(np.broadcast_to(np.asarray(receiver, np.int64), (k,))))
        if k and not (envs.min() >= 0 and envs.max() < self.n_envs):
            raise IndexError(f"games must be 0 to {self.n_envs - 1}, got {envs.tolist()[:10]}")
        if not one:
            if k and not (-p <= receiver.min() and receiver.max() < p):
                raise IndexError(f"receivers must be players 0 to {p - 1} (or -{p} to -1, from "
                                 f"the last), got {receiver.tolist()[:10]}")
            receiver %= p  # (as an index: -1 is the last player)
        if base_x is None:
            base_x = np.full((k, self.n_players), -2.7)
        self.bodies.reset(envs, base_x, theta, **body)
        pos, vel = self.serve(functools.partial(self.streams.random, envs), receiver)
        self._kernel.restart(self, envs, receiver, np.ascontiguousarray(pos, np.float64),
                             np.ascontiguousarray(vel, np.float64))

    # -- one decision ---------------------------------------------------------------------------
    def step(self, actions: np.ndarray, active: np.ndarray | None = None) -> Events:
        """Hold ``actions`` (N, P, 3) in [-1, 1] for one decision; return its events (a new
        ``Events``, never written again).

        ``active`` (N,) bool, optional: games left out are held still (bodies and shuttle keep
        their state and nothing happens to them), so a batch can wait on some of its games.
        Non-finite actions raise ``ValueError`` before anything moves: MuJoCo would reset the
        whole batch's state on them, not only the offending game's."""
        actions = np.asarray(actions)
        shape = (self.n_envs, self.n_players)
        if actions.shape[:2] != shape:  # (as NumPy broadcasts an assignment, or says why not)
            actions = np.broadcast_to(actions, (*shape, actions.shape[-1]))
        if not self._all_finite(actions):
            bad = np.flatnonzero(~np.isfinite(actions).reshape(len(actions), -1).all(axis=1))
            raise ValueError(f"actions must be finite; got NaN or inf for game(s) "
                             f"{bad[:10].tolist()}")
        self.bodies.set_actions(actions)
        self.events = self._new_events.take()
        frozen = None if active is None or active.all() else np.flatnonzero(~active)
        if frozen is not None:
            self._active[:] = active
            saved = self._snapshot(frozen)
        self._kernel.run(self, PHYSICS_STEPS_PER_DECISION)
        if frozen is not None:
            self._restore(frozen, saved)
            self._active[:] = True
        return self.events

    def _all_finite(self, actions: np.ndarray) -> bool:
        """Whether every action is finite (a few: as Python numbers, cheaper)."""
        if actions.size <= 16:
            return all(map(math.isfinite, actions.ravel().tolist()))
        finite = np.isfinite(actions)
        return np.count_nonzero(finite) == finite.size

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
        the bases' x-distances to it) after the state was set by hand."""
        self._kernel.refresh(self)

    def _run(self, steps: int) -> None:
        if not 0 <= steps <= PHYSICS_STEPS_PER_DECISION:  # (the trace's rows)
            raise ValueError(f"a call runs at most {PHYSICS_STEPS_PER_DECISION} physics steps")
        self._kernel.run(self, steps)

    def _physics_step(self) -> None:
        self._run(1)


def _kernel_kind(bodies: Any) -> type[GameKernel]:
    """The compiled steps of ``bodies``' kind of players."""
    if isinstance(bodies, SimpleBodies):
        return SimpleKernel
    if isinstance(bodies, HumanLikeBodies):
        return HumanLikeKernel
    raise TypeError(f"no compiled steps for players of {type(bodies).__name__}: "
                    "bodies must be SimpleBodies or HumanLikeBodies")
