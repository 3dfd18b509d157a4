"""Perception for the daemon: a camera thread that keeps only the latest result.

The control loop never waits for the camera: each State takes whatever result is newest and
judges its age (decide.py treats an old one as no rings and no goals, as the policy was trained
to see them). A result carries the goals and the robots the pipeline's goal and robot detectors
found, when it has them (jetson/perception/pipeline.py).
The thread owns the camera: it opens the source, runs the perception pipeline on every frame, and
when the camera fails or ends it logs why, closes it and opens it again, forever. It runs at a
lower priority than the control loop (jetson/threads.py): the loop first, perception with the
rest of the CPU. `pete-jetson run` runs it in a process of its own (jetson/camera_process.py),
so that its Python never holds the loop's interpreter.

Feeds other than the thread (all meet PerceptionFeed):
  SyncPerception   frames submitted by the caller and processed at once (a lockstep simulator
                   that needs every run to be identical)
  FixedPerception  one result that is always fresh (benchmarks, tests)
"""

from __future__ import annotations

import contextlib
import itertools
import threading
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from typing import Any, Protocol

import numpy as np
from numpy.typing import ArrayLike, NDArray

from jetson.clock import Clock
from jetson.log import EventLog
from jetson.threads import lower_this_thread

NO_GOALS = np.zeros((0, 3))
NO_GOALS.flags.writeable = False


# No robots seen: the same shape, (0, 3) x, y robot frame and alliance code.
NO_ROBOTS = NO_GOALS


def no_goals() -> NDArray[np.float64]:
    return NO_GOALS


def no_robots() -> NDArray[np.float64]:
    return NO_ROBOTS


@dataclass(frozen=True)
class Perceived:
    """One frame's rings in the robot frame (x right, y forward, metres), with its time on the
    daemon's clock; its goals, (N, 3) x, y robot frame and colour code
    (jetson/perception/goals.py), when the pipeline has a goal detector; and its robots, (N, 3)
    x, y robot frame and alliance code (jetson/perception/robots.py), when it has a robot
    detector (none otherwise)."""

    id: int
    stamp_s: float
    rings_robot_xy: NDArray[np.float64]
    frame_index: int = 0
    detections: int = 0
    process_ms: float = 0.0
    error: str | None = None  # perception raised on this frame: no rings to trust
    goals_robot: NDArray[np.float64] = field(default_factory=no_goals)
    robots_robot: NDArray[np.float64] = field(default_factory=no_robots)


class PerceptionFeed(Protocol):
    def latest(self) -> Perceived | None: ...


class FrameLike(Protocol):
    timestamp_s: float
    index: int


class SourceLike(Protocol):
    """jetson.perception.sources.FrameSource, as far as the thread uses it."""

    def read(self) -> Any: ...

    def close(self) -> None: ...


# Frame -> object with .rings_robot_xy (and .detections, .goals_robot with a goal detector and
# .robots_robot with a robot detector)
Processor = Callable[[Any], Any]


def _rings(result: Any) -> NDArray[np.float64]:
    rings = np.asarray(result.rings_robot_xy, dtype=np.float64)
    return rings.reshape(-1, 2) if rings.size else np.zeros((0, 2))


def _rows3(result: Any, name: str) -> NDArray[np.float64]:
    """A result's (N, 3) report `name` (goals_robot, robots_robot); none when it has none."""
    rows = getattr(result, name, None)
    if rows is None:
        return NO_GOALS
    rows = np.asarray(rows, dtype=np.float64)
    return rows.reshape(-1, 3) if rows.size else NO_GOALS


def _goals(result: Any) -> NDArray[np.float64]:
    return _rows3(result, "goals_robot")


def _robots(result: Any) -> NDArray[np.float64]:
    return _rows3(result, "robots_robot")


class _Ids:
    def __init__(self) -> None:
        self._next = itertools.count(1)

    def __call__(self) -> int:
        return next(self._next)


