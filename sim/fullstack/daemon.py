"""The Jetson daemon inside the simulator's process, on the simulated clock.

It is the real daemon (jetson.loop.Daemon with jetson.decide.Decider and the ONNX policy) and the
real camera thread (jetson.service.make_camera: a CameraWorker reading a frame stream
jetson.perception serves, the detector and the localiser). Only two things differ from
`pete-jetson run`, both for determinism:

- its clock is a ManualClock the simulator sets to the Brain's time before each turn, and the
  simulator decides when it turns (`service`): after brain_host's bytes for a loop step have
  crossed the cable, so every State is answered from the same inputs on every run;
- camera results reach the daemon through a gate: a frame rendered at time t is processed at once
  by the camera thread, and the daemon may see the result from t + perception_latency_s on (a
  Jetson's perception takes tens of ms). The simulator waits for the result before that moment,
  so no result is ever early or late by the wall clock.

`kill()` stops it dead, as SIGKILL would: no stop Command, its port closed. A daemon that must
get real signals (SIGTERM, SIGKILL) or a full disk runs as its own process instead:
sim/fullstack/daemon_process.py hosts this same class there.
"""

from __future__ import annotations

import threading
import time
from collections import deque
from dataclasses import dataclass
from pathlib import Path
from typing import Any, TextIO

from jetson.camera_feed import Perceived
from jetson.clock import Clock
from jetson.frames import FrameTap
from jetson.service import build, make_camera, policy_reads_goals, policy_reads_robots
from jetson.settings import Settings
from jetson.stats import Counters
from protocol import messages
from sim.errors import DaemonError

RESULT_TIMEOUT_S = 10.0
ERROR_POLL_S = 0.005  # how often a wait for a frame's result looks for a camera error


@dataclass(frozen=True)
class DaemonOptions:
    policy: Path
    camera: bool = True
    detector: str = "classical"  # classical | cnn
    detector_model: Path | None = None
    camera_config: Path | None = None  # pete-camera JSON (mount + intrinsics)
    perception_latency_s: float = 0.05
    valid_ms: int = 250
    boot_id: int = 0x7E75_0001
    fingerprint: int = messages.FINGERPRINT
    log_level: str = "info"
    record_dir: Path | None = None  # the daemon's session recordings (pete-jetson replay)
    # What decides ([decision] player): the policy, or the scripted alliance as `role`.
    player: str = "policy"
    role: str = "24in"


class GatedFeed:
    """The camera thread's results, each released to the daemon at its frame time + latency."""

    def __init__(self, clock: Clock, latency_s: float) -> None:
        if latency_s < 0:
            raise ValueError(f"perception latency must be >= 0, got {latency_s}")
        self._clock = clock
        self.latency_s = latency_s
        self._pending: deque[tuple[float, Perceived]] = deque()
        self._latest: Perceived | None = None
        self.enabled = True

    def offer(self, result: Perceived, frame_time_s: float) -> None:
        self._pending.append((frame_time_s + self.latency_s, result))

    def latest(self) -> Perceived | None:
        now = self._clock.now()
        while self._pending and self._pending[0][0] <= now + 1e-9:
            self._latest = self._pending.popleft()[1]
        return self._latest


class RecordingFeed:
    """Realtime: the camera thread's newest result as it is, each one kept for scoring."""

    def __init__(self, results: dict[int, Perceived]) -> None:
        self.camera: Any = None
        self._results = results

    def latest(self) -> Perceived | None:
        if self.camera is None:
            return None
        got = self.camera.latest()
        if got is not None:
            self._results.setdefault(got.frame_index, got)
        return got


