"""The dashboard's web server: one page, its script, and a WebSocket of snapshots and frames.

It runs on its own thread with its own asyncio event loop (aiohttp). For a live robot that thread
is in the dashboard's own process (jetson/dashboard/process.py), which reads the daemon's
snapshots and frames from shared memory (jetson/dashboard/bridge.py); for a recording
(`pete-jetson dashboard --recording`) it is in the command's process.

Each browser gets its own sender: every 1/state_hz it asks the daemon for a snapshot and sends
the newest one it has, every 1/camera_hz the newest camera frame (JPEG, encoded once for all the
browsers), once a second the Jetson's health. A browser that reads slowly holds up only its own
sender, which then sends the newest data when it can: frames and snapshots in between are
dropped, never queued, and never wait on the daemon.

Read-only: no route changes anything. The only messages a page may send are a replay's
"seek"/"play", which move that page's own cursor in a recording. A WebSocket whose Origin is
another site than the page's is refused (a page elsewhere cannot read the robot's data through
the visitor's browser either).
"""

from __future__ import annotations

import asyncio
import contextlib
import json
import threading
import time
from collections import Counter
from importlib import resources
from typing import Any, Protocol
from urllib.parse import urlsplit

from aiohttp import WSMsgType, web

from jetson.dashboard.address import page_url
from jetson.frames import view_record

__all__ = ["DashboardServer", "LiveSource"]

STATIC_FILES = {
    "/": ("index.html", "text/html"),
    "/dashboard.js": ("dashboard.js", "text/javascript"),
    "/dashboard.css": ("dashboard.css", "text/css"),
}
SECURITY_HEADERS = {
    "Content-Security-Policy": (
        "default-src 'self'; img-src 'self' data:; connect-src 'self'; "
        "style-src 'self'; script-src 'self'; frame-ancestors 'none'"
    ),
    "X-Content-Type-Options": "nosniff",
    "Referrer-Policy": "no-referrer",
    "Cache-Control": "no-store",
}
# A browser that has this much unsent on its socket gets no camera frame until it drains.
SLOW_CLIENT_BYTES = 256 * 1024


class Source(Protocol):
    """What the server shows: the live daemon (LiveSource) or a recording (ReplaySource)."""

    mode: str  # "live" | "replay"

    def info(self) -> dict[str, Any]: ...


class LiveSource:
    """The running daemon: its Observer's snapshots and its FrameTap's frames."""

    mode = "live"

    def __init__(
        self,
        observer: Any,
        frames: Any = None,  # a jetson.frames.FrameTap, or what has its `newest`
        system: Any = None,
        title: str = "pete-jetson",
        frame_width: int = 320,
    ) -> None:
        self.observer = observer
        self.frames = frames
        self.system = system
        self.title = title
        self.frame_width = frame_width
        self._frame: tuple[int, str] | None = None  # (view id, encoded message)
        self._jetson: tuple[float, str] | None = None
        self._dashboard_s = 0.0  # the server thread's CPU time at the last sample
        self._rendered: dict[str, Any] | None = None

    def info(self) -> dict[str, Any]:
        from jetson.dashboard.snapshot import FIELD_HALF_M, fingerprint

        return {
            "kind": "hello", "mode": self.mode, "title": self.title, "read_only": True,
            "field_half_m": FIELD_HALF_M, "fingerprint": fingerprint(),
            "camera": self.frames is not None,
        }  # fmt: skip

    def want(self) -> None:
        self.observer.wanted = True

    def snapshot(self) -> dict[str, Any] | None:
        """The newest snapshot, rendered (here, on the server's thread) once whoever asks."""
        raw = self.observer.snapshot
        if raw is None:
            return None
        if self._rendered is None or self._rendered["n"] != raw["n"]:
            self._rendered = self.observer.render(raw)
        return self._rendered

    def frame_message(self) -> tuple[int, str] | None:
        """The newest frame as a message (encoded once, whoever asks)."""
        view = self.frames.newest if self.frames is not None else None
        if view is None:
            return None
        cached = self._frame
        if cached is not None and cached[0] == view.id:
            return cached
        msg = {"kind": "frame", **view_record(view, self.frame_width, quality=75)}
        self._frame = (view.id, json.dumps(msg, separators=(",", ":")))
        return self._frame

    def jetson_message(self) -> str | None:
        """The Jetson's health, sampled at most once a second whoever asks; the dashboard's CPU
        is this process's (a live source is served from the dashboard's own process)."""
        if self.system is None:
            return None
        now = time.monotonic()
        if self._jetson is None or now - self._jetson[0] >= 1.0:
            dashboard_s = time.process_time()
            sample = self.system.sample(dashboard_s - self._dashboard_s)
            self._dashboard_s = dashboard_s
            sample["observer"] = self.observer.counters()
            self._jetson = (now, json.dumps(sample, separators=(",", ":")))
        return self._jetson[1]


