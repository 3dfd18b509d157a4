"""Session recordings: everything the decision saw and did, for `pete-jetson replay`.

One file per Brain session (a new file at every handshake with a new Brain boot id; a reconnect to
the same boot goes on in the same file, as the decision goes on with its memories), JSON lines,
gzip-compressed when the name ends in .gz (the default). Records, each with "kind":

    header      format, software, protocol fingerprint, the policy (path, sha256), the decision
                settings and control rate: what replay needs to rebuild the decision code
    reset       the decision's history was cleared (a new session starts with one)
    perception  a perception result the first time a State used it: id, time, rings (robot frame)
                and, when the camera saw goals, goals (x, y robot frame, colour code); when it
                saw robots, robots (x, y robot frame, alliance code: 1 red, 2 blue)
    cycle       one State and its answer: clock time, the State's fields, the perception id and
                age used, the Command, the decision's reason, and the latency (ms); while the
                partner link is up, the partner's report the decision was given and its age
    frame       a downscaled camera frame (JPEG colour and depth, base64) with its detection
                boxes, a few a second (`[record] frames_hz`): what the camera saw, for
                `pete-jetson dashboard --recording` (ignored by replay)
    event       link events (link_down, link_up), for context (ignored by replay)
    end         the last record of a file closed whole: how many records, and why it stopped
                early if it did ("stopped"); a file without one was cut off (version 2 on)

Writing happens on a background thread: the control loop only queues a tuple, after its Command
is on the wire. The directory keeps at most `keep_bytes` (`[record] keep_mb`): the oldest
sessions are deleted first, when a session starts and every second while it is written; a session
that alone reaches the budget stops there. A write that fails (a full disk, ENOSPC, or any other
OSError) stops the session's recording (`failed` says why; the daemon logs it once): the robot
never waits for the disk. The file is flushed every second, so power lost mid-write leaves a
recording that `pete-jetson replay` reads up to the cut.
"""

from __future__ import annotations

import contextlib
import errno
import gzip
import io
import json
import math
import queue
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from jetson.frames import FrameView, view_record
from jetson.threads import lower_this_thread
from protocol.framing import message_to_dict

FORMAT = "pete-jetson-session"
VERSION = 2  # 2: the end record
READABLE_VERSIONS = (1, 2)
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
    partner: Any = None  # jetson.partner.PartnerInput the decision was given, if any


def write_failure(exc: BaseException) -> str:
    """Why a write failed, for the log line."""
    if isinstance(exc, OSError) and exc.errno in (errno.ENOSPC, errno.EDQUOT):
        return f"the disk is full ({exc.strerror})"
    return f"cannot write it: {type(exc).__name__}: {exc}"


class Recorder:
    """One session's file. `budget`, when given, is asked after every flush (on the writer
    thread) and returns why the recording must stop, or None."""

    def __init__(
        self,
        path: Path,
        header: dict[str, Any],
        flush_s: float = 1.0,
        budget: Callable[[], str | None] | None = None,
        frames_hz: float = 0.0,
        frame_width: int = 160,
    ) -> None:
        self.path = path
        self.frame_period_s = 1.0 / frames_hz if frames_hz > 0 else math.inf
        self.frame_width = frame_width
        self._last_frame_s = -math.inf
        self.frames = 0
        self.frames_failed = 0
        path.parent.mkdir(parents=True, exist_ok=True)
        self._file = _open(path)
        self._queue: queue.SimpleQueue[Any] = queue.SimpleQueue()
        self._flush_s = flush_s
        self._budget = budget
        self._seen: set[int] = set()
        self.records = 0
        self.failed: str | None = None  # why recording stopped early (set by the writer thread)
        self._put({"kind": "header", "format": FORMAT, "version": VERSION, **header})
        self._thread = threading.Thread(target=self._run, name="pete-recorder", daemon=True)
        self._thread.start()

    def _put(self, item: Any) -> None:
        if self.failed is None:
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
        record = {
            "kind": "perception",
            "id": result.id,
            "stamp": result.stamp_s,
            "rings": result.rings_robot_xy.tolist(),
            "frame": result.frame_index,
            "detections": result.detections,
            "process_ms": round(result.process_ms, 3),
            "error": result.error,
        }
        goals = getattr(result, "goals_robot", None)
        if goals is not None and len(goals):  # none: the key is left out, as before goals
            record["goals"] = goals.tolist()
        robots = getattr(result, "robots_robot", None)
        if robots is not None and len(robots):  # none: the key is left out, as before robots
            record["robots"] = robots.tolist()
        self._put(record)

    def cycle(self, rec: CycleRecord) -> None:
        self._put(rec)

    def frame(self, view: FrameView | None) -> None:
        """Keep a camera frame (jetson.frames.FrameView), at most frames_hz a second; it is
        encoded on the writer thread."""
        if view is None or self.frame_period_s == math.inf:
            return
        if 0 <= view.stamp_s - self._last_frame_s < self.frame_period_s:
            return
        self._last_frame_s = view.stamp_s
        self.frames += 1
        self._put(view)

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
        } | (
            {}
            if r.partner is None
            else {"partner": message_to_dict(r.partner.report), "partner_age": r.partner.age_s}
        )

    def _frame_dict(self, view: FrameView) -> dict[str, Any] | None:
        try:
            return {"kind": "frame", **view_record(view, self.frame_width)}
        except Exception:  # a picture that cannot be encoded is left out, the session goes on
            self.frames_failed += 1
            return None

    def _run(self) -> None:
        lower_this_thread()  # the control loop first (jetson/threads.py)
        last_flush = time.monotonic()
        while True:
            try:
                item = self._queue.get(timeout=self._flush_s)
            except queue.Empty:
                item = None
            if item is _CLOSE:
                break
            if item is not None and self.failed is None:
                try:
                    if isinstance(item, CycleRecord):
                        record = self._cycle_dict(item)
                    elif isinstance(item, FrameView):
                        record = self._frame_dict(item)
                    else:
                        record = item
                    if record is not None:
                        self._file.write(json.dumps(record, separators=(",", ":")) + "\n")
                        self.records += 1
                except (OSError, ValueError, TypeError) as exc:
                    # A full disk must not stop the robot: stop recording, say why (once).
                    self._stop(write_failure(exc))
            if self.failed is None and time.monotonic() - last_flush >= self._flush_s:
                last_flush = time.monotonic()
                try:
                    self._file.flush()
                except (OSError, ValueError) as exc:
                    self._stop(write_failure(exc))
                else:
                    reason = self._budget() if self._budget is not None else None
                    if reason:
                        self._stop(reason, cleanly=True)
        if self.failed is None:
            try:
                self._end(None)
            except (OSError, ValueError) as exc:
                self.failed = write_failure(exc)
                self._close_quietly()

    def _end(self, stopped: str | None) -> None:
        end = {"kind": "end", "records": self.records, "stopped": stopped}
        self._file.write(json.dumps(end, separators=(",", ":")) + "\n")
        self._file.close()

    def _stop(self, reason: str, cleanly: bool = False) -> None:
        """No more writing. A file stopped by its budget is closed whole (its end record says
        why); one whose write failed is closed as far as it goes (replay reads up to the cut)."""
        self.failed = reason
        if cleanly:
            try:
                self._end(reason)
                return
            except (OSError, ValueError) as exc:
                self.failed = f"{reason}; then {write_failure(exc)}"
        self._close_quietly()

    def _close_quietly(self) -> None:
        with contextlib.suppress(Exception):
            self._file.close()  # closes the file descriptor even when its last flush fails

    def close(self, timeout_s: float = 5.0) -> None:
        """Stop after what is queued; wait at most timeout_s for the writer (0: do not wait, the
        thread finishes on its own)."""
        self._queue.put(_CLOSE)
        if timeout_s > 0:
            self._thread.join(timeout_s)