class DaemonHost:
    """The daemon, its camera thread and its gate, wired to a port path and a frame stream."""

    def __init__(
        self,
        options: DaemonOptions,
        clock: Clock,
        port_path: Path,
        frames_address: str | None,
        log_stream: TextIO,
        realtime: bool = False,
    ) -> None:
        self.options = options
        self.realtime = realtime
        self.clock = clock
        self.settings = Settings().with_overrides(
            link={"port": str(port_path)},
            decision={
                "valid_ms": options.valid_ms,
                "player": options.player,
                "role": options.role,
            },
            policy={"path": str(options.policy)},
            camera={
                "enabled": options.camera,
                "source": frames_address,
                "detector": options.detector,
                "model": str(options.detector_model) if options.detector_model else None,
                "config": str(options.camera_config) if options.camera_config else None,
                # Lockstep frames carry the daemon's (simulated) time; realtime ones do not.
                "frame_clock": not realtime,
                "retry_s": 0.2,
            },
            record={"dir": str(options.record_dir) if options.record_dir else ""},
            log={"level": options.log_level, "summary": False},
        )
        self.results: dict[int, Perceived] = {}
        self.failed_frames: set[int] = set()
        self.feed: GatedFeed | RecordingFeed | None = None
        if options.camera:
            if frames_address is None:
                raise DaemonError("the camera needs a frame stream address")
            self.feed = (
                RecordingFeed(self.results)
                if realtime
                else GatedFeed(clock, options.perception_latency_s)
            )
        try:
            # What `pete-jetson run` builds, with the simulator's clock and the gated feed.
            self.service_ = build(
                self.settings,
                clock,
                log_stream=log_stream,
                perception=self.feed,
                boot_id=options.boot_id,
                fingerprint=options.fingerprint,
            )
        except Exception as exc:  # PolicyError, SettingsError, onnxruntime's own
            raise DaemonError(f"the daemon cannot start: {exc}") from exc
        self.daemon = self.service_.daemon
        self._turn = self.daemon.service  # one turn of the daemon's loop
        self.log = self.daemon.log
        self.camera: Any = None
        if options.camera:
            try:
                decider = self.daemon.decider
                self.camera = make_camera(
                    self.settings, clock, self.log, robots=policy_reads_robots(decider),
                    goals=policy_reads_goals(decider),
                )  # fmt: skip
            except Exception as exc:  # a missing detector model, a bad camera config
                raise DaemonError(f"the daemon's camera cannot start: {exc}") from exc
            if isinstance(self.feed, RecordingFeed):
                self.feed.camera = self.camera
            if options.record_dir is not None and self.settings.record.frames_hz > 0:
                # The recording keeps small camera frames, as `pete-jetson run`'s does.
                r = self.settings.record
                self.daemon.frames = self.camera.tap = FrameTap(1.0 / r.frames_hz, r.frame_width)
            self.camera.on_result = self._published
        # Told by the camera thread as it publishes each result: lockstep's wait for a frame's
        # result sleeps on it instead of polling (a poller's wakeups take the GIL from the very
        # thread it waits for).
        self._published_cond = threading.Condition()
        self.alive = True
        self.exits: list[Any] = []  # a process's ends (DaemonProcess); none in this process
        self._shut = False
        self._thread: threading.Thread | None = None
        # (frame index, frame time, camera errors when it was sent)
        self._awaiting: deque[tuple[int, float, int]] = deque()

    # --- running --------------------------------------------------------------------------------

    def start(self) -> None:
        mode = "realtime" if self.realtime else "lockstep"
        self.daemon.log.info("start", f"pete-jetson in the simulator ({mode})")
        if self.camera is not None:
            self.camera.start()

    def start_thread(self, stop: threading.Event) -> threading.Thread:
        """Realtime: the daemon's loop in its own thread on the wall clock, as on the robot."""

        def loop() -> None:
            while self.alive and not stop.is_set():
                try:
                    self.daemon.service(0.02)
                except Exception as exc:  # the daemon's own run() logs and goes on, as here
                    self.daemon.log.error("internal_error", f"{type(exc).__name__}: {exc}")
                    time.sleep(0.05)

        th = threading.Thread(target=loop, name="pete-daemon", daemon=True)
        th.start()
        self._thread = th
        return th

    def service(self, rx_total: int, timeout_s: float = 5.0) -> None:
        """One turn at the clock's time: connect or say Hello when due, then read until the
        daemon has `rx_total` bytes on its current connection, answering what arrives."""
        if not self.alive:
            return
        self._release_results()
        d = self.daemon
        turn = self._turn
        turn(0.0)
        # Daemon.pump_until's loop, through _turn (the daemon's own service(), captured when
        # built: the daemon process replaces the instance's with its lockstep turn).
        deadline = time.monotonic() + timeout_s
        while not (d.link is None or d.link.rx_bytes >= rx_total):
            left = deadline - time.monotonic()
            if left <= 0:
                raise DaemonError(
                    f"the daemon read {d.link.rx_bytes if d.link else 0} of {rx_total} bytes "
                    f"within {timeout_s:g} s"
                )
            turn(min(left, 0.02))

    @property
    def tx_on_connection(self) -> int:
        link = self.daemon.link
        return link.tx_bytes if link is not None else 0

    @property
    def connected(self) -> bool:
        return self.daemon.link is not None

    # What the match reads of the daemon (sim.fullstack.daemon_process.DaemonProcess has the same).

    @property
    def last_command_seq(self) -> int:
        cmd = self.daemon.last_command
        return 0 if cmd is None else int(cmd.seq)

    @property
    def counters(self) -> Counters:
        return self.daemon.counters

    @property
    def latencies(self) -> list[float]:
        """Every State -> Command latency so far, seconds."""
        return list(self.daemon.latency.recent)

    def link_errors(self) -> dict[str, int]:
        return self.daemon.link_errors()

    @property
    def link_state(self) -> str:
        return self.daemon.state

    # --- camera ---------------------------------------------------------------------------------

    def frame_sent(self, index: int, frame_time_s: float) -> None:
        """The simulator sent frame `index`, rendered at `frame_time_s` on the daemon's clock."""
        if self.camera is not None and self.alive and not self.realtime:
            self._awaiting.append((index, frame_time_s, self.camera.errors))

    def _release_results(self) -> None:
        """Wait for the camera thread's result on every frame whose release time has come."""
        assert self.feed is not None or not self._awaiting
        now = self.clock.now()
        while self._awaiting and self._awaiting[0][1] + self.options.perception_latency_s <= now:
            index, t, errors = self._awaiting.popleft()
            result = self._wait_result(index, errors)
            if result is None:
                self.failed_frames.add(index)
                continue
            self.results[index] = result
            assert self.feed is not None
            self.feed.offer(result, t)

    def _wait_result(self, index: int, errors: int) -> Perceived | None:
        """The result of frame `index`, or None when the pipeline failed on it. One frame is in
        flight at a time (the latency is shorter than the frame period), so a camera error
        after it was sent is its own."""
        deadline = time.monotonic() + RESULT_TIMEOUT_S
        with self._published_cond:
            while (left := deadline - time.monotonic()) > 0:
                got = self.camera.latest()
                if got is not None and got.frame_index >= index:
                    return got if got.frame_index == index else None
                if self.camera.errors > errors:
                    return None  # the pipeline failed on this frame (the thread logged why)
                # A camera error publishes nothing: look again every few milliseconds.
                self._published_cond.wait(min(left, ERROR_POLL_S))
        raise DaemonError(f"the camera thread gave no result for frame {index} in time")

    def _published(self, result: Perceived) -> None:
        """The camera thread published `result` (its on_result)."""
        with self._published_cond:
            self._published_cond.notify_all()

    def drop_pending_frames(self) -> None:
        """The stream stopped: frames in flight will never be processed."""
        self._awaiting.clear()

    # --- ending ---------------------------------------------------------------------------------

    def kill(self) -> None:
        """Dead at once, as SIGKILL: no stop Command, no goodbye; the OS closes its port."""
        if not self.alive:
            return
        self.alive = False
        if self._thread is not None:
            self._thread.join(1.0)  # it ends at its next turn, having said nothing
        if self.daemon.link is not None:
            self.daemon.link.close()
        if self.camera is not None:
            self.camera.stop(0.0)  # told to stop; nobody waits for it (nor reads it any more)

    def sigterm(self, delay_s: float = 0.0) -> None:
        raise DaemonError("a real SIGTERM needs the daemon as its own process (--daemon process)")

    def set_disk_full(self, full: bool) -> None:
        raise DaemonError("a full disk needs the daemon as its own process (--daemon process)")

    def shutdown(self) -> None:
        """A clean exit at the end of the match: the daemon sends a stop and logs its totals."""
        if self.alive:
            self.alive = False
            if self._thread is not None:
                self._thread.join(1.0)
            self.daemon.shutdown("simulation over")
        elif not self._shut and self.daemon.link is not None:
            self.daemon.link.close()  # killed: the OS closes what it held
        self._shut = True
        if self.camera is not None:
            self.camera.stop(1.0)
