"""The USB cable between the simulated Brain and the Jetson daemon.

brain_host's link is a pty (the Brain's USB user port); the daemon opens another pty, behind a
stable symlink as the udev rule gives a real Brain's port. The cable joins them: every byte one
side writes is forwarded, unchanged, to the other, so the daemon reads exactly what brain_host
wrote and brain_host exactly what the daemon wrote. Standing in the middle, it can also:

- count messages: it decodes each direction twice, as sent (before the cable) and as received
  (after it, with the receiver's own decoder rules), so "sent", "received", "rejected" (frames the
  receiver refused) and "lost" (sent, never received) are measured, not estimated;
- corrupt bytes (a random bit of each byte, with a probability per byte), per direction;
- be unplugged and plugged back in: the daemon's pty vanishes (its reads fail as on a real USB
  disconnect) and a new one appears behind the same path;
- lose its reader (the daemon process died: bytes for it are dropped, as a tty nobody holds open
  discards them) and get a new one (the restarted daemon opens the same port afresh);
- be moved to a new Brain (brain_host restarted: a rebooted Brain's new port).

In lockstep everything happens in the caller's thread: pump_up(n) forwards until brain_host's
first n uplink bytes have passed, pump_down(n) until the daemon's first n bytes (on this
connection) have, and `delivered_down` is the count brain_host's `rx=` must wait for.
"""

from __future__ import annotations

import contextlib
import os
import select
import termios
import threading
import time
from collections import Counter
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from jetson.testing import plug_pty, unplug_pty
from protocol.framing import DownlinkDecoder, Received, UplinkDecoder
from sim.errors import CableError

PUMP_TIMEOUT_S = 5.0


@dataclass
class WireStats:
    """One direction of the cable. Message counts are by type name (State, Command, ...)."""

    name: str
    bytes_in: int = 0  # written by the sender
    bytes_out: int = 0  # delivered to the receiver
    bytes_dropped: int = 0  # lost to an unplugged cable or a receiver that stopped reading
    bytes_corrupted: int = 0
    sent: Counter[str] = field(default_factory=Counter)
    received: Counter[str] = field(default_factory=Counter)
    errors: Counter[str] = field(default_factory=Counter)  # refused frames by kind
    seq_gaps: int = 0  # what the receiver's packet sequence numbers say it missed
    altered: int = 0  # received messages that differ from what was sent: must stay 0

    @property
    def messages_sent(self) -> int:
        return sum(self.sent.values())

    @property
    def messages_received(self) -> int:
        return sum(self.received.values())

    @property
    def rejected(self) -> int:
        return sum(self.errors.values())

    @property
    def lost(self) -> int:
        """Messages sent that the receiver never got, for any reason (cut, corrupted, dropped)."""
        return max(0, self.messages_sent - self.messages_received)

    def as_dict(self) -> dict[str, Any]:
        return {
            "bytes_in": self.bytes_in,
            "bytes_out": self.bytes_out,
            "bytes_dropped": self.bytes_dropped,
            "bytes_corrupted": self.bytes_corrupted,
            "sent": self.messages_sent,
            "received": self.messages_received,
            "lost": self.lost,
            "rejected": self.rejected,
            "seq_gaps": self.seq_gaps,
            "altered": self.altered,
            "sent_by_type": dict(sorted(self.sent.items())),
            "received_by_type": dict(sorted(self.received.items())),
            "rejected_by_kind": dict(sorted(self.errors.items())),
        }


