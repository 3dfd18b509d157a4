"""Session recordings: everything the decision saw and did, for `pete-jetson replay`.

One file per link session (a new file at every handshake), JSON lines, gzip-compressed when the
name ends in .gz (the default). Records, each with "kind":

    header      format, software, protocol fingerprint, the policy (path, sha256), the decision
                settings and control rate: what replay needs to rebuild the decision code
    reset       the decision's history was cleared (a new session starts with one)
    perception  a perception result the first time a State used it: id, time, rings (robot frame)
    cycle       one State and its answer: clock time, the State's fields, the perception id and
                age used, the Command, the decision's reason, and the latency (ms)
    event       link events, for context (ignored by replay)

Writing happens on a background thread: the control loop only queues a tuple, after its Command
is on the wire. The directory keeps at most `keep_bytes`: the oldest sessions are deleted first.
"""

from __future__ import annotations

import contextlib
import gzip
import io
import json
import queue
import threading
import time
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from protocol.framing import message_to_dict

FORMAT = "pete-jetson-session"
VERSION = 1
PATTERN = "session-*.jsonl*"


def _open(path: Path) -> io.TextIOBase:
    if path.suffix == ".gz":
        # Level 1: a fraction of level 6's CPU for most of its gain on these repetitive lines.
        return io.TextIOWrapper(gzip.open(path, "wb", compresslevel=1), encoding="utf-8")
    return path.open("w", encoding="utf-8")


def open_recording(path: Path) -> io.TextIOBase:
    if path.suffix == ".gz":
        return io.TextIOWrapper(gzip.open(path, "rb"), encoding="utf-8")
    return path.open(encoding="utf-8")


@dataclass(frozen=True, slots=True)
class CycleRecord:
    """What the loop queues per State; turned into JSON on the writer thread."""

    t: float
    state: Any
    perception_id: int | None
    perception_age_s: float | None
    command: Any
    reason: str
    perception: str
    rings: int
    error: str | None
    latency_ms: float
    decide_ms: float


class Recorder:
    def __init__(self, path: Path, header: dict[str, Any], flush_s: float = 1.0) -> None:
        self.path = path
        path.parent.mkdir(parents=True, exist_ok=True)
        self._file = _open(path)
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._flush_s = flush_s
        self._seen: set[int] = set()
        self.records = 0
        self.failed: str | None = None
        self._put({"kind": "header", "format": FORMAT, "version": VERSION, **header})
        self._thread = threading.Thread(target=self._run, name="pete-recorder", daemon=True)
        self._thread.start()

    def _put(self, item: Any) -> None:
        self._queue.put(item)

    def reset(self, t: float) -> None:
        self._put({"kind": "reset", "t": t})

    def event(self, t: float, event: str, **fields: Any) -> None:
        self._put({"kind": "event", "t": t, "event": event, **fields})

    def perception(self, result: Any) -> None:
        """Record a perception result once, the first time a cycle uses it."""
        if result.id in self._seen:
            return
        if len(self._seen) > 100_000:
            self._seen.clear()
        self._seen.add(result.id)
        self._put(
            {
                "kind": "perception",
                "id": result.id,
                "stamp": result.stamp_s,
                "rings": result.rings_robot_xy.tolist(),
                "frame": result.frame_index,
                "detections": result.detections,
                "process_ms": round(result.process_ms, 3),
                "error": result.error,
            }
        )

    def cycle(self, rec: CycleRecord) -> None:
        self._put(rec)

    @staticmethod
    def _cycle_dict(r: CycleRecord) -> dict[str, Any]:
        return {
            "kind": "cycle",
            "t": r.t,
            "state": message_to_dict(r.state),
            "p": r.perception_id,
            "age": r.perception_age_s,
            "cmd": message_to_dict(r.command),
            "reason": r.reason,
            "perception": r.perception,
            "rings": r.rings,
            "error": r.error,
            "latency_ms": round(r.latency_ms, 4),
            "decide_ms": round(r.decide_ms, 4),
        }

    def _run(self) -> None:
        last_flush = time.monotonic()
        while True:
            try:
                item = self._queue.get(timeout=self._flush_s)
            except queue.Empty:
                item = None
            if item is _CLOSE:
                break
            if item is not None and self.failed is None:
                record = self._cycle_dict(item) if isinstance(item, CycleRecord) else item
                try:
                    self._file.write(json.dumps(record, separators=(",", ":")) + "\n")
                    self.records += 1
                except (OSError, ValueError, TypeError) as exc:
                    # A full disk must not stop the robot: stop recording, say why once.
                    self.failed = str(exc)
            if time.monotonic() - last_flush >= self._flush_s and self.failed is None:
                with contextlib.suppress(OSError, ValueError):
                    self._file.flush()
                last_flush = time.monotonic()
        with contextlib.suppress(OSError, ValueError):
            self._file.close()

    def close(self, timeout_s: float = 5.0) -> None:
        self._put(_CLOSE)
        self._thread.join(timeout_s)


_CLOSE = object()


class RecordingDir:
    """Where sessions go: one new file per session, the oldest deleted beyond keep_bytes."""

    def __init__(self, directory: Path, keep_bytes: int = 2_000_000_000, compress: bool = True):
        self.directory = Path(directory)
        self.keep_bytes = keep_bytes
        self.compress = compress
        self._n = 0

    def new_path(self) -> Path:
        self._n += 1
        stamp = time.strftime("%Y%m%d-%H%M%S")
        suffix = ".jsonl.gz" if self.compress else ".jsonl"
        return self.directory / f"session-{stamp}-{self._n:03d}{suffix}"

    def prune(self) -> list[Path]:
        """Delete the oldest sessions until the folder holds at most keep_bytes."""
        files = sorted(self.directory.glob(PATTERN), key=lambda p: p.stat().st_mtime)
        total = sum(p.stat().st_size for p in files)
        removed = []
        for p in files:
            if total <= self.keep_bytes:
                break
            total -= p.stat().st_size
            with contextlib.suppress(OSError):
                p.unlink()
                removed.append(p)
        return removed

    def open(self, header: dict[str, Any]) -> Recorder:
        self.directory.mkdir(parents=True, exist_ok=True)
        self.prune()
        return Recorder(self.new_path(), header)
