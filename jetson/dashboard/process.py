"""The live dashboard in its own process, below the robot's loop.

A browser watching the robot must never slow it. Python runs one thread at a time in a process,
so a server thread beside the daemon's loop (building pages, encoding JPEGs, talking WebSocket)
makes the loop wait for the interpreter; and on a 2-core Jetson the server's CPU is the robot's.
So the server (jetson/dashboard/server.py) runs in a process of its own, started with `spawn`
(nothing of the daemon's threads is copied) at the priority of the daemon's helper threads
(jetson/threads.py: 10 nice steps below the control loop, as the camera thread): the loop always
runs first, and the dashboard shares what it leaves with the camera.

What the daemon's side does for the dashboard: when the dashboard has asked (a shared flag), the
daemon's thread takes a snapshot (references and numbers, jetson/dashboard/snapshot.py) and
pickles it into a shared slot; the camera pickles each frame view it keeps into another (the
camera's own process writes it; a camera thread in the daemon's process writes it through its
FrameTap). Neither ever waits (jetson/dashboard/bridge.py). Everything else (rendering, JSON,
JPEG, the Jetson's health, the browsers) happens in the dashboard's process.

The dashboard's process ends when told to, and on its own when the daemon's process is gone.
"""

from __future__ import annotations

import multiprocessing
import os
import pickle
import signal
from collections import Counter
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any

from jetson.dashboard.address import page_url, parse_address
from jetson.dashboard.bridge import Bridge
from jetson.frames import frame_bytes_for
from jetson.helper_process import Helper, HelperHandle, serve_until_stopped
from jetson.slots import Latest
from jetson.threads import lower_this_thread

__all__ = ["DashboardProcess", "live_server"]

SNAPSHOT_BYTES = 1 << 20  # room for one pickled snapshot (a few kB to a few tens of kB)
START_TIMEOUT_S = 30.0  # a Jetson imports the server's libraries in a few seconds
STATS_PERIOD_S = 0.5


@dataclass(frozen=True)
class ProcessOptions:
    host: str
    port: int
    state_hz: float
    camera_hz: float
    frame_width: int
    title: str
    record_dir: str | None
    camera: bool
    daemon_pid: int


class RemoteObserver:
    """The daemon's Observer as the dashboard's process sees it: what LiveSource reads."""

    def __init__(self, bridge: Bridge) -> None:
        from jetson.dashboard.snapshot import Observer

        self._bridge = bridge
        self._latest = Latest(bridge.snapshots)
        self._renderer = Observer()  # render() follows forgotten rings from one to the next

    @property
    def snapshot(self) -> dict[str, Any] | None:
        return self._latest.get()

    @property
    def wanted(self) -> bool:
        return False

    @wanted.setter
    def wanted(self, value: bool) -> None:
        if value:
            self._bridge.wanted.set()

    def render(self, raw: dict[str, Any]) -> dict[str, Any]:
        return self._renderer.render(raw)

    def counters(self) -> dict[str, Any]:
        raw = self._latest.value
        return dict(raw.get("observer", {})) if isinstance(raw, dict) else {}


class RemoteFrames:
    """The daemon's FrameTap as the dashboard's process sees it: the newest view."""

    def __init__(self, bridge: Bridge) -> None:
        self._latest = Latest(bridge.frames)

    @property
    def newest(self) -> Any:
        return self._latest.get()


def child_main(conn: Connection, bridge: Bridge, options: ProcessOptions) -> None:
    """The dashboard's process: serve until told to stop or the daemon's process is gone."""
    lower_this_thread()  # before any other thread starts: they inherit it
    signal.signal(signal.SIGINT, signal.SIG_IGN)  # Ctrl-C is the daemon's to handle
    from jetson.dashboard.server import DashboardServer, LiveSource
    from jetson.dashboard.system import SystemStats

    frames = RemoteFrames(bridge) if options.camera else None
    source = LiveSource(
        RemoteObserver(bridge),
        frames,
        SystemStats(options.record_dir, pid=options.daemon_pid),
        options.title,
        options.frame_width,
    )
    server = DashboardServer(
        source, options.host, options.port, options.state_hz, options.camera_hz
    )
    try:
        server.start()
    except OSError as exc:
        conn.send(("error", str(exc)))
        return
    conn.send(("ready", server.port))

    def report() -> None:
        stats = {"sent": dict(server.sent), "clients": server.clients, "refused": server.refused}
        bridge.stats.put(pickle.dumps(stats))

    try:
        serve_until_stopped(conn, options.daemon_pid, STATS_PERIOD_S, report)
    finally:
        server.stop()


