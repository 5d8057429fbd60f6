"""What the fused physics steps of one game of one player share: ``OneGame`` (a game's steps
between those that need judging, which ``Game._judge`` judges) and the helpers its kernels call
(``HELPERS``, compiled by ``compiled_helpers``).

One HUMAN-LIKE game runs them (``rallysim.core.one_humanlike``). SIMPLE games of any batch size
run their steps, judging included, in ``rallysim.core.kernels.simple``.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

from rallysim.core import native
from rallysim.core.lanes import SCALARS


def paper_flight(px: float, py: float, pz: float, vx: float, vy: float, vz: float,
                 shot_time: float, fall: float, f: float, dt: float) -> tuple:
    """``PaperShuttle.fly`` of one shuttle on local numbers (``fall``: gravity * dt, ``f``: the
    damping factor): the new position, velocity and shot time."""
    vz -= fall
    vx *= f
    vy *= f
    vz *= f
    return px + vx * dt, py + vy * dt, pz + vz * dt, vx, vy, vz, shot_time + dt


def approach_counts(gap: float, moved: bool, todo: bool, good: int, bad: int, old_gap: float
                    ) -> tuple[int, int, float]:
    """``Game._shape`` of one live game on local numbers (``todo``: the player has not hit
    yet): the approach counts and the gap to keep."""
    closer = moved & (gap < old_gap) & todo
    return good + closer, bad + (todo ^ closer), gap


def load_game(motion: Any, q: Any, shot_time_a: Any, gap_a: Any, good_a: Any, bad_a: Any,
              has_hit_a: Any) -> tuple:
    """One live game's moving numbers from its arrays (``Game.lane_views``): the shuttle's
    position and velocity, its point in the face's frame, the shot time, the shaping's gap and
    counts, and whether the player has yet to hit (``_shape``'s todo)."""
    return (float(motion[0, 0]), float(motion[1, 0]), float(motion[2, 0]), float(motion[3, 0]),
            float(motion[4, 0]), float(motion[5, 0]), float(q[0, 0, 0]), float(q[0, 0, 1]),
            float(q[0, 0, 2]), shot_time_a.item(), gap_a.item(), good_a.item(), bad_a.item(),
            not has_hit_a.item())


def store_game(motion: Any, q: Any, shot_time_a: Any, gap_a: Any, good_a: Any, bad_a: Any,
               px: float, py: float, pz: float, vx: float, vy: float, vz: float, qx: float,
               qy: float, qz: float, shot_time: float, gap: float, good: int, bad: int) -> None:
    """``load_game``'s numbers (but todo) back to the arrays."""
    motion[0, 0], motion[1, 0], motion[2, 0] = px, py, pz
    motion[3, 0], motion[4, 0], motion[5, 0] = vx, vy, vz
    q[0, 0, 0], q[0, 0, 1], q[0, 0, 2] = qx, qy, qz
    shot_time_a[0], gap_a[0, 0] = shot_time, gap
    good_a[0, 0], bad_a[0, 0] = good, bad


# what the free steps of every kind of player do alike (``compiled_helpers``: compiled)
HELPERS = (paper_flight, approach_counts, load_game, store_game)


def compiled_helpers() -> tuple[Callable, ...]:
    """``HELPERS`` compiled (the compiled kernels call them)."""
    numba = native.numba_module()
    return tuple(numba.njit(helper) for helper in HELPERS)


class OneGame:
    """What the fused physics steps of one game share, whatever its player: ``run`` hands a
    step that needs judging to ``Game._judge``; a subclass runs the free steps between
    (``_steps``) and may run the steps out of play (``_held_steps``; by default the lanes
    code's, ``Game._run_lanes``)."""

    def run(self, game: Any, steps: int) -> None:
        """``steps`` physics steps of ``game``, from and to its arrays."""
        state, active = game.state, game._active
        done = 0
        while done < steps:
            if not (state.in_play.item() and active.item()):
                self._held_steps(game, steps - done)  # the rest of the decision
                return
            done += self._free_steps(game, steps - done)

    def _held_steps(self, game: Any, steps: int) -> None:
        """``steps`` steps of a game out of play (until its next reset): the lanes code's."""
        game._run_lanes(steps)

    def _free_steps(self, game: Any, steps: int) -> int:
        """Up to ``steps`` steps of a live game, until one needs judging (judged here too);
        the number of steps run."""
        run, judged, face0, world0 = self._steps(game, steps)
        if judged:
            g = game._lanes(SCALARS)
            game._judge(g, SCALARS, (face0, world0), True)
            game._store(g)
        return run

    def _steps(self, game: Any, steps: int) -> tuple[int, bool, tuple, tuple]:
        """The kernel's free steps of a game in play: the steps run, whether the last needs
        judging, and the points its box test started from (the face's frame, the world)."""
        raise NotImplementedError

    def kernel_in(self, game: Any) -> str:
        """What runs ``game``'s physics steps in this process: "compiled" or "python"."""
        raise NotImplementedError
