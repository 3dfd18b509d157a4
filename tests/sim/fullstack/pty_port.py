"""The Jetson's end of a brain_host pty in the full stack's tests: write downlink messages, read
the uplink's bytes up to a count (lockstep) and keep the messages decoded."""

from __future__ import annotations

import os
import select
import time

from protocol import framing
from protocol.framing import Received
from protocol.messages import State


class Port:
    """The Jetson's end of brain_host's pty, with byte counts for lockstep."""

    def __init__(self, path: str) -> None:
        self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        self.written = 0
        self.read_total = 0
        self.decoder = framing.UplinkDecoder()
        self.messages: list[object] = []
        self.seq = 0

    def send(self, msg: object) -> None:
        self.written += os.write(self.fd, framing.encode_downlink(msg, self.seq))
        self.seq += 1

    def collect(self, total: int) -> None:
        deadline = time.monotonic() + 5.0
        while self.read_total < total:
            assert time.monotonic() < deadline, f"uplink stalled at {self.read_total}/{total}"
            ready, _, _ = select.select([self.fd], [], [], 0.5)
            if ready:
                chunk = os.read(self.fd, 65536)
                self.read_total += len(chunk)
                for ev in self.decoder.feed(chunk):
                    if isinstance(ev, Received):
                        self.messages.append(ev.message)

    def states(self) -> list[State]:
        return [m for m in self.messages if isinstance(m, State)]

    def close(self) -> None:
        os.close(self.fd)