class _Wire:
    """Decoders on both ends of one direction, and the corruption in between."""

    def __init__(self, name: str, uplink: bool, rng: np.random.Generator) -> None:
        make = UplinkDecoder if uplink else DownlinkDecoder
        self.stats = WireStats(name)
        self._tx = make()
        self._rx = make()
        self._rng = rng
        self.corruption = 0.0
        # Application seq -> message as sent, for the messages that carry one (State, Command).
        self._by_seq: dict[tuple[str, int], Any] = {}
        self.received_log: list[Any] = []  # messages as received, for who wants them
        self.keep_received = False
        self._err_base: Counter[str] = Counter()
        self._gap_base = 0

    def sent(self, data: bytes) -> None:
        self.stats.bytes_in += len(data)
        for ev in self._tx.feed(data):
            if isinstance(ev, Received):
                name = type(ev.message).__name__
                self.stats.sent[name] += 1
                seq = getattr(ev.message, "seq", None)
                if seq is not None:
                    self._by_seq[(name, int(seq))] = ev.message

    def corrupt(self, data: bytes) -> bytes:
        if self.corruption <= 0.0 or not data:
            return data
        hits = np.flatnonzero(self._rng.random(len(data)) < self.corruption)
        if len(hits) == 0:
            return data
        out = bytearray(data)
        for i in hits:
            out[i] ^= 1 << int(self._rng.integers(8))
        self.stats.bytes_corrupted += len(hits)
        return bytes(out)

    def delivered(self, data: bytes) -> None:
        self.stats.bytes_out += len(data)
        for ev in self._rx.feed(data):
            if isinstance(ev, Received):
                msg = ev.message
                name = type(msg).__name__
                self.stats.received[name] += 1
                seq = getattr(msg, "seq", None)
                if seq is not None:
                    # Anything that arrives must have been sent, byte for byte: a message with
                    # no original (a damaged seq) counts as altered as much as a changed one.
                    original = self._by_seq.pop((name, int(seq)), None)
                    if original is None or original != msg:
                        self.stats.altered += 1
                if self.keep_received:
                    self.received_log.append(msg)
        self._sync_receiver()

    def _sync_receiver(self) -> None:
        now = Counter({str(k): v for k, v in self._rx.stats.errors.items() if v})
        self.stats.errors = self._err_base + now
        self.stats.seq_gaps = self._gap_base + self._rx.stats.lost

    def receiver_restarted(self) -> None:
        """A new connection: the receiver's decoder starts afresh (as the daemon's does)."""
        self._sync_receiver()
        self._err_base = Counter(self.stats.errors)
        self._gap_base = self.stats.seq_gaps
        self._rx = type(self._rx)()

    def sender_restarted(self) -> None:
        """A new sender (a rebooted Brain): its stream starts afresh; a frame the old one was
        writing is cut off."""
        self._tx = type(self._tx)()


