"""A helper process of the daemon's (the camera's, the dashboard's): started, awaited, stopped.

Both helpers are started with `spawn` (nothing of the daemon's threads is copied) and talk to the
daemon over one Pipe: the child sends one reply when it is ready (`("ready", value)`) or cannot
be (`("error", why)`), then waits for "stop". The child also ends on its own when the daemon's
process is gone (killed outright, no stop sent): `serve_until_stopped` looks every
`period_s`. Everything else crosses in shared memory (jetson/slots.py).
"""

from __future__ import annotations

import contextlib
import multiprocessing
import os
import time
from collections.abc import Callable
from dataclasses import dataclass
from multiprocessing.connection import Connection
from typing import Any


@dataclass
class Helper:
    """The daemon's side of one helper process."""

    process: Any
    conn: Connection | None

    @classmethod
    def spawn(cls, target: Callable[..., None], args: tuple[Any, ...], name: str) -> Helper:
        """Start `target(conn, *args)` in a spawned process, without waiting for it."""
        ctx = multiprocessing.get_context("spawn")
        ours, theirs = ctx.Pipe()
        process = ctx.Process(target=target, args=(theirs, *args), name=name, daemon=True)
        process.start()
        theirs.close()
        return cls(process, ours)

    @property
    def alive(self) -> bool:
        return self.process.is_alive()

    def await_reply(self, timeout_s: float) -> tuple[str, Any] | None:
        """The child's first reply, or None when it died or did not answer in `timeout_s`."""
        conn = self.conn
        if conn is None:
            return None
        deadline = time.monotonic() + timeout_s
        while time.monotonic() < deadline and self.process.is_alive():
            with contextlib.suppress(EOFError, OSError):
                if conn.poll(0.1):
                    reply: tuple[str, Any] = conn.recv()
                    return reply
        return None

    def stop(self, timeout_s: float) -> None:
        """Ask the child to stop, and end it when it does not within `timeout_s`."""
        conn = self.conn
        if conn is not None:
            with contextlib.suppress(OSError, ValueError):
                conn.send("stop")
        self.process.join(timeout_s)
        if self.process.is_alive():
            self.process.terminate()
            self.process.join(timeout_s)
        if conn is not None:
            conn.close()
        self.conn = None


class HelperHandle:
    """What the handles on a helper process (CameraProcess, DashboardProcess) share: whether it
    runs, and its process id."""

    _helper: Helper | None = None

    @property
    def alive(self) -> bool:
        return self._helper is not None and self._helper.alive

    @property
    def pid(self) -> int | None:
        return None if self._helper is None else self._helper.process.pid


def serve_until_stopped(
    conn: Connection, daemon_pid: int, period_s: float, tick: Callable[[], None] | None = None
) -> None:
    """The child's side: wait until the daemon says stop or its process is gone, calling `tick`
    every `period_s` meanwhile."""
    try:
        while not conn.poll(period_s):
            if os.getppid() != daemon_pid:
                return
            if tick is not None:
                tick()
    except (EOFError, OSError):
        pass
