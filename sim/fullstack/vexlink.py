"""VEXlink in the twin: the radio between the two Brains of an alliance.

Each Brain (a brain_host) writes its partner reports to its radio as COBS frames ending in a zero
byte (protocol/README.md, section 13). `Vexlink` carries them to the other Brain as the radio
would: one frame at a time per direction at that direction's bandwidth (the transmitter end about
1040 bytes/s, the receiver end 520), after a latency with jitter, some frames lost, and none at
all while the link is cut (the `vexlink-lost` fault). Frames arrive whole and in order.
`relay(a, b, t_ms)` moves what both Brains wrote since the last call and hands each what has
arrived by t_ms; `stats` counts what was sent, lost and late. An end is a BrainHost (its radio
read and written by round trips of their own) or a `Radio`, the buffer a lockstep match's Brain
step carries in its own batch (sim.fullstack.partner_stack.send_step).
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

# VEXlink's bandwidth from each end (PROS pros::Link; ../shared/REFERENCE.md section 9).
TRANSMITTER_BYTES_PER_S = 1040.0
RECEIVER_BYTES_PER_S = 520.0


@dataclass(frozen=True)
class VexlinkConfig:
    """The radio between two Brains. Latency is one way, on top of the time a frame takes to go
    out at its direction's bandwidth; a frame later than `late_ms` after it was written counts
    as late (it still arrives)."""

    latency_ms: float = 15.0
    jitter_ms: float = 10.0
    loss: float = 0.02
    late_ms: float = 250.0
    transmitter_bytes_per_s: float = TRANSMITTER_BYTES_PER_S
    receiver_bytes_per_s: float = RECEIVER_BYTES_PER_S

    def __post_init__(self) -> None:
        if not 0.0 <= self.loss <= 1.0:
            raise ValueError(f"vexlink loss must be in [0, 1], got {self.loss}")
        if self.latency_ms < 0 or self.jitter_ms < 0 or self.late_ms <= 0:
            raise ValueError("vexlink latency_ms and jitter_ms must be >= 0, late_ms > 0")
        if self.transmitter_bytes_per_s <= 0 or self.receiver_bytes_per_s <= 0:
            raise ValueError("vexlink bandwidths must be positive")


class RadioEnd(Protocol):
    """A Brain's radio as the link sees it."""

    def radio_tx(self) -> bytes: ...

    def radio_rx(self, data: bytes) -> bool: ...


@dataclass
class Radio:
    """A Brain's radio in lockstep: what has arrived for it goes with its next step's batch and
    what it wrote is read in the same batch, so the radio costs no round trips of its own (the
    Brain runs nothing between its step and the next)."""

    incoming: bytes = b""  # arrived from the partner's radio, for the next step
    outgoing: bytes = b""  # what it wrote by the last step

    def radio_tx(self) -> bytes:
        out, self.outgoing = self.outgoing, b""
        return out

    def radio_rx(self, data: bytes) -> bool:
        self.incoming += data
        return True


@dataclass
class VexlinkStats:
    frames: int = 0  # written by either Brain
    delivered: int = 0
    lost: int = 0  # dropped by the radio (loss) or while the link was cut
    late: int = 0  # delivered later than late_ms after being written
    bytes: int = 0
    max_delay_ms: float = 0.0


@dataclass
class _Direction:
    bytes_per_s: float
    pending: bytearray = field(default_factory=bytearray)  # a frame not yet ended
    free_at_ms: float = 0.0  # when the radio has sent what it already has
    flight: deque[tuple[float, float, bytes]] = field(
        default_factory=deque
    )  # (arrive, sent, frame)


class Vexlink:
    """The radio between Brain `a` (the link's transmitter end) and Brain `b`."""

    def __init__(self, config: VexlinkConfig, rng: np.random.Generator) -> None:
        self.config = config
        self._rng = rng
        self._ab = _Direction(config.transmitter_bytes_per_s)
        self._ba = _Direction(config.receiver_bytes_per_s)
        self.cut = False
        self.stats = VexlinkStats()

    def carry(self, t_ms: float, from_a: bytes, from_b: bytes) -> None:
        """Bytes each Brain wrote to its radio by t_ms."""
        self._write(self._ab, t_ms, from_a)
        self._write(self._ba, t_ms, from_b)

    def arrived(self, t_ms: float) -> tuple[bytes, bytes]:
        """What has reached (a, b) by t_ms."""
        return self._take(self._ba, t_ms), self._take(self._ab, t_ms)

    def a_down(self, t_ms: float, from_b: bytes) -> None:
        """Brain a is off (a reboot): what b writes meanwhile and what was on its way to a are
        lost, not kept for a's return; a's own half-written frame goes with it."""
        self._write(self._ba, t_ms, from_b)
        self.stats.lost += len(self._ba.flight)
        self._ba.flight.clear()
        self._ab.pending.clear()

    def relay(self, a: RadioEnd, b: RadioEnd, t_ms: float) -> None:
        """Move what both brain_hosts wrote since the last call, and give each what has arrived."""
        self.carry(t_ms, a.radio_tx(), b.radio_tx())
        to_a, to_b = self.arrived(t_ms)
        a.radio_rx(to_a)
        b.radio_rx(to_b)

    def _write(self, d: _Direction, t_ms: float, data: bytes) -> None:
        cfg = self.config
        for byte in data:
            d.pending.append(byte)
            if byte != 0:
                continue
            frame = bytes(d.pending)
            d.pending.clear()
            self.stats.frames += 1
            self.stats.bytes += len(frame)
            start = max(t_ms, d.free_at_ms)
            d.free_at_ms = start + 1000.0 * len(frame) / d.bytes_per_s
            if self.cut or self._rng.random() < cfg.loss:
                self.stats.lost += 1
                continue
            jitter = self._rng.uniform(0.0, cfg.jitter_ms) if cfg.jitter_ms > 0 else 0.0
            arrive = d.free_at_ms + cfg.latency_ms + jitter
            # Frames arrive in order: never before the one ahead of it.
            if d.flight:
                arrive = max(arrive, d.flight[-1][0])
            d.flight.append((arrive, t_ms, frame))

    def _take(self, d: _Direction, t_ms: float) -> bytes:
        out = bytearray()
        while d.flight and d.flight[0][0] <= t_ms:
            arrive, sent, frame = d.flight.popleft()
            if self.cut:
                self.stats.lost += 1
                continue
            delay = arrive - sent
            self.stats.delivered += 1
            self.stats.max_delay_ms = max(self.stats.max_delay_ms, delay)
            if delay > self.config.late_ms:
                self.stats.late += 1
            out += frame
        return bytes(out)