class DashboardProcess(HelperHandle):
    """The daemon's handle on its dashboard's process (see the module doc). start() returns once
    the server listens, or raises OSError saying why it cannot (a port taken, an address this
    machine does not have); or launch() now and await_ready() on another thread, so that the
    robot's loop never waits for the dashboard to start. `url` says where it listens. `sent`,
    `clients` and `refused` are the server's counts as its process last reported them (twice a
    second)."""

    def __init__(self, options: ProcessOptions, bridge: Bridge, log: Any = None) -> None:
        self.options = options
        self.bridge = bridge
        self.log = log
        self.host = options.host
        self.port = options.port
        self._helper: Helper | None = None
        self._stats = Latest(bridge.stats)
        self.ready = False  # listening (set by start() or await_ready())

    @property
    def url(self) -> str:
        return page_url(self.host, self.port)

    def _stat(self, key: str) -> Any:
        stats = self._stats.get() or {}
        return stats.get(key)

    @property
    def sent(self) -> Counter[str]:
        return Counter(self._stat("sent") or {})

    @property
    def clients(self) -> int:
        return int(self._stat("clients") or 0)

    @property
    def refused(self) -> int:
        return int(self._stat("refused") or 0)

    def start(self, timeout_s: float = START_TIMEOUT_S) -> DashboardProcess:
        """Start the process and wait until it listens (OSError when it cannot)."""
        self.launch()
        why = self.await_ready(timeout_s)
        if why is not None:
            raise OSError(why)
        return self

    def launch(self) -> None:
        """Start the process without waiting for it (await_ready() says how it went)."""
        self._helper = Helper.spawn(child_main, (self.bridge, self.options), "pete-dashboard")

    def await_ready(self, timeout_s: float = START_TIMEOUT_S) -> str | None:
        """Wait for the launched process to listen: None when it does (`port` is then where),
        else why it cannot (it is stopped)."""
        if self._helper is None:
            return "the dashboard's process was not launched"
        reply = self._helper.await_reply(timeout_s)
        if reply is None or reply[0] != "ready":
            self.stop(0.5)
            why = reply[1] if reply else "its process did not start in time"
            return f"the dashboard cannot listen on {self.host}:{self.port}: {why}"
        self.port = int(reply[1])
        self.ready = True
        return None

    def stop(self, timeout_s: float = 1.0) -> None:
        if self._helper is not None:
            self._helper.stop(timeout_s)


def live_server(
    daemon: Any,
    camera: Any = None,
    settings: Any = None,
    record_dir: str | None = None,
    title: str = "pete-jetson",
) -> DashboardProcess:
    """A dashboard for a built daemon (jetson.loop.Daemon), not started yet: its Observer is set
    on the daemon, and the camera (when given) hands small copies of its frames to the
    dashboard's process: a camera in its own process (jetson.camera_process.CameraProcess) writes
    them into its frame slot, which the dashboard reads; a camera thread (a CameraWorker) hands
    them to the daemon's FrameTap (made here when the daemon has none), which writes them into
    the dashboard's. `settings` is jetson.settings.DashboardSettings."""
    from jetson.dashboard.snapshot import Observer
    from jetson.frames import FrameTap
    from jetson.settings import DashboardSettings

    s = settings or DashboardSettings()
    host, port = parse_address(s.address or "0")
    tap = daemon.frames
    own_process = hasattr(camera, "frame_copies")  # jetson.camera_process.CameraProcess
    if camera is not None:
        if tap is None:
            period = 1.0 / s.camera_hz
            tap = (
                camera.frame_copies(period, s.frame_width)
                if own_process
                else FrameTap(period, s.frame_width)
            )
            daemon.frames = tap
        else:
            tap.period_s = min(tap.period_s, 1.0 / s.camera_hz)
            tap.width = max(tap.width, s.frame_width)
        if not own_process:
            camera.tap = tap
    ctx = multiprocessing.get_context("spawn")
    width = tap.width if tap is not None else s.frame_width
    # A camera in its own process writes its frame slot itself; the dashboard reads that one.
    frames = camera.frame_slot if own_process else None
    bridge = Bridge(ctx, SNAPSHOT_BYTES, frame_bytes_for(width), frames)
    daemon.observer = Observer(bridge)
    if camera is not None and tap is not None and not own_process:
        tap.sink = bridge.post_frame
    options = ProcessOptions(
        host, port, s.state_hz, s.camera_hz, s.frame_width, title, record_dir,
        camera is not None, os.getpid(),
    )  # fmt: skip
    return DashboardProcess(options, bridge, log=daemon.log)
