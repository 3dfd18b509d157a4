"""The daemon's log: one JSON object per line, plus a human summary line each second.

Every record has `ts` (wall-clock Unix time), `t` (the daemon's clock, which a lockstep simulator
drives), `level`, `event` (a stable name to grep or filter on) and `msg` (a sentence for people),
then the event's own fields. The summary line goes, as text, to a second stream (stderr by
default) and, as a `summary` record, into the JSON log. Under systemd both land in the journal.

Writes are serialised by a lock: the camera thread logs too. Nothing may log from a signal
handler (the interrupted thread may hold that lock): jetson/service.py's handlers only set a flag.

The log's rate is bounded whatever happens (LogLimits): a line repeated with the same event and
message is written a few times, then counted and written once as `repeated` ("link_down x312 in
10 s") when the repeats stop, or every `repeat_every_s` while they go on; each event and the log as
a whole have a token bucket, and lines they refuse are counted and reported in one `log_dropped`
line when lines flow again. The summary and the start / exit lines are never held back.
"""

from __future__ import annotations

import json
import math
import threading
import time
from collections import deque
from collections.abc import Callable, Iterable
from dataclasses import dataclass
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


@dataclass(frozen=True)
class LogLimits:
    """How many lines the log lets through (counted on the wall clock: the journal's rate)."""

    repeat_burst: int = 3  # the same event and message: this many lines, then counted
    repeat_every_s: float = 10.0  # one `repeated` line at most this often per repeated line
    repeat_quiet_s: float = 2.0  # repeats stopped: their `repeated` line is written this soon
    event_burst: float = 30.0  # one event's lines (any message): a token bucket
    event_rate: float = 2.0  # lines per second, sustained
    total_burst: float = 200.0  # all lines together
    total_rate: float = 20.0
    # Never held back: rare by nature, and the summary is the daemon's heartbeat.
    exempt: frozenset[str] = frozenset(
        {"summary", "start", "config", "signal", "stop_sent", "stop_failed", "exit"}
    )

    def __post_init__(self) -> None:
        for name in ("repeat_every_s", "repeat_quiet_s", "event_burst", "event_rate"):
            if not getattr(self, name) > 0:
                raise ValueError(f"log limit {name} must be positive")
        if not (self.repeat_burst >= 1 and self.total_burst >= 1 and self.total_rate > 0):
            raise ValueError("log limits: the bursts must be >= 1 and the rates positive")


class _Bucket:
    """A token bucket: `burst` lines at once, `rate` a second after that."""

    __slots__ = ("burst", "rate", "t", "tokens")

    def __init__(self, burst: float, rate: float, now: float) -> None:
        self.burst, self.rate, self.tokens, self.t = burst, rate, burst, now

    def take(self, now: float) -> bool:
        self.tokens = min(self.burst, self.tokens + (now - self.t) * self.rate)
        self.t = now
        if self.tokens >= 1.0:
            self.tokens -= 1.0
            return True
        return False


class _Repeat:
    """One (event, message): its bucket and the repeats not written yet."""

    __slots__ = ("bucket", "count", "first", "last", "level")

    def __init__(self, bucket: _Bucket, level: str) -> None:
        self.bucket, self.level = bucket, level
        self.count, self.first, self.last = 0, 0.0, 0.0


# Distinct (event, message) pairs remembered; beyond this the ones with nothing pending go.
_MAX_REPEAT_KEYS = 2048


class LogLevels:
    """debug/info/warning/error as calls of `event(level, ...)`: what a log gives its users."""

    def event(self, level: str, event: str, msg: str, **fields: Any) -> None:
        raise NotImplementedError

    def debug(self, event: str, msg: str, **fields: Any) -> None:
        self.event("debug", event, msg, **fields)

    def info(self, event: str, msg: str, **fields: Any) -> None:
        self.event("info", event, msg, **fields)

    def warning(self, event: str, msg: str, **fields: Any) -> None:
        self.event("warning", event, msg, **fields)

    def error(self, event: str, msg: str, **fields: Any) -> None:
        self.event("error", event, msg, **fields)