_CLOSE = object()


class RecordingDir:
    """Where sessions go: one new file per session, the oldest deleted beyond keep_bytes (the
    session being written is never deleted; if it alone reaches keep_bytes it stops)."""

    def __init__(
        self,
        directory: Path,
        keep_bytes: int = 2_000_000_000,
        compress: bool = True,
        flush_s: float = 1.0,
        frames_hz: float = 0.0,
        frame_width: int = 160,
    ) -> None:
        self.directory = Path(directory)
        self.frames_hz = frames_hz  # camera frames kept a second (0: none)
        self.frame_width = frame_width
        self.keep_bytes = keep_bytes
        self.compress = compress
        self.flush_s = flush_s  # how often a session is flushed and the budget looked at
        self._n = 0

    def new_path(self) -> Path:
        """A name no session has yet (a daemon restarted within the second counts on)."""
        stamp = time.strftime("%Y%m%d-%H%M%S")
        suffix = ".jsonl.gz" if self.compress else ".jsonl"
        while True:
            self._n += 1
            path = self.directory / f"session-{stamp}-{self._n:03d}{suffix}"
            if not path.exists():
                return path

    def sessions(self) -> list[tuple[Path, int]]:
        """The session files with their sizes, oldest first (a file that vanishes while
        looking is left out)."""
        found = []
        for p in self.directory.glob(PATTERN):
            try:
                st = p.stat()
            except OSError:
                continue
            found.append((st.st_mtime, p.name, p, st.st_size))
        return [(p, size) for _, _, p, size in sorted(found)]

    def prune(self, keep: Path | None = None) -> list[Path]:
        """Delete the oldest sessions (never `keep`, the one being written) until the folder
        holds at most keep_bytes."""
        files = self.sessions()
        total = sum(size for _, size in files)
        removed = []
        for p, size in files:
            if total <= self.keep_bytes:
                break
            if p == keep:
                continue
            try:
                p.unlink()
            except FileNotFoundError:
                pass
            except OSError:
                continue
            total -= size
            removed.append(p)
        return removed

    def enforce(self, current: Path) -> str | None:
        """The budget, while `current` is written: older sessions go first; None while it
        fits, else why `current` must stop."""
        self.prune(keep=current)
        try:
            size = current.stat().st_size
        except OSError:
            return None
        if size >= self.keep_bytes:
            return (
                f"the session reached the recordings' budget on its own ({size / 1e6:.3g} MB "
                f"of keep_mb {self.keep_bytes / 1e6:.3g})"
            )
        return None

    def open(self, header: dict[str, Any]) -> Recorder:
        self.directory.mkdir(parents=True, exist_ok=True)
        self.prune()
        path = self.new_path()
        return Recorder(
            path, header, self.flush_s, budget=lambda: self.enforce(path),
            frames_hz=self.frames_hz, frame_width=self.frame_width,
        )  # fmt: skip
