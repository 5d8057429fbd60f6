"""Each game's own random stream, for a whole batch in one array.

Game i of a batch seeded s replays a single game seeded s + i, so every game draws from a
stream of its own: NumPy's ``default_rng(s + i)``, a PCG64 generator. Held as N NumPy
``Generator`` objects, a batch's resets called into NumPy once per game and draw site.
``Streams`` keeps the N generators' states in one array instead, and draws doubles for any set
of games in one compiled call per draw site, bit for bit what ``Generator.random`` gives from
the same state (tested): PCG64's 128-bit step and XSL-RR output, and NumPy's 53-bit double.
"""

from __future__ import annotations

import functools
from typing import Any

import numpy as np

from rallysim.core import native

_MASK64 = (1 << 64) - 1


def _mulhi(a, b):  # compiled by Numba: the high 64 bits of the 128-bit product a * b
    m32, s32 = np.uint64(0xFFFFFFFF), np.uint64(32)
    a_lo, a_hi, b_lo, b_hi = a & m32, a >> s32, b & m32, b >> s32
    lolo, hilo, lohi = a_lo * b_lo, a_hi * b_lo, a_lo * b_hi
    cross = (lolo >> s32) + (hilo & m32) + lohi
    return a_hi * b_hi + (hilo >> s32) + (cross >> s32)


def _doubles_with(mulhi):
    # PCG64's multiplier (NumPy's PCG_DEFAULT_MULTIPLIER_128), as two 64-bit halves
    mult_hi, mult_lo = np.uint64(0x2360ED051FC65DA4), np.uint64(0x4385DF649FCCF645)

    def doubles(state, games, out):  # compiled by Numba
        one, s11, s58 = np.uint64(1), np.uint64(11), np.uint64(58)
        s63, s64 = np.uint64(63), np.uint64(64)
        for i in range(games.shape[0]):  # (Numba does not check indices: every one first)
            if games[i] < 0 or games[i] >= state.shape[0]:
                raise IndexError("stream index out of range")
        for i in range(games.shape[0]):
            g = games[i]
            hi, lo, inc_hi, inc_lo = state[g, 0], state[g, 1], state[g, 2], state[g, 3]
            for j in range(out.shape[1]):
                # state = state * multiplier + increment (mod 2**128)
                new_hi = mulhi(lo, mult_lo) + lo * mult_hi + hi * mult_lo
                new_lo = lo * mult_lo
                lo = new_lo + inc_lo
                hi = new_hi + inc_hi + (one if lo < new_lo else np.uint64(0))
                # XSL-RR: the two halves xored, rotated right by the state's top 6 bits
                x, rot = hi ^ lo, hi >> s58
                word = (x >> rot) | (x << ((s64 - rot) & s63))
                out[i, j] = np.float64(word >> s11) * (1.0 / 9007199254740992.0)
            state[g, 0], state[g, 1] = hi, lo
    return doubles


@functools.cache
def _compiled() -> Any:
    numba = native.numba_module()
    return native.jit(_doubles_with(numba.njit(inline="always")(_mulhi)))


class Streams:
    """``n`` PCG64 streams, stream i started as ``np.random.default_rng(seed + i)`` (fresh
    entropy for each where ``seed`` is None)."""

    def __init__(self, n: int, seed: int | None = None) -> None:
        # per stream: the state's high and low 64 bits, then the increment's
        self.state = np.zeros((n, 4), np.uint64)
        self.seed(np.arange(n), seed)

    def __len__(self) -> int:
        return len(self.state)

    def seed(self, games: np.ndarray, seed: int | None) -> None:
        """Restart the streams of ``games``: ``games[j]`` as ``default_rng(seed + j)``."""
        games = self._indices(games)
        if games.size and (games.min() < 0 or games.max() >= len(self.state)):
            raise IndexError(self._out_of_range(games))
        for j, g in enumerate(games):
            s = np.random.PCG64(None if seed is None else seed + j).state["state"]
            self.state[g] = [s["state"] >> 64, s["state"] & _MASK64,
                             s["inc"] >> 64, s["inc"] & _MASK64]

    def random(self, games: np.ndarray, k: int) -> np.ndarray:
        """(len(games), k) doubles in [0, 1): ``k`` from each of the streams ``games`` (distinct
        indices), as ``Generator.random(k)`` draws them."""
        games = self._indices(games)
        out = np.empty((len(games), k))
        if len(games) and k:
            try:
                _compiled()(self.state, games, out)
            except IndexError:
                raise IndexError(self._out_of_range(games)) from None
        return out

    def _indices(self, games: np.ndarray) -> np.ndarray:
        """``games`` as contiguous int64 indices; ``IndexError`` for anything but a 1-D array
        of integers (a mask is not indices). Their range is checked where they are used."""
        a = np.asarray(games)
        if a.ndim != 1 or (a.size and a.dtype.kind not in "iu"):
            raise IndexError(f"games must be a 1-D array of stream indices, got {a!r}")
        return np.ascontiguousarray(a, np.int64)

    def _out_of_range(self, games: np.ndarray) -> str:
        n = len(self.state)
        return (f"stream index out of range for {n} streams: "
                f"{games[(games < 0) | (games >= n)][:5].tolist()}")

    def generator(self, game: int) -> np.random.Generator:
        """A NumPy ``Generator`` that goes on from stream ``game``'s present state (a copy:
        drawing from it does not advance the stream)."""
        hi, lo, inc_hi, inc_lo = (int(v) for v in self.state[game])
        bits = np.random.PCG64()
        bits.state = {"bit_generator": "PCG64",
                      "state": {"state": hi << 64 | lo, "inc": inc_hi << 64 | inc_lo},
                      "has_uint32": 0, "uinteger": 0}
        return np.random.Generator(bits)
