"""The daemon's notion of "now", injectable so that a simulator can run it in lockstep.

Everything the daemon times by the clock (perception age, Hello resends, silence, the summary
second) reads a Clock; only the State -> Command latency is always measured with the real
perf_counter, because it measures this machine's work, not the match.
"""

from __future__ import annotations

import threading
import time
from typing import Protocol


class Clock(Protocol):
    def now(self) -> float:
        """Seconds on a monotonic time line (the origin is arbitrary)."""
        ...


class MonotonicClock:
    """The wall clock the robot runs on."""

    def now(self) -> float:
        return time.monotonic()


class ManualClock:
    """Time that moves only when told: lockstep simulation and tests. Thread-safe."""

    def __init__(self, start_s: float = 0.0) -> None:
        self._t = float(start_s)
        self._lock = threading.Lock()

    def now(self) -> float:
        with self._lock:
            return self._t

    def set(self, t_s: float) -> None:
        with self._lock:
            if t_s < self._t:
                raise ValueError(f"time cannot go backwards: {t_s} < {self._t}")
            self._t = float(t_s)

    def advance(self, dt_s: float) -> None:
        if dt_s < 0:
            raise ValueError(f"cannot advance by a negative time {dt_s}")
        with self._lock:
            self._t += dt_s