class CameraWorker:
    """The camera thread. latest() is safe from any thread (one reference swap under the GIL)."""

    def __init__(
        self,
        open_source: Callable[[], SourceLike],
        process: Processor,
        clock: Clock,
        log: EventLog,
        retry_s: float = 1.0,
        frame_clock: bool = False,
        error_log_period_s: float = 10.0,
    ) -> None:
        self._open_source = open_source
        self._process = process
        self._clock = clock
        self._log = log
        self._retry_s = retry_s
        # True when the source stamps frames on the daemon's own clock (the lockstep simulator);
        # a RealSense stamps on its own, so arrival time is used instead.
        self._frame_clock = frame_clock
        self._error_period = error_log_period_s
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._latest: Perceived | None = None
        self._ids = _Ids()
        self._last_error: tuple[str, float] | None = None
        self.frames = 0
        self.errors = 0
        self.opens = 0
        # Small copies of the frames for the recording and the dashboard (jetson.frames), when
        # the daemon has either; offered after the result is published.
        self.tap: Any = None
        self.tap_errors = 0
        # Called on the camera thread with each result as it is published (the camera's own
        # process hands it to the daemon's this way: jetson/camera_process.py).
        self.on_result: Callable[[Perceived], object] | None = None

    def latest(self) -> Perceived | None:
        return self._latest

    def start(self) -> None:
        if self._thread is not None:
            raise RuntimeError("camera thread already started")
        self._thread = threading.Thread(target=self._run, name="pete-camera", daemon=True)
        self._thread.start()

    def stop(self, timeout_s: float = 2.0) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(timeout_s)

    @property
    def alive(self) -> bool:
        return self._thread is not None and self._thread.is_alive()

    def _error(self, what: str, exc: BaseException) -> None:
        """Log a failure, but the same one at most every error_log_period_s: a camera that is
        unplugged for a minute should not fill the disk."""
        self.errors += 1
        text = f"{what}: {type(exc).__name__}: {exc}"
        now = time.monotonic()
        last = self._last_error
        if last is None or last[0] != text or now - last[1] >= self._error_period:
            self._log.error("camera_error", text, errors=self.errors)
            self._last_error = (text, now)

    def _run(self) -> None:
        lower_this_thread()  # the control loop first (jetson/threads.py)
        source: SourceLike | None = None
        try:
            while not self._stop.is_set():
                try:
                    source = self._turn(source)
                except Exception as exc:  # a bug must not end perception for the day
                    self._error("camera thread error", exc)
                    source = self._close(source)
                    self._stop.wait(self._retry_s)
        finally:
            self._close(source)

    def _turn(self, source: SourceLike | None) -> SourceLike | None:
        """Open the camera if needed, read one frame and process it; the source, or None when
        it failed and must be reopened."""
        if source is None:
            try:
                source = self._open_source()
            except Exception as exc:
                self._error("cannot open the camera", exc)
                self._stop.wait(self._retry_s)
                return None
            self.opens += 1
            desc = getattr(source, "description", type(source).__name__)
            self._log.info("camera_open", f"camera open: {desc}", opens=self.opens)
        try:
            frame = source.read()
        except Exception as exc:
            self._error("camera stopped delivering frames", exc)
            self._close(source)
            self._stop.wait(self._retry_s)
            return None
        if frame is None:
            self._log.warning("camera_end", "camera source ended; reopening it")
            self._close(source)
            self._stop.wait(self._retry_s)
            return None
        self._handle(frame)
        return source

    def _handle(self, frame: Any) -> None:
        stamp = float(frame.timestamp_s) if self._frame_clock else self._clock.now()
        t0 = time.perf_counter()
        try:
            result = self._process(frame)
            rings, goals, robots = _rings(result), _goals(result), _robots(result)
        except Exception as exc:
            index = int(getattr(frame, "index", 0))
            self._error(f"perception failed on frame {index}", exc)
            # Published, not swallowed: the control loop stops the robot while the newest frame
            # is one perception could not handle (decide.py).
            self._latest = Perceived(
                self._ids(), stamp, np.zeros((0, 2)), index, 0,
                (time.perf_counter() - t0) * 1e3, f"{type(exc).__name__}: {exc}",
            )  # fmt: skip
            self._hand_on(self._latest)
            return
        self.frames += 1
        self._latest = latest = Perceived(
            self._ids(),
            stamp,
            rings,
            int(getattr(frame, "index", 0)),
            len(getattr(result, "detections", ()) or ()),
            (time.perf_counter() - t0) * 1e3,
            goals_robot=goals,
            robots_robot=robots,
        )
        self._hand_on(latest)
        if self.tap is not None:
            try:
                self.tap.offer(latest.id, stamp, frame, result)
            except Exception as exc:  # pictures for people must never cost the robot its rings
                self.tap_errors += 1
                if self.tap_errors == 1:
                    self._log.error("camera_tap", f"cannot keep a copy of the frame: {exc!r}")

    def _hand_on(self, result: Perceived) -> None:
        if self.on_result is not None:
            self.on_result(result)

    @staticmethod
    def _close(source: SourceLike | None) -> None:
        if source is not None:
            # A failing camera may fail to close too; it is dropped either way.
            with contextlib.suppress(Exception):
                source.close()
        return None


class SyncPerception:
    """Frames processed when submitted, in the caller's thread: deterministic."""

    def __init__(self, process: Processor, clock: Clock) -> None:
        self._process = process
        self._clock = clock
        self._latest: Perceived | None = None
        self._ids = _Ids()

    def submit(self, frame: Any, stamp_s: float | None = None) -> Perceived:
        """Process a frame now; an exception is published as an error result (as the camera
        thread does), not raised."""
        stamp = self._clock.now() if stamp_s is None else stamp_s
        index = int(getattr(frame, "index", 0))
        t0 = time.perf_counter()
        try:
            result = self._process(frame)
            rings, goals, robots, error = _rings(result), _goals(result), _robots(result), None
            detections = len(getattr(result, "detections", ()) or ())
        except Exception as exc:
            rings, goals, robots = np.zeros((0, 2)), NO_GOALS, NO_ROBOTS
            error = f"{type(exc).__name__}: {exc}"
            detections = 0
        ms = (time.perf_counter() - t0) * 1e3
        self._latest = Perceived(
            self._ids(), stamp, rings, index, detections, ms, error, goals, robots
        )
        return self._latest

    def set_rings(self, rings_robot_xy: ArrayLike, stamp_s: float | None = None) -> Perceived:
        """A result from elsewhere (e.g. the simulator's own visibility), stamped now."""
        stamp = self._clock.now() if stamp_s is None else stamp_s
        rings = np.asarray(rings_robot_xy, dtype=np.float64).reshape(-1, 2)
        self._latest = Perceived(self._ids(), stamp, rings)
        return self._latest

    def latest(self) -> Perceived | None:
        return self._latest


class FixedPerception:
    """The same rings, always fresh."""

    def __init__(self, rings_robot_xy: ArrayLike, clock: Clock) -> None:
        self._rings = np.asarray(rings_robot_xy, dtype=np.float64).reshape(-1, 2)
        self._clock = clock

    def latest(self) -> Perceived:
        return Perceived(1, self._clock.now(), self._rings)