def _same_origin(request: web.Request) -> bool:
    """No Origin (not a browser page) or the page's own host:port."""
    origin = request.headers.get("Origin")
    if origin is None:
        return True
    parts = urlsplit(origin)
    return parts.scheme in ("http", "https") and parts.netloc.lower() == request.host.lower()


class DashboardServer:
    """The server on its own thread (see the module docstring). start() returns once it listens
    (or raises OSError when it cannot bind); `url` says where."""

    def __init__(
        self,
        source: Any,
        host: str = "127.0.0.1",
        port: int = 0,
        state_hz: float = 20.0,
        camera_hz: float = 10.0,
        log: Any = None,
    ) -> None:
        self.source = source
        self.host = host
        self.port = port
        self.state_period = 1.0 / state_hz
        self.camera_period = 1.0 / camera_hz
        self.log = log
        self.sent: Counter[str] = Counter()
        self.clients = 0
        self.refused = 0
        self._loop: asyncio.AbstractEventLoop | None = None
        self._thread: threading.Thread | None = None
        self._ready = threading.Event()
        self._error: BaseException | None = None
        self._stopping: asyncio.Event | None = None
        self._static = {
            path: (resources.files("jetson.dashboard").joinpath("static", name).read_bytes(), ct)
            for path, (name, ct) in STATIC_FILES.items()
        }

    @property
    def url(self) -> str:
        return page_url(self.host, self.port)

    # --- the thread ------------------------------------------------------------------------

    def start(self, timeout_s: float = 10.0) -> DashboardServer:
        self._thread = threading.Thread(target=self._run, name="pete-dashboard", daemon=True)
        self._thread.start()
        if not self._ready.wait(timeout_s):
            raise OSError("the dashboard's server did not start in time")
        if self._error is not None:
            raise OSError(f"the dashboard cannot listen on {self.host}:{self.port}: {self._error}")
        return self

    def stop(self, timeout_s: float = 1.0) -> None:
        loop, stopping = self._loop, self._stopping
        if loop is not None and stopping is not None and not loop.is_closed():
            with contextlib.suppress(RuntimeError):  # the loop has just closed
                loop.call_soon_threadsafe(stopping.set)
        if self._thread is not None:
            self._thread.join(timeout_s)

    def _run(self) -> None:
        loop = asyncio.new_event_loop()
        self._loop = loop
        try:
            loop.run_until_complete(self._serve())
        except BaseException as exc:
            self._error = exc
        finally:
            self._ready.set()
            loop.close()

    async def _serve(self) -> None:
        self._stopping = asyncio.Event()
        app = web.Application(middlewares=[self._headers])
        app.router.add_get("/", self._static_file)
        app.router.add_get("/dashboard.js", self._static_file)
        app.router.add_get("/dashboard.css", self._static_file)
        app.router.add_get("/api/info", self._info)
        app.router.add_get("/api/snapshot", self._snapshot)
        app.router.add_get("/ws", self._ws)
        app.router.add_get("/favicon.ico", self._no_content)
        runner = web.AppRunner(app, access_log=None, handle_signals=False)
        await runner.setup()
        try:
            site = web.TCPSite(runner, self.host, self.port, reuse_address=True)
            await site.start()
            server = getattr(site, "_server", None)
            sockets = getattr(server, "sockets", None) or ()
            if sockets:
                self.port = int(sockets[0].getsockname()[1])
            self._ready.set()
            await self._stopping.wait()
        finally:
            await runner.cleanup()

    # --- routes ----------------------------------------------------------------------------

    @web.middleware
    async def _headers(self, request: web.Request, handler: Any) -> web.StreamResponse:
        response = await handler(request)
        for k, v in SECURITY_HEADERS.items():
            response.headers.setdefault(k, v)
        return response

    async def _static_file(self, request: web.Request) -> web.Response:
        body, content_type = self._static[request.path]
        return web.Response(body=body, content_type=content_type, charset="utf-8")

    async def _no_content(self, request: web.Request) -> web.Response:
        return web.Response(status=204)

    async def _info(self, request: web.Request) -> web.Response:
        return web.json_response(self.source.info())

    async def _snapshot(self, request: web.Request) -> web.Response:
        """The newest snapshot as JSON (live: it asks for a fresh one and waits up to 0.5 s)."""
        src = self.source
        if src.mode != "live":
            return web.json_response(src.snapshot_at(src.start_t))
        before = src.observer.snapshot
        src.want()
        deadline = time.monotonic() + 0.5
        while time.monotonic() < deadline and src.observer.snapshot is before:
            await asyncio.sleep(0.01)
        return web.json_response(src.snapshot())

    async def _ws(self, request: web.Request) -> web.StreamResponse:
        if not _same_origin(request):
            self.refused += 1
            return web.Response(status=403, text="another site's page may not connect here\n")
        ws = web.WebSocketResponse(heartbeat=10.0, max_msg_size=4096)
        await ws.prepare(request)
        self.clients += 1
        try:
            await ws.send_str(json.dumps(self.source.info()))
            if self.source.mode == "live":
                await self._live(ws, request)
            else:
                await self._replay(ws, request)
        except (ConnectionError, asyncio.CancelledError, RuntimeError):
            pass
        finally:
            self.clients -= 1
        return ws

    def _slow(self, request: web.Request) -> bool:
        transport = request.transport
        return transport is None or transport.get_write_buffer_size() > SLOW_CLIENT_BYTES

    async def _send(self, ws: web.WebSocketResponse, text: str, kind: str) -> None:
        await ws.send_str(text)
        self.sent[kind] += 1

    async def _drain_incoming(self, ws: web.WebSocketResponse, on_message: Any = None) -> None:
        async for msg in ws:
            if msg.type == WSMsgType.TEXT and on_message is not None:
                try:
                    data = json.loads(msg.data)
                except ValueError:
                    continue
                if isinstance(data, dict):
                    on_message(data)
            elif msg.type in (WSMsgType.ERROR, WSMsgType.CLOSE):
                break

    async def _live(self, ws: web.WebSocketResponse, request: web.Request) -> None:
        src: LiveSource = self.source
        reader = asyncio.ensure_future(self._drain_incoming(ws))  # a live page sends nothing
        last_n = None
        last_frame = None
        next_state = next_frame = next_jetson = time.monotonic()
        src.want()
        try:
            while not ws.closed and not reader.done() and not self._stopping.is_set():
                now = time.monotonic()
                if now >= next_state:
                    next_state = max(next_state + self.state_period, now)
                    snap = src.snapshot()
                    src.want()
                    if snap is not None and snap.get("n") != last_n:
                        last_n = snap.get("n")
                        await self._send(ws, json.dumps(snap, separators=(",", ":")), "state")
                if now >= next_frame:
                    next_frame = max(next_frame + self.camera_period, now)
                    if not self._slow(request):
                        frame = src.frame_message()
                        if frame is not None and frame[0] != last_frame:
                            last_frame = frame[0]
                            await self._send(ws, frame[1], "frame")
                if now >= next_jetson:
                    next_jetson = now + 1.0
                    msg = src.jetson_message()
                    if msg is not None:
                        await self._send(ws, msg, "jetson")
                wake = min(next_state, next_frame, next_jetson) - time.monotonic()
                await asyncio.sleep(max(wake, 0.002))
        finally:
            reader.cancel()

    async def _replay(self, ws: web.WebSocketResponse, request: web.Request) -> None:
        src = self.source
        cursor = {"t": src.start_t, "playing": False, "speed": 1.0, "moved": True}

        def on_message(data: dict[str, Any]) -> None:
            if "seek" in data:
                try:
                    cursor["t"] = min(max(float(data["seek"]), src.start_t), src.end_t)
                except (TypeError, ValueError):
                    return
                cursor["moved"] = True
            if "play" in data:
                cursor["playing"] = bool(data["play"])
            if "speed" in data:
                with contextlib.suppress(TypeError, ValueError):
                    cursor["speed"] = min(max(float(data["speed"]), 0.1), 20.0)

        reader = asyncio.ensure_future(self._drain_incoming(ws, on_message))
        last = time.monotonic()
        sent_state = sent_frame = None
        try:
            while not ws.closed and not reader.done() and not self._stopping.is_set():
                now = time.monotonic()
                if cursor["playing"]:
                    cursor["t"] = min(cursor["t"] + (now - last) * cursor["speed"], src.end_t)
                    cursor["moved"] = True
                    if cursor["t"] >= src.end_t:
                        cursor["playing"] = False
                last = now
                if cursor["moved"]:
                    cursor["moved"] = False
                    i = src.index_at(cursor["t"])
                    if i != sent_state:
                        sent_state = i
                        snap = dict(src.snapshot_at(cursor["t"]))
                        await self._send(ws, json.dumps(snap, separators=(",", ":")), "state")
                    frame = src.frame_at(cursor["t"])
                    if frame is not None and frame[0] != sent_frame and not self._slow(request):
                        sent_frame = frame[0]
                        await self._send(ws, frame[1], "frame")
                    await self._send(
                        ws,
                        json.dumps({"kind": "cursor", "t": cursor["t"],
                                    "playing": cursor["playing"]}),
                        "cursor",
                    )  # fmt: skip
                await asyncio.sleep(self.state_period)
        finally:
            reader.cancel()
