"""Frames from another process over a local socket: how the simulator feeds the daemon.

The producer (the simulator) runs a FrameStreamServer; the consumer (the daemon) opens a
StreamSource on the same address. Addresses: "unix:/path/to.sock" (a UNIX stream socket) or
"tcp:HOST:PORT" (for another machine or a container; port 0 lets the server pick one).

Protocol, version 1. The server writes frames back to back on a stream connection; each is a
108-byte little-endian header followed by the raw arrays:

    offset  size  type      field
    0       4     bytes     magic "PETF"
    4       2     u16       version (1)
    6       2     u16       flags: bit 0 = depth follows the colour
    8       4     u32       width W
    12      4     u32       height H
    16      8     u64       frame index
    24      8     f64       timestamp, seconds
    32      32    4 x f64   fx, fy, cx, cy (pixels)
    64      40    5 x f64   distortion k1, k2, p1, p2, k3 (OpenCV's order)
    104     4     u32       payload bytes = W*H*3 (+ W*H*2 with depth)
    108     W*H*3 u8        colour, BGR, row-major
    ...     W*H*2 u16 LE    depth in millimetres aligned to colour, 0 = no reading (if flag 0)

The client sends nothing. Writes block when the client is a frame behind (the socket's buffer is
smaller than a frame), so a slow consumer slows the producer instead of reading stale frames
from a growing queue. Closing the connection at a frame boundary ends the stream; anything else
(a short header, a bad magic, a payload that does not match its header) is an error.
"""

from __future__ import annotations

import contextlib
import os
import socket
import struct
import time
from pathlib import Path

import numpy as np

from jetson.autonomy.camera import Intrinsics
from jetson.errors import SourceError
from jetson.perception.frame import Frame, depth_from_mm, depth_to_mm
from jetson.perception.sources.base import FrameSource

MAGIC = b"PETF"
VERSION = 1
FLAG_DEPTH = 1
HEADER = struct.Struct("<4sHHIIQd4d5dI")
MAX_PIXELS = 4096 * 4096  # refuses a header that would make us allocate gigabytes

assert HEADER.size == 108


def parse_address(address: str) -> tuple[int, str | tuple[str, int]]:
    """(socket family, address) from "unix:PATH" or "tcp:HOST:PORT"."""
    kind, _, rest = address.partition(":")
    if kind == "unix" and rest:
        return socket.AF_UNIX, rest
    if kind == "tcp":
        host, _, port = rest.rpartition(":")
        if host and port.isdigit() and int(port) < 65536:
            return socket.AF_INET, (host, int(port))
    raise SourceError(f"bad stream address {address!r}: use unix:/path/to.sock or tcp:HOST:PORT")


def encode_header(frame: Frame) -> bytes:
    i = frame.intrinsics
    w, h = frame.size
    dist = (tuple(i.dist) + (0.0,) * 5)[:5]
    has_depth = frame.depth_m is not None
    payload = w * h * 3 + (w * h * 2 if has_depth else 0)
    flags = FLAG_DEPTH if has_depth else 0
    return HEADER.pack(
        MAGIC, VERSION, flags, w, h, frame.index, frame.timestamp_s, i.fx, i.fy, i.cx, i.cy,
        *dist, payload,
    )  # fmt: skip


def encode_frame(frame: Frame) -> list[bytes | memoryview]:
    """The header and payload buffers of one frame, ready for sendall."""
    parts: list[bytes | memoryview] = [encode_header(frame)]
    parts.append(memoryview(np.ascontiguousarray(frame.color)).cast("B"))
    if frame.depth_m is not None:
        mm = depth_to_mm(frame.depth_m).astype("<u2", copy=False)
        parts.append(memoryview(np.ascontiguousarray(mm)).cast("B"))
    return parts


