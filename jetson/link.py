"""The serial link to the Brain: finding its port, opening it raw, reading and writing bytes.

The Brain's user port is a CDC ACM tty (/dev/ttyACM1, or the stable name the udev rule in
jetson/deploy gives it); in tests and in the full-stack simulation it is a pty. Both are opened the
same way: non-blocking, raw (no echo, no CR/LF translation: either would corrupt frames, and echo
would send the Brain's own bytes back to it), 8N1 at 115200 baud (USB CDC ignores the rate).

Disconnection (the USB cable pulled, the Brain powered off, the pty's other end closed) surfaces as
LinkClosed from read() or write(); the daemon then waits for the port to reappear and reopens it.
"""

from __future__ import annotations

import contextlib
import errno
import fcntl
import os
import select
import termios
import time
from collections.abc import Callable
from dataclasses import dataclass, field

from jetson.ports import V5Port

READ_CHUNK = 4096
# A Command is 42 bytes; if the Brain has not drained the tty buffer in this long it is wedged,
# and a late command is worse than a dropped one.
WRITE_TIMEOUT_S = 0.01
# Errors that mean the device is gone rather than busy.
_GONE = {errno.EIO, errno.ENXIO, errno.ENODEV, errno.EBADF, errno.EPIPE, errno.ENOENT}


class LinkClosed(ConnectionError):
    """The port went away: unplugged, powered off, or the other end closed."""


class LinkOpenError(OSError):
    """The port exists but cannot be opened (permissions, held by another program, not a tty)."""


def configure_raw(fd: int, baud: int = 115200) -> None:
    """Raw 8N1, no flow control, reads return at once (VMIN = VTIME = 0)."""
    iflag, oflag, cflag, lflag, _, _, cc = termios.tcgetattr(fd)
    iflag &= ~(
        termios.IGNBRK | termios.BRKINT | termios.PARMRK | termios.ISTRIP | termios.INLCR
        | termios.IGNCR | termios.ICRNL | termios.IXON | termios.IXOFF | termios.IXANY
        | termios.INPCK
    )  # fmt: skip
    oflag &= ~termios.OPOST
    lflag &= ~(
        termios.ECHO | termios.ECHONL | termios.ICANON | termios.ISIG | termios.IEXTEN
        | termios.ECHOE | termios.ECHOK
    )  # fmt: skip
    cflag &= ~(termios.CSIZE | termios.PARENB | termios.CSTOPB | getattr(termios, "CRTSCTS", 0))
    cflag |= termios.CS8 | termios.CREAD | termios.CLOCAL
    cc = list(cc)
    cc[termios.VMIN] = 0
    cc[termios.VTIME] = 0
    speed = getattr(termios, f"B{baud}", None)
    if speed is None:
        raise ValueError(f"unsupported baud rate {baud}")
    termios.tcsetattr(fd, termios.TCSANOW, [iflag, oflag, cflag, lflag, speed, speed, cc])


