"""sim.fullstack.cable: the USB cable between brain_host's pty and the daemon's, with a pty pair
standing in for brain_host."""

from __future__ import annotations

import os
import pty
import select
import tty
from collections.abc import Iterator
from pathlib import Path

import pytest

from jetson.link import LinkClosed, SerialLink
from protocol import framing
from protocol.messages import (
    FINGERPRINT,
    PROTOCOL_VERSION,
    Alliance,
    Command,
    Fault,
    GpsStatus,
    Hello,
    MatchPhase,
    Role,
    State,
)
from sim.errors import CableError
from sim.fullstack.cable import Cable


class FakeBrainPort:
    """The master side of a pty, as brain_host holds it; the cable opens the slave by path."""

    def __init__(self) -> None:
        self.master, self.slave = pty.openpty()
        tty.setraw(self.slave)
        os.set_blocking(self.master, False)
        self.path = os.ttyname(self.slave)
        self.written = 0
        self.read = bytearray()

    def write(self, data: bytes) -> None:
        self.written += os.write(self.master, data)

    def read_until(self, total: int) -> bytes:
        while len(self.read) < total:
            ready, _, _ = select.select([self.master], [], [], 2.0)
            assert ready, f"only {len(self.read)} of {total} bytes reached the Brain"
            self.read += os.read(self.master, 65536)
        return bytes(self.read)

    def close(self) -> None:
        os.close(self.master)
        os.close(self.slave)


@pytest.fixture
def rig(tmp_path: Path) -> Iterator[tuple[FakeBrainPort, Cable]]:
    brain = FakeBrainPort()
    cable = Cable(brain.path, tmp_path / "brain-usb", seed=3)
    yield brain, cable
    cable.close()
    brain.close()


def state(seq: int) -> State:
    return State(
        seq=seq, time_ms=seq * 20, phase=MatchPhase.DRIVER, phase_ms=seq * 20,
        alliance=Alliance.RED, x=0.5, y=-1.0, heading=90.0, gps_error=0.01,
        gps_status=GpsStatus.OK, left_speed=0.1, right_speed=0.1, last_command_seq=seq,
        faults=Fault(0),
    )  # fmt: skip


def command(seq: int) -> Command:
    return Command(seq=seq, linear=0.3, angular=-0.5, intake=True, valid_ms=250)


def daemon_read(link: SerialLink, total: int) -> bytes:
    out = bytearray()
    while len(out) < total:
        chunk = link.read(2.0)
        assert chunk, f"only {len(out)} of {total} bytes reached the daemon"
        out += chunk
    return bytes(out)


def test_bytes_cross_unchanged_both_ways(rig: tuple[FakeBrainPort, Cable]) -> None:
    brain, cable = rig
    assert cable.port_path.is_symlink()
    link = SerialLink.open(str(cable.port_path))
    try:
        up = b"".join(framing.encode_uplink(state(k), k) for k in range(1, 6))
        brain.write(up)
        cable.pump_up(brain.written)
        assert daemon_read(link, len(up)) == up
        assert cable.delivered_up_on_connection == len(up)

        hello = Hello(FINGERPRINT, PROTOCOL_VERSION, Role.JETSON, 7, "t")
        down = framing.encode_downlink(hello, 0) + framing.encode_downlink(command(1), 1)
        assert link.write(down)
        delivered = cable.pump_down(link.tx_bytes)
        assert delivered == len(down) == cable.delivered_down
        assert brain.read_until(len(down)) == down
    finally:
        link.close()
    assert cable.up.sent == {"State": 5} and cable.up.received == {"State": 5}
    assert cable.down.sent == {"Hello": 1, "Command": 1}
    assert cable.down.messages_received == 2
    assert cable.up.lost == cable.down.lost == 0
    assert cable.up.rejected == cable.down.rejected == 0
    assert cable.up.altered == cable.down.altered == 0


def test_corruption_is_counted_and_never_delivered(rig: tuple[FakeBrainPort, Cable]) -> None:
    brain, cable = rig
    cable.set_corruption(up=0.05, down=0.05)
    link = SerialLink.open(str(cable.port_path))
    try:
        # In batches of 50 States (3.7 kB), so the daemon's pty never holds more than it buffers.
        for first in range(1, 201, 50):
            up = b"".join(
                framing.encode_uplink(state(k), k & 0xFF) for k in range(first, first + 50)
            )
            brain.write(up)
            cable.pump_up(brain.written)
            daemon_read(link, len(up))
        down = b"".join(framing.encode_downlink(command(k), k & 0xFF) for k in range(1, 201))
        link.write(down)
        cable.pump_down(link.tx_bytes)
    finally:
        link.close()
    for wire in (cable.up, cable.down):
        assert wire.bytes_corrupted > 0
        assert wire.rejected > 0, "damaged frames are refused and counted"
        assert wire.lost > 0 and wire.messages_received + wire.lost == wire.messages_sent == 200
        assert wire.altered == 0, "nothing damaged was delivered as a message"
        assert wire.bytes_out == wire.bytes_in, "corruption flips bits, it loses no bytes"


def test_unplugging_closes_the_daemons_port_and_plugging_makes_a_new_one(
    rig: tuple[FakeBrainPort, Cable],
) -> None:
    brain, cable = rig
    link = SerialLink.open(str(cable.port_path))
    cable.unplug()
    assert not cable.plugged and not cable.port_path.exists()
    with pytest.raises(LinkClosed):
        for _ in range(5):
            link.read(0.2)
    link.close()
    # The Brain keeps writing into a cable that goes nowhere.
    frame = framing.encode_uplink(state(1), 1)
    brain.write(frame)
    cable.pump_up(brain.written)
    assert cable.up.bytes_dropped == len(frame) and cable.up.messages_received == 0
    assert cable.delivered_up_on_connection == 0
    assert cable.pump_down(10_000) == 0, "nothing comes down an unplugged cable"

    cable.plug_in()
    assert cable.plugged and cable.plugs == 2
    assert cable.port_path.exists()  # (the kernel may hand out the freed pty number again)
    link = SerialLink.open(str(cable.port_path))
    try:
        brain.write(frame)
        cable.pump_up(brain.written)
        assert daemon_read(link, len(frame)) == frame
    finally:
        link.close()
    assert cable.up.lost == 1 and cable.up.messages_received == 1


def test_missing_bytes_raise_instead_of_hanging(rig: tuple[FakeBrainPort, Cable]) -> None:
    _, cable = rig
    with pytest.raises(CableError, match="uplink bytes"):
        cable.pump_up(10, timeout_s=0.1)
    with pytest.raises(CableError, match="this connection"):
        cable.pump_down(10, timeout_s=0.1)
    with pytest.raises(ValueError, match="probability"):
        cable.set_corruption(up=1.5)
