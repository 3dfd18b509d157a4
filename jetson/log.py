"""The daemon's log: one JSON object per line, plus a human summary line each second.

Every record has `ts` (wall-clock Unix time), `t` (the daemon's clock, which a lockstep simulator
drives), `level`, `event` (a stable name to grep or filter on) and `msg` (a sentence for people),
then the event's own fields. The summary line goes, as text, to a second stream (stderr by
default) and, as a `summary` record, into the JSON log. Under systemd both land in the journal.

Writes are serialised by a lock: the camera thread logs too.
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections import deque
from collections.abc import Iterable
from typing import Any, TextIO

from jetson.clock import Clock, MonotonicClock

LEVELS = ("debug", "info", "warning", "error")


def _plain(value: Any) -> Any:
    """JSON-safe: numpy scalars and arrays become numbers and lists, NaN becomes null."""
    if isinstance(value, float):
        return value if math.isfinite(value) else None
    if hasattr(value, "tolist"):
        return _plain(value.tolist())
    if isinstance(value, dict):
        return {str(k): _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    if isinstance(value, bool | int | str) or value is None:
        return value
    return str(value)


class EventLog:
    def __init__(
        self,
        stream: TextIO,
        human: TextIO | None = None,
        clock: Clock | None = None,
        min_level: str = "info",
    ) -> None:
        if min_level not in LEVELS:
            raise ValueError(f"log level must be one of {LEVELS}, got {min_level!r}")
        self._stream = stream
        self._human = human
        self._clock = clock or MonotonicClock()
        self._min = LEVELS.index(min_level)
        self._lock = threading.Lock()

    def event(self, level: str, event: str, msg: str, **fields: Any) -> None:
        if LEVELS.index(level) < self._min:
            return
        record = {
            "ts": round(time.time(), 6),
            "t": round(self._clock.now(), 6),
            "level": level,
            "event": event,
            "msg": msg,
        }
        record.update(_plain(fields))
        line = json.dumps(record, separators=(",", ":"), allow_nan=False)
        with self._lock:
            try:
                self._stream.write(line + "\n")
                self._stream.flush()
            except (OSError, ValueError):
                pass  # a log that cannot be written must never stop the robot

    def debug(self, event: str, msg: str, **fields: Any) -> None:
        self.event("debug", event, msg, **fields)

    def info(self, event: str, msg: str, **fields: Any) -> None:
        self.event("info", event, msg, **fields)

    def warning(self, event: str, msg: str, **fields: Any) -> None:
        self.event("warning", event, msg, **fields)

    def error(self, event: str, msg: str, **fields: Any) -> None:
        self.event("error", event, msg, **fields)

    def summary(self, line: str, **fields: Any) -> None:
        self.event("info", "summary", line, **fields)
        if self._human is not None:
            with self._lock:
                try:
                    self._human.write(line + "\n")
                    self._human.flush()
                except (OSError, ValueError):
                    pass


def percentile(sorted_values: list[float], q: float) -> float:
    """The q-th percentile (0..100) of already sorted values, nearest rank; NaN when empty."""
    if not sorted_values:
        return math.nan
    rank = max(1, math.ceil(q / 100.0 * len(sorted_values)))
    return sorted_values[min(rank, len(sorted_values)) - 1]


class LatencyStats:
    """State -> Command latencies: the current summary window and the last `keep` overall."""

    def __init__(self, keep: int = 100_000) -> None:
        self.window: list[float] = []
        self.recent: deque[float] = deque(maxlen=keep)
        self.count = 0
        self.max_s = 0.0

    def add(self, seconds: float) -> None:
        self.window.append(seconds)
        self.recent.append(seconds)
        self.count += 1
        if seconds > self.max_s:
            self.max_s = seconds

    def take_window(self) -> list[float]:
        out, self.window = self.window, []
        return out

    @staticmethod
    def summary_ms(values: Iterable[float]) -> dict[str, float]:
        s = sorted(values)
        return {
            "n": len(s),
            "p50_ms": percentile(s, 50) * 1e3,
            "p99_ms": percentile(s, 99) * 1e3,
            "max_ms": (s[-1] * 1e3) if s else math.nan,
        }