class SerialLink:
    """One open connection to the Brain's port. Counts bytes both ways for lockstep harnesses."""

    def __init__(self, fd: int, path: str) -> None:
        self._fd: int | None = fd
        self.path = path
        self._poll = select.poll()
        self._poll.register(fd, select.POLLIN | select.POLLPRI)
        self.rx_bytes = 0
        self.tx_bytes = 0
        self.tx_dropped = 0  # frames dropped because the Brain did not drain its buffer

    @classmethod
    def open(cls, path: str, baud: int = 115200, exclusive: bool = True) -> SerialLink:
        try:
            fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK | os.O_CLOEXEC)
        except FileNotFoundError as exc:
            raise LinkClosed(f"{path} does not exist") from exc
        except OSError as exc:
            raise LinkOpenError(exc.errno, f"cannot open {path}: {exc.strerror}") from exc
        try:
            if os.isatty(fd):
                configure_raw(fd, baud)
                if exclusive:
                    # A second program (a PROS terminal) reading the same port would steal
                    # half of the Brain's frames.
                    with contextlib.suppress(OSError):
                        fcntl.ioctl(fd, termios.TIOCEXCL)
        except (OSError, termios.error, ValueError) as exc:
            os.close(fd)
            raise LinkOpenError(errno.EINVAL, f"cannot configure {path}: {exc}") from exc
        return cls(fd, path)

    @property
    def is_open(self) -> bool:
        return self._fd is not None

    def fileno(self) -> int:
        if self._fd is None:
            raise LinkClosed(f"{self.path} is closed")
        return self._fd

    def read(self, timeout_s: float) -> bytes:
        """Bytes that arrived within timeout_s (b"" if none); LinkClosed if the port went away."""
        fd = self.fileno()
        events = self._poll.poll(max(0, int(timeout_s * 1000)))
        if not events:
            return b""
        mask = events[0][1]
        if mask & (select.POLLIN | select.POLLPRI):
            try:
                data = os.read(fd, READ_CHUNK)
            except BlockingIOError:
                return b""
            except OSError as exc:
                raise LinkClosed(f"{self.path}: {exc.strerror}") from exc
            if not data:
                raise LinkClosed(f"{self.path}: end of file (the other end hung up)")
            self.rx_bytes += len(data)
            return data
        if mask & (select.POLLHUP | select.POLLERR | select.POLLNVAL):
            raise LinkClosed(f"{self.path}: hung up")
        return b""

    def write(self, data: bytes, timeout_s: float = WRITE_TIMEOUT_S) -> bool:
        """Write all of data; False (counted in tx_dropped) if the port stayed full past
        timeout_s. LinkClosed if the port went away."""
        fd = self.fileno()
        view = memoryview(data)
        waited = False
        while view:
            try:
                n = os.write(fd, view)
            except BlockingIOError:
                n = 0
            except OSError as exc:
                if exc.errno in _GONE:
                    raise LinkClosed(f"{self.path}: {exc.strerror}") from exc
                raise
            self.tx_bytes += n
            view = view[n:]
            if view:
                if waited:
                    self.tx_dropped += 1
                    return False
                _, ready, _ = select.select([], [fd], [], timeout_s)
                waited = True
                if not ready:
                    self.tx_dropped += 1
                    return False
        return True

    def close(self) -> None:
        fd, self._fd = self._fd, None
        if fd is None:
            return
        with contextlib.suppress(OSError):
            self._poll.unregister(fd)
        with contextlib.suppress(OSError):
            if os.isatty(fd):
                fcntl.ioctl(fd, termios.TIOCNXCL)
        with contextlib.suppress(OSError):
            os.close(fd)


@dataclass
class PortLocator:
    """Where the Brain's user port is now: a fixed path (the udev name, a pty), or the user port
    found by USB discovery as pros-cli does (jetson.ports). None while there is none."""

    path: str | None = None
    discover: Callable[[], list[V5Port]] | None = None
    # A USB scan reads sysfs (~1 ms); five a second find a Brain soon enough and cost nothing.
    scan_interval_s: float = 0.2
    _scanned_at: float = field(default=-1e9, init=False, repr=False)
    _found: str | None = field(default=None, init=False, repr=False)

    def find(self) -> str | None:
        if self.path is not None:
            return self.path if os.path.exists(self.path) else None
        now = time.monotonic()
        if now - self._scanned_at < self.scan_interval_s:
            return self._found
        discover = self.discover
        if discover is None:
            from jetson.ports import list_v5_ports

            discover = list_v5_ports
        # Only a port known to be the user port: the system port carries uploads and never the
        # program's stdio, and writing Commands there could disturb an upload.
        users = [p.device for p in discover() if p.kind == "user"]
        self._scanned_at = now
        self._found = users[0] if users else None
        return self._found

    def describe(self) -> str:
        return self.path if self.path is not None else "the V5 user port (USB VID 0x2888)"
