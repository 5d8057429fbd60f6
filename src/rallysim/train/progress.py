"""Progress lines for long work whose output is not a terminal (a log file, CI, a pipe).

A ``Heartbeat`` prints one line at least every ``every`` seconds from a daemon thread: the
label (stage and seed), the phase, steps done of the total, the rate and the ETA. The work
only updates counters; the thread does the printing, so a phase that makes no steps (the
warm start's behaviour cloning, an evaluation) still reports that it is alive.
"""

from __future__ import annotations

import math
import sys
import threading
import time
from collections.abc import Callable

Say = Callable[[str], None]
HEARTBEAT_S = 30.0


def say_stderr(text: str) -> None:
    # one write per line, so that the heartbeat's thread and the work never split a line
    sys.stderr.write(text + "\n")
    sys.stderr.flush()


def progress_lines() -> Say | None:
    """Where progress lines go: stderr when it is not a terminal (a log, CI, a pipe); None on
    a terminal, where a bar or the results themselves show progress."""
    return None if sys.stderr.isatty() else say_stderr


def format_eta(seconds: float) -> str:
    if not math.isfinite(seconds):  # no rate yet
        return "?"
    minutes, s = divmod(round(seconds), 60)
    return f"{minutes}:{s:02d}" if minutes < 60 else f"{minutes // 60}:{minutes % 60:02d}:{s:02d}"


class Heartbeat:
    """``with Heartbeat("low seed 0", total, say) as beat: ... beat.update(done)``."""

    def __init__(self, label: str, total: int, say: Say = say_stderr,
                 every: float | None = None, unit: str = "steps") -> None:
        every = HEARTBEAT_S if every is None else every
        if every <= 0:
            raise ValueError(f"every must be > 0 seconds, got {every}")
        self.label, self.total, self.say, self.every, self.unit = label, total, say, every, unit
        self.phase = "starting"
        self.done = 0
        self._phase_start = time.perf_counter()
        self._phase_done0 = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None

    def set_phase(self, phase: str, restart_rate: bool = True,
                  count: tuple[int, int, str] | None = None) -> None:
        """Name what is running; ``restart_rate``: measure the rate from now (a new kind of
        work), else keep the running rate (more of the same work, e.g. the next seed);
        ``count``: (done, total, unit) when the new phase counts other units (a warm start's
        epochs before PPO's decisions)."""
        if count is not None:  # (before the name: the heartbeat's thread reads both)
            self.done, self.total, self.unit = int(count[0]), int(count[1]), count[2]
        self.phase = phase
        if restart_rate:
            self._phase_start = time.perf_counter()
            self._phase_done0 = self.done

    def update(self, done: int) -> None:
        self.done = int(done)

    def line(self) -> str:
        elapsed = time.perf_counter() - self._phase_start
        rate = (self.done - self._phase_done0) / elapsed if elapsed > 0 else 0.0
        eta = max(0.0, self.total - self.done) / rate if rate > 0 else float("nan")
        shown = f"{rate:,.0f}" if rate >= 10 else f"{rate:.2g}"
        return (f"{self.label} {self.phase}: {self.done:,}/{self.total:,} {self.unit}, "
                f"{shown}/s, ETA {format_eta(eta)} ({elapsed:.0f} s in this phase)")

    def _run(self) -> None:
        while not self._stop.wait(self.every):
            self.say(self.line())

    def __enter__(self) -> Heartbeat:
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()
        return self

    def __exit__(self, *exc: object) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join()