class Cable:
    """brain_host's pty on one end; on the other a pty behind `port_path` for the daemon."""

    def __init__(self, brain_pty: str, port_path: Path, seed: int = 0) -> None:
        self._brain: int | None = os.open(brain_pty, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        self.port_path = Path(port_path)
        self._up = _Wire("up", True, np.random.default_rng((seed, 1)))
        self._down = _Wire("down", False, np.random.default_rng((seed, 2)))
        self._master: int | None = None
        self._slave: int | None = None
        self._conn_down_read = 0  # daemon bytes read on this connection
        self._conn_up_delivered = 0  # bytes put into the daemon's pty on this connection
        # This Brain's share of the totals: brain_host counts its tx and rx from its own start.
        self._brain_in_base = 0
        self._brain_out_base = 0
        self._reader = True  # a daemon holds the port open (False: it died, bytes are dropped)
        self._lock = threading.RLock()  # realtime: the forwarding thread against (un)plugging
        self.plugs = 0
        self.brains = 1
        self.plug_in()

    # --- state ----------------------------------------------------------------------------------

    @property
    def up(self) -> WireStats:
        return self._up.stats

    @property
    def down(self) -> WireStats:
        return self._down.stats

    @property
    def plugged(self) -> bool:
        return self._master is not None

    @property
    def delivered_up_on_connection(self) -> int:
        """Bytes put into the daemon's current pty: what it will have read once caught up."""
        return self._conn_up_delivered if self._master is not None else 0

    @property
    def delivered_down(self) -> int:
        """Bytes delivered to this brain_host since it started: its `rx=`."""
        return self._down.stats.bytes_out - self._brain_out_base

    def set_corruption(self, up: float = 0.0, down: float = 0.0) -> None:
        for p in (up, down):
            if not 0.0 <= p <= 1.0:
                raise ValueError(f"corruption is a probability per byte in [0, 1], got {p}")
        self._up.corruption = up
        self._down.corruption = down

    def keep_received(self, up: bool = False, down: bool = False) -> None:
        """Keep every message as received (tests, the replay's event track)."""
        self._up.keep_received = up
        self._down.keep_received = down

    def take_received(self, direction: str) -> list[Any]:
        wire = self._up if direction == "up" else self._down
        out, wire.received_log = wire.received_log, []
        return out

    # --- plugging -------------------------------------------------------------------------------

    def plug_in(self) -> str:
        """A new pty for the daemon, and the stable path pointed at it."""
        with self._lock:
            return self._plug_in()

    def _plug_in(self) -> str:
        if self._master is not None:
            raise CableError("the cable is already plugged in")
        self._master, self._slave, name = plug_pty(self.port_path)
        self._conn_down_read = 0
        self._conn_up_delivered = 0
        self.plugs += 1
        self._up.receiver_restarted()
        return name

    def unplug(self) -> None:
        """The USB cable pulled: the daemon's port disappears; bytes in flight are lost."""
        with self._lock:
            self._unplug()

    def _unplug(self) -> None:
        unplug_pty(self.port_path, self._master, self._slave)
        self._master = self._slave = None
        # The Brain's decoder sees a frame cut off mid-way at worst; it resynchronises itself.

    # --- the daemon's process and the Brain -----------------------------------------------------

    def reader_gone(self) -> None:
        """The daemon's process died: nobody holds its port open, so what the Brain sends now is
        lost (a tty discards input while no program has it open)."""
        with self._lock:
            self._reader = False

    def new_reader(self) -> None:
        """A new daemon process is about to open the port: it starts with an empty input queue
        and its own byte counts."""
        with self._lock:
            if self._slave is not None:
                with contextlib.suppress(OSError, termios.error):
                    termios.tcflush(self._slave, termios.TCIFLUSH)
            self._conn_down_read = 0
            self._conn_up_delivered = 0
            self._up.receiver_restarted()
            self._reader = True

    def brain_off(self) -> None:
        """The Brain went down (brain_host ended): what the daemon sends meanwhile is lost."""
        with self._lock:
            if self._brain is not None:
                with contextlib.suppress(OSError):
                    os.close(self._brain)
            self._brain = None

    def new_brain(self, brain_pty: str) -> None:
        """The Brain rebooted: brain_host's new pty replaces the old one. Bytes in flight to or
        from the old Brain are lost; the new one counts its bytes from zero."""
        with self._lock:
            self.brain_off()
            self._brain = os.open(brain_pty, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
            self._brain_in_base = self._up.stats.bytes_in
            self._brain_out_base = self._down.stats.bytes_out
            self._up.sender_restarted()
            self._down.receiver_restarted()
            self.brains += 1

    # --- forwarding -----------------------------------------------------------------------------

    def pump_up(self, brain_tx_total: int, timeout_s: float = PUMP_TIMEOUT_S) -> None:
        """Forward this brain_host's bytes until its first `brain_tx_total` have passed."""
        deadline = time.monotonic() + timeout_s
        want = self._brain_in_base + brain_tx_total
        brain = self._brain
        if brain is None:
            raise CableError("the Brain is off: no bytes to pump")
        while self._up.stats.bytes_in < want:
            left = deadline - time.monotonic()
            if left <= 0:
                raise CableError(
                    f"brain_host reported {brain_tx_total} uplink bytes, only "
                    f"{self._up.stats.bytes_in - self._brain_in_base} arrived within "
                    f"{timeout_s:g} s"
                )
            ready, _, _ = select.select([brain], [], [], left)
            if not ready:
                continue
            try:
                data = os.read(brain, 65536)
            except BlockingIOError:
                continue
            self._up.sent(data)
            self._to_jetson(self._up.corrupt(data))

    def _to_jetson(self, data: bytes) -> None:
        if self._master is None or not self._reader:
            self._up.stats.bytes_dropped += len(data)
            return
        view = memoryview(data)
        while view:
            try:
                n = os.write(self._master, view)
            except BlockingIOError:
                # Nobody reads the daemon's end (it was killed): the buffer is full, as a USB
                # host's is when no program holds the port.
                self._up.stats.bytes_dropped += len(view)
                return
            except OSError:
                self._up.stats.bytes_dropped += len(view)
                return
            self._up.delivered(bytes(view[:n]))
            self._conn_up_delivered += n
            view = view[n:]

    def pump_down(self, jetson_tx_total: int, timeout_s: float = PUMP_TIMEOUT_S) -> int:
        """Forward the daemon's bytes until the first `jetson_tx_total` it wrote on this
        connection have passed; returns `delivered_down`."""
        deadline = time.monotonic() + timeout_s
        while self._master is not None and self._conn_down_read < jetson_tx_total:
            left = deadline - time.monotonic()
            if left <= 0:
                raise CableError(
                    f"the daemon wrote {jetson_tx_total} bytes on this connection, only "
                    f"{self._conn_down_read} arrived within {timeout_s:g} s"
                )
            ready, _, _ = select.select([self._master], [], [], left)
            if not ready:
                continue
            try:
                data = os.read(self._master, 65536)
            except BlockingIOError:
                continue
            except OSError:
                break
            self._conn_down_read += len(data)
            self._to_brain(data)
        return self.delivered_down

    def drain_down(self) -> int:
        """Forward whatever the daemon wrote that is still in its pty (it has exited: all it
        wrote is there); returns `delivered_down`."""
        while self._master is not None:
            ready, _, _ = select.select([self._master], [], [], 0)
            if not ready:
                break
            try:
                data = os.read(self._master, 65536)
            except (BlockingIOError, OSError):
                break
            if not data:
                break
            self._conn_down_read += len(data)
            self._to_brain(data)
        return self.delivered_down

    def _to_brain(self, data: bytes) -> None:
        self._down.sent(data)
        if self._brain is None:
            self._down.stats.bytes_dropped += len(data)
            return
        data = self._down.corrupt(data)
        view = memoryview(data)
        while view:
            try:
                n = os.write(self._brain, view)
            except BlockingIOError:
                select.select([], [self._brain], [], 0.1)
                continue
            self._down.delivered(bytes(view[:n]))
            view = view[n:]

    # --- realtime -------------------------------------------------------------------------------

    def start_forwarding(self, stop: threading.Event) -> threading.Thread:
        """Realtime: forward both ways in a thread, as fast as bytes come, until `stop`."""

        brain = self._brain
        if brain is None:
            raise CableError("the Brain is off: nothing to forward")

        def loop() -> None:
            while not stop.is_set():
                with self._lock:
                    fds = [brain] + ([self._master] if self._master is not None else [])
                try:
                    ready, _, _ = select.select(fds, [], [], 0.02)
                except (OSError, ValueError):
                    continue  # unplugged under us
                with self._lock:
                    if brain in ready:
                        with contextlib.suppress(BlockingIOError, OSError):
                            data = os.read(brain, 65536)
                            self._up.sent(data)
                            self._to_jetson(self._up.corrupt(data))
                    if self._master is not None and self._master in ready:
                        try:
                            data = os.read(self._master, 65536)
                        except (BlockingIOError, OSError):
                            continue
                        self._down.sent(data)
                        data = self._down.corrupt(data)
                        with contextlib.suppress(OSError):
                            os.write(brain, data)
                            self._down.delivered(data)

        th = threading.Thread(target=loop, name="pete-cable", daemon=True)
        th.start()
        return th

    def close(self) -> None:
        self.unplug()
        self.brain_off()

    def as_dict(self) -> dict[str, Any]:
        return {
            "up": self.up.as_dict(), "down": self.down.as_dict(), "plugs": self.plugs,
            "brains": self.brains,
        }  # fmt: skip
