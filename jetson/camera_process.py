"""Perception in a process of its own: the camera thread, without sharing the daemon's interpreter.

The camera thread (jetson.camera_feed.CameraWorker) runs Python for every frame: the detector's
pre- and post-processing, placing the rings, keeping copies of frames. Python runs one thread at
a time in a process, so in the daemon's process that work takes turns with the control loop: a
State that arrives while the camera thread holds the interpreter waits. `pete-jetson run`
therefore runs the same CameraWorker in a process of its own (spawned: nothing of the daemon's
threads is copied; at the daemon's own priority), and the daemon reads what it needs from
shared memory (jetson/slots.py), never waiting:

- its newest result (jetson.camera_feed.Perceived, stamped on the machine's monotonic clock,
  which both processes share) and its counters, in the result slot;
- the frame copies for the recording and the dashboard (jetson.frames.FrameView), in the frame
  slot, which the dashboard's process reads too (RemoteTap on the daemon's side);
- its log lines, through a bounded queue the daemon drains a few at a time (a full queue drops
  lines and counts them; the camera's own log limits apply before that).

Everything CameraWorker does (reopening a camera that fails, publishing a frame perception
could not handle as an error result, rate-limited errors) happens in the camera's process as it
would in a thread. A model or camera config that cannot load fails start() with the error the
thread would have raised at start-up. The camera's process ends when the daemon stops it, and on
its own when the daemon's process is gone.
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import pickle
import queue
import signal
from collections import deque
from dataclasses import dataclass
from typing import Any

from jetson.camera_feed import Perceived
from jetson.errors import CameraProcessError
from jetson.frames import FrameView, frame_bytes_for, newest_view, view_for
from jetson.helper_process import Helper, HelperHandle, serve_until_stopped
from jetson.log import LogLevels
from jetson.slots import Latest, Slot

__all__ = ["CameraProcess", "RemoteTap"]

RESULT_BYTES = 256 * 1024
MAX_FRAME_BYTES = frame_bytes_for(1280)  # the widest frame copy a setting allows
LOG_QUEUE = 256  # log lines in flight from the camera's process
LOG_LINES_PER_TURN = 16  # drained by each latest() call, at most
START_TIMEOUT_S = 120.0  # a Jetson builds a TensorRT engine for a new model in about a minute
PARENT_CHECK_S = 0.5


@dataclass(frozen=True)
class FrameCopies:
    """The frame copies the camera keeps: at most one a `period_s`, `width` pixels wide."""

    period_s: float
    width: int


class _QueueLog(LogLevels):
    """The camera's process's log: each line goes to the daemon's (jetson.log.EventLog)."""

    def __init__(self, lines: Any) -> None:
        self._lines = lines
        self.dropped = 0

    def event(self, level: str, event: str, msg: str, **fields: Any) -> None:
        try:
            self._lines.put_nowait((level, event, msg, fields))
        except queue.Full:
            self.dropped += 1


def child_main(
    conn: Any,
    settings: Any,
    results: Slot,
    frames: Slot,
    copies: FrameCopies | None,
    lines: Any,
    daemon_pid: int,
) -> None:
    """The camera's process: build the pipeline, run the camera thread, hand its results on."""
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the daemon's to handle
    from jetson.camera_feed import CameraWorker
    from jetson.clock import MonotonicClock
    from jetson.frames import FrameTap
    from jetson.perception.pipeline import make_pipeline
    from jetson.perception.sources import open_source

    log = _QueueLog(lines)
    try:
        camera, pipeline = make_pipeline(settings)
    except Exception as exc:
        conn.send(("error", f"{type(exc).__name__}: {exc}"))
        return
    worker = CameraWorker(
        lambda: open_source(settings.source, camera.intrinsics),
        pipeline.process,
        MonotonicClock(),
        log,  # type: ignore[arg-type]
        retry_s=settings.retry_s,
        frame_clock=settings.frame_clock,
    )

    def hand_on(result: Perceived) -> None:
        counters = {"frames": worker.frames, "errors": worker.errors, "opens": worker.opens,
                    "log_dropped": log.dropped}  # fmt: skip
        with contextlib.suppress(Exception):
            results.put(pickle.dumps((result, counters), protocol=pickle.HIGHEST_PROTOCOL))

    worker.on_result = hand_on
    if copies is not None:
        tap = FrameTap(copies.period_s, copies.width)
        tap.sink = lambda view: frames.put(pickle.dumps(view, protocol=pickle.HIGHEST_PROTOCOL))
        worker.tap = tap
    conn.send(("ready", getattr(pipeline.detector, "provider", None)))
    worker.start()
    try:
        serve_until_stopped(conn, daemon_pid, PARENT_CHECK_S)
    finally:
        worker.stop(1.0)