class EventLog(LogLevels):
    def __init__(
        self,
        stream: TextIO,
        human: TextIO | None = None,
        clock: Clock | None = None,
        min_level: str = "info",
        limits: LogLimits | None = None,
        wall: Callable[[], float] = time.monotonic,
    ) -> None:
        if min_level not in LEVELS:
            raise ValueError(f"log level must be one of {LEVELS}, got {min_level!r}")
        self._stream = stream
        self._human = human
        self._clock = clock or MonotonicClock()
        self._min = LEVELS.index(min_level)
        self._lock = threading.Lock()
        self.limits = limits or LogLimits()
        self._wall = wall  # the limits' clock (tests pass their own)
        self._repeats: dict[tuple[str, str], _Repeat] = {}
        self._events: dict[str, _Bucket] = {}
        self._total = _Bucket(self.limits.total_burst, self.limits.total_rate, wall())
        self._dropped = 0  # lines the buckets refused since the last log_dropped line
        self._dropped_since = 0.0
        self.lines = 0  # lines written
        self.held_back = 0  # lines not written one by one (repeats and drops), all told

    def event(self, level: str, event: str, msg: str, **fields: Any) -> None:
        if LEVELS.index(level) < self._min:
            return
        record = self._record(level, event, msg)
        record.update(_plain(fields))
        line = json.dumps(record, separators=(",", ":"), allow_nan=False)
        with self._lock:
            if event in self.limits.exempt:
                self._write(line)
                return
            now = self._wall()
            if not self._admit(level, event, msg, now):
                return
            self._write(line)

    def flush_repeats(self) -> None:
        """Write the `repeated` lines of repeats that stopped (or have gone on for
        repeat_every_s) and a `log_dropped` line for lines the buckets refused. The daemon calls
        this every summary; a final call before exiting writes whatever is pending."""
        with self._lock:
            now = self._wall()
            lim = self.limits
            for (event, msg), rep in list(self._repeats.items()):
                if rep.count and (
                    now - rep.last >= lim.repeat_quiet_s or now - rep.first >= lim.repeat_every_s
                ):
                    self._write_repeated(event, msg, rep, now)
            if self._dropped:
                self._write_dropped(now)

    def close(self) -> None:
        """Everything pending written, whatever its age (at exit)."""
        with self._lock:
            now = self._wall()
            for (event, msg), rep in list(self._repeats.items()):
                if rep.count:
                    self._write_repeated(event, msg, rep, now)
            if self._dropped:
                self._write_dropped(now)

    # --- the limits (called with the lock held) --------------------------------------------------

    def _admit(self, level: str, event: str, msg: str, now: float) -> bool:
        lim = self.limits
        key = (event, msg)
        rep = self._repeats.get(key)
        if rep is None:
            if len(self._repeats) >= _MAX_REPEAT_KEYS:
                self._repeats = {k: r for k, r in self._repeats.items() if r.count}
            rep = _Repeat(_Bucket(lim.repeat_burst, 1.0 / lim.repeat_every_s, now), level)
            self._repeats[key] = rep
        if not rep.bucket.take(now):
            if rep.count == 0:
                rep.first = now
            rep.count += 1
            rep.last = now
            self.held_back += 1
            if now - rep.first >= lim.repeat_every_s:
                self._write_repeated(event, msg, rep, now)
            return False
        if rep.count:
            self._write_repeated(event, msg, rep, now)
        bucket = self._events.get(event)
        if bucket is None:
            bucket = self._events[event] = _Bucket(lim.event_burst, lim.event_rate, now)
        # A line its event's bucket refuses costs the total nothing: a chatty event cannot use
        # up the lines the others need.
        if not (bucket.take(now) and self._total.take(now)):
            if self._dropped == 0:
                self._dropped_since = now
            self._dropped += 1
            self.held_back += 1
            return False
        if self._dropped:
            self._write_dropped(now)
        return True

    def _write_repeated(self, event: str, msg: str, rep: _Repeat, now: float) -> None:
        span = max(now - rep.first, rep.last - rep.first)
        n, rep.count = rep.count, 0
        record = self._record(
            rep.level, "repeated", f"{event} x{n} in {span:.0f} s (the same line, not written "
            f"one by one): {msg}",
        )  # fmt: skip
        record.update({"of": event, "count": n, "span_s": round(span, 3)})
        self._write(json.dumps(record, separators=(",", ":"), allow_nan=False))

    def _write_dropped(self, now: float) -> None:
        n, self._dropped = self._dropped, 0
        span = now - self._dropped_since
        record = self._record(
            "warning", "log_dropped", f"{n} log lines dropped in {span:.0f} s: more than the "
            "log's rate limit",
        )  # fmt: skip
        record.update({"count": n, "span_s": round(span, 3)})
        self._write(json.dumps(record, separators=(",", ":"), allow_nan=False))

    def _record(self, level: str, event: str, msg: str) -> dict[str, Any]:
        return {
            "ts": round(time.time(), 6),
            "t": round(self._clock.now(), 6),
            "level": level,
            "event": event,
            "msg": msg,
        }

    def _write(self, line: str) -> None:
        try:
            self._stream.write(line + "\n")
            self._stream.flush()
            self.lines += 1
        except (OSError, ValueError):
            pass  # a log that cannot be written must never stop the robot

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