class FrameStreamServer:
    """The producer's end: listens on an address and sends frames to one client at a time."""

    def __init__(self, address: str) -> None:
        family, addr = parse_address(address)
        self._family = family
        self._path: str | None = None
        self._listener = socket.socket(family, socket.SOCK_STREAM)
        try:
            if family == socket.AF_UNIX:
                assert isinstance(addr, str)
                self._claim_unix_path(addr)
                self._path = addr
            else:
                self._listener.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)
            self._listener.bind(addr)
            self._listener.listen(1)
        except OSError as exc:
            self._listener.close()
            raise SourceError(f"cannot serve frames on {address}: {exc}") from exc
        if family == socket.AF_INET:
            host, port = self._listener.getsockname()
            self.address = f"tcp:{host}:{port}"
        else:
            self.address = address
        self._client: socket.socket | None = None

    @staticmethod
    def _claim_unix_path(path: str) -> None:
        if not os.path.exists(path):
            return
        probe = socket.socket(socket.AF_UNIX, socket.SOCK_STREAM)
        try:
            probe.connect(path)
        except OSError:
            os.unlink(path)  # a socket file left by a server that died: ours to replace
            return
        finally:
            probe.close()
        raise SourceError(f"{path} is in use by another frame server")

    @property
    def connected(self) -> bool:
        return self._client is not None

    def wait_for_client(self, timeout_s: float | None = None) -> bool:
        """Accept a client (dropping any previous one); False if none came in time."""
        self._drop_client()
        self._listener.settimeout(timeout_s)
        try:
            client, _ = self._listener.accept()
        except TimeoutError:
            return False
        self._take(client)
        return True

    def accept_pending(self) -> bool:
        """Without waiting: take a client that is waiting to connect (one that gave up on a
        quiet stream and came back), dropping any previous one; False if none is waiting."""
        self._listener.settimeout(0.0)
        try:
            client, _ = self._listener.accept()
        except (BlockingIOError, TimeoutError):
            return False
        self._drop_client()
        self._take(client)
        return True

    def _take(self, client: socket.socket) -> None:
        client.settimeout(None)
        if self._family == socket.AF_INET:
            client.setsockopt(socket.IPPROTO_TCP, socket.TCP_NODELAY, 1)
        self._client = client

    def send(self, frame: Frame) -> bool:
        """Send one frame; False (and the client dropped) if the client has gone."""
        if self._client is None:
            raise SourceError("no client connected: call wait_for_client() first")
        try:
            for part in encode_frame(frame):
                self._client.sendall(part)
        except (BrokenPipeError, ConnectionResetError):
            self._drop_client()
            return False
        return True

    def _drop_client(self) -> None:
        if self._client is not None:
            with contextlib.suppress(OSError):
                self._client.close()
            self._client = None

    def close(self) -> None:
        """End the stream: the client reads the end after the last whole frame."""
        self._drop_client()
        self._listener.close()
        if self._path is not None:
            with contextlib.suppress(FileNotFoundError):
                os.unlink(self._path)
            self._path = None

    def __enter__(self) -> FrameStreamServer:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()


class StreamSource(FrameSource):
    """The consumer's end: connects to a FrameStreamServer and reads its frames."""

    def __init__(
        self, address: str, connect_timeout_s: float = 5.0, read_timeout_s: float = 5.0
    ) -> None:
        family, addr = parse_address(address)
        self.description = f"frame stream {address}"
        self.address = address
        deadline = time.monotonic() + connect_timeout_s
        last: OSError | None = None
        while True:
            sock = socket.socket(family, socket.SOCK_STREAM)
            try:
                sock.settimeout(max(0.05, deadline - time.monotonic()))
                sock.connect(addr)
                break
            except OSError as exc:
                sock.close()
                last = exc
                if time.monotonic() >= deadline:
                    hint = "is the simulator (or whatever serves frames) running?"
                    raise SourceError(f"no frame stream at {address} ({last}); {hint}") from exc
                time.sleep(0.05)
        sock.settimeout(read_timeout_s)
        self._sock: socket.socket | None = sock
        self._timeout = read_timeout_s
        self._header = bytearray(HEADER.size)
        self._payload = bytearray()

    def _recv_exact(self, buf: bytearray | memoryview, *, at_boundary: bool) -> bool:
        """Fill buf; False on a clean end of stream before its first byte (at a boundary)."""
        assert self._sock is not None
        view = memoryview(buf)
        got = 0
        while got < len(view):
            try:
                n = self._sock.recv_into(view[got:])
            except TimeoutError as exc:
                raise SourceError(f"no frame from {self.address} within {self._timeout} s") from exc
            except OSError as exc:
                raise SourceError(f"frame stream {self.address} failed: {exc}") from exc
            if n == 0:
                if got == 0 and at_boundary:
                    return False
                raise SourceError(f"frame stream {self.address} closed in the middle of a frame")
            got += n
        return True

    def read(self) -> Frame | None:
        if self._sock is None:
            return None
        if not self._recv_exact(self._header, at_boundary=True):
            self.close()
            return None
        (magic, version, flags, w, h, index, ts, fx, fy, cx, cy, *dist, payload) = HEADER.unpack(
            self._header
        )
        if magic != MAGIC:
            raise SourceError(f"frame stream {self.address}: bad magic {magic!r}, not a frame")
        if version != VERSION:
            raise SourceError(f"frame stream {self.address}: protocol version {version} (need 1)")
        if not (0 < w * h <= MAX_PIXELS):
            raise SourceError(f"frame stream {self.address}: bad frame size {w}x{h}")
        has_depth = bool(flags & FLAG_DEPTH)
        expected = w * h * 3 + (w * h * 2 if has_depth else 0)
        if payload != expected:
            raise SourceError(
                f"frame stream {self.address}: payload {payload} bytes, expected {expected} "
                f"for {w}x{h}{' with depth' if has_depth else ''}"
            )
        if len(self._payload) != payload:
            self._payload = bytearray(payload)
        self._recv_exact(self._payload, at_boundary=False)
        color = np.frombuffer(self._payload, np.uint8, w * h * 3).reshape(h, w, 3).copy()
        depth = None
        if has_depth:
            mm = np.frombuffer(self._payload, "<u2", w * h, offset=w * h * 3).reshape(h, w)
            depth = depth_from_mm(mm)
        intr = Intrinsics(w, h, fx, fy, cx, cy, tuple(dist))
        return Frame(color, depth, intr, ts, int(index))

    def close(self) -> None:
        if self._sock is not None:
            with contextlib.suppress(OSError):
                self._sock.close()
            self._sock = None


def is_stream_address(text: str) -> bool:
    return text.startswith(("unix:", "tcp:")) and not Path(text).exists()