class RemoteTap:
    """The frame copies of a camera in its own process, as the daemon reads them (what
    jetson.frames.FrameTap offers the recording and the dashboard: get(id), newest, views).
    `period_s` and `width` may change until the camera starts."""

    def __init__(self, slot: Slot, period_s: float, width: int, keep: int = 6) -> None:
        self.slot = slot
        self.period_s = period_s
        self.width = width
        self._latest = Latest(slot, wait=False)
        self._views: deque[FrameView] = deque(maxlen=keep)

    def _refresh(self) -> None:
        seq = self._latest.seq
        view = self._latest.get()
        if view is not None and self._latest.seq != seq:
            self._views.append(view)

    @property
    def views(self) -> tuple[FrameView, ...]:
        self._refresh()
        return tuple(self._views)

    @property
    def newest(self) -> FrameView | None:
        return newest_view(self.views)

    def get(self, result_id: int) -> FrameView | None:
        return view_for(self.views, result_id)


class CameraProcess(HelperHandle):
    """The daemon's handle on its camera's process (see the module doc): a PerceptionFeed."""

    def __init__(self, settings: Any, log: Any, frame_bytes: int = MAX_FRAME_BYTES) -> None:
        self.settings = settings
        self.log = log
        self._ctx = multiprocessing.get_context("spawn")
        self.results = Slot(self._ctx, RESULT_BYTES)
        self.frame_slot = Slot(self._ctx, frame_bytes)
        self._lines = self._ctx.Queue(LOG_QUEUE)
        self._latest = Latest(self.results, wait=False)
        self._helper: Helper | None = None
        self.tap: RemoteTap | None = None
        self.provider: str | None = None

    def frame_copies(self, period_s: float, width: int) -> RemoteTap:
        """The frame copies this camera keeps (for the recording and the dashboard): asked
        before start()."""
        if self.tap is None:
            self.tap = RemoteTap(self.frame_slot, period_s, width)
        return self.tap

    # --- PerceptionFeed --------------------------------------------------------------------

    def latest(self) -> Perceived | None:
        self._drain_log()
        got = self._latest.get()
        return None if got is None else got[0]

    @property
    def counters(self) -> dict[str, int]:
        """The camera thread's counts (frames, errors, opens) with its newest result."""
        got = self._latest.get()
        return {} if got is None else dict(got[1])

    @property
    def frames(self) -> int:
        return int(self.counters.get("frames", 0))

    @property
    def errors(self) -> int:
        return int(self.counters.get("errors", 0))

    @property
    def opens(self) -> int:
        return int(self.counters.get("opens", 0))

    def _drain_log(self) -> None:
        for _ in range(LOG_LINES_PER_TURN):
            try:
                level, event, msg, fields = self._lines.get_nowait()
            except (queue.Empty, OSError, ValueError):
                return
            with contextlib.suppress(Exception):
                self.log.event(level, event, msg, **fields)

    # --- the process -----------------------------------------------------------------------

    def start(self, timeout_s: float = START_TIMEOUT_S) -> None:
        if self._helper is not None:
            raise RuntimeError("camera process already started")
        copies = None if self.tap is None else FrameCopies(self.tap.period_s, self.tap.width)
        args = (self.settings, self.results, self.frame_slot, copies, self._lines, os.getpid())
        self._helper = Helper.spawn(child_main, args, "pete-camera")
        reply = self._helper.await_reply(timeout_s)
        if reply is None or reply[0] != "ready":
            self.stop(0.5)
            why = reply[1] if reply else "its process did not start in time"
            raise CameraProcessError(f"the camera cannot start: {why}")
        self.provider = reply[1]
        if self.provider is not None:
            self.log.info(
                "onnxruntime", f"ring detector runs on {self.provider}", detector=self.provider
            )

    def stop(self, timeout_s: float = 2.0) -> None:
        if self._helper is not None:
            self._helper.stop(timeout_s)
        self._drain_log()
