"""VEXlink in the twin (sim.fullstack.vexlink) alone, and between two real brain_hosts: a Jetson's
partner report crosses to the partner's Jetson, and a cut link is lost on both sides."""

from __future__ import annotations

import contextlib
from collections.abc import Iterator

import numpy as np
import pytest

from protocol.messages import (
    FINGERPRINT,
    PROTOCOL_VERSION,
    Hello,
    Partner,
    PartnerFlags,
    PartnerLink,
    PartnerStatus,
    Role,
    TargetKind,
)
from sim.fullstack.brain_host import DEFAULT_BINARY, BrainHost
from sim.fullstack.partner_stack import finish_step, send_step
from sim.fullstack.vexlink import Radio, Vexlink, VexlinkConfig
from tests.sim.fullstack.pty_port import Port


def frame(n: int, fill: int = 0x41) -> bytes:
    """A radio frame of n bytes: n - 1 non-zero bytes and the zero that ends it."""
    return bytes([fill]) * (n - 1) + b"\x00"


def test_a_frame_arrives_after_its_airtime_and_latency() -> None:
    link = Vexlink(VexlinkConfig(latency_ms=15, jitter_ms=0, loss=0.0), np.random.default_rng(0))
    link.carry(0, frame(26), b"")
    assert link.arrived(39) == (b"", b"")  # 26 bytes at 1040 B/s take 25 ms, then 15 ms
    assert link.arrived(41) == (b"", frame(26))
    link.carry(100, b"", frame(26))  # the receiver end's half bandwidth: 50 ms of airtime
    assert link.arrived(164) == (b"", b"")
    assert link.arrived(166) == (frame(26), b"")
    assert link.stats.delivered == 2 and link.stats.lost == 0


def test_while_one_brain_is_down_nothing_waits_for_its_return() -> None:
    """A Brain rebooting hears nothing: what its partner sent meanwhile, and what was on its
    way, is lost, not delivered when it comes back."""
    link = Vexlink(VexlinkConfig(latency_ms=15, jitter_ms=0, loss=0.0), np.random.default_rng(0))
    link.carry(0, b"", frame(26))  # on its way to a
    link.a_down(10, frame(26, 0x42))  # a goes down: b's next report too
    link.a_down(20, b"")
    assert link.stats.lost == 2 and link.stats.frames == 2
    link.carry(500, b"", frame(26, 0x43))  # a is back: only what b sends now arrives
    assert link.arrived(1000) == (frame(26, 0x43), b"")


def test_a_frame_cut_across_writes_goes_whole() -> None:
    link = Vexlink(VexlinkConfig(jitter_ms=0, loss=0.0), np.random.default_rng(0))
    whole = frame(26)
    link.carry(0, whole[:10], b"")
    link.carry(10, whole[10:], b"")
    assert link.arrived(1000)[1] == whole
    assert link.stats.frames == 1


def test_more_than_the_bandwidth_queues_and_turns_late() -> None:
    link = Vexlink(VexlinkConfig(jitter_ms=0, loss=0.0), np.random.default_rng(0))
    for t in range(0, 1000, 10):  # 2,600 bytes/s offered to a 520 bytes/s direction
        link.carry(t, b"", frame(26))
    got = link.arrived(1000)[0]
    assert len(got) <= 520 + 26
    assert link.stats.late > 0


def test_loss_drops_about_its_share_and_frames_stay_in_order() -> None:
    link = Vexlink(VexlinkConfig(loss=0.2, jitter_ms=20), np.random.default_rng(1))
    sent = [bytes([i % 250 + 1]) * 5 + b"\x00" for i in range(2000)]
    for i, f in enumerate(sent):
        link.carry(i * 100, f, b"")
    got = link.arrived(1e9)[1]
    frames = [f + b"\x00" for f in got.split(b"\x00")[:-1]]
    assert 0.15 < link.stats.lost / len(sent) < 0.25
    assert len(frames) == link.stats.delivered
    positions, k = [], 0
    for f in frames:
        k = sent.index(f, k)
        positions.append(k)
        k += 1
    assert positions == sorted(positions)


def test_a_cut_link_carries_nothing() -> None:
    link = Vexlink(VexlinkConfig(jitter_ms=0, loss=0.0), np.random.default_rng(0))
    link.carry(0, frame(26), frame(26))
    link.cut = True
    assert link.arrived(1000) == (b"", b"")
    link.carry(1000, frame(26), b"")
    assert link.arrived(2000) == (b"", b"")
    assert link.stats.lost == 3 and link.stats.delivered == 0


def test_bad_settings_are_named() -> None:
    with pytest.raises(ValueError, match="loss"):
        VexlinkConfig(loss=1.5)
    with pytest.raises(ValueError, match="bandwidth"):
        VexlinkConfig(receiver_bytes_per_s=0)


@contextlib.contextmanager
def two_brains(boot_id: int) -> Iterator[tuple[list[BrainHost], list[Port]]]:
    """Two brain_hosts with their radios on, each with a Jetson (a test port) that said hello;
    both closed after, and each must end cleanly."""
    hosts = [BrainHost.start(boot_id=boot_id + i) for i in range(2)]
    ports = [Port(h.pty_path) for h in hosts]
    try:
        for h, p in zip(hosts, ports, strict=True):
            h.set_radio("on")
            p.send(Hello(FINGERPRINT, PROTOCOL_VERSION, Role.JETSON, 0xA11CE, "test"))
        yield hosts, ports
    finally:
        for p in ports:
            p.close()
        statuses = [h.close() for h in hosts]
    assert statuses == [0, 0]


@pytest.mark.skipif(not DEFAULT_BINARY.exists(), reason="brain_host is not built: run `make build`")
def test_two_brains_carry_a_report_between_their_jetsons_and_a_cut_is_lost_on_both() -> None:
    link = Vexlink(VexlinkConfig(loss=0.0), np.random.default_rng(0))
    with two_brains(0x5EED0010) as (hosts, ports):
        report = Partner(
            x_mm=-1200, y_mm=900, heading_cdeg=4500, flags=PartnerFlags.POSE_OK, goal=1,
            rings=6, target=TargetKind.GOAL, target_id=3, target_x_mm=0, target_y_mm=0,
            match_ms=0,
        )  # fmt: skip
        t = 0
        for step in range(100):  # one second, the Jetson of Brain a reporting every 100 ms
            t += 10
            if step % 10 == 0:
                ports[0].send(report)
            reps = [h.until(t, rx=p.written) for h, p in zip(hosts, ports, strict=True)]
            link.relay(hosts[0], hosts[1], t)
        ports[1].collect(reps[1].tx)
        heard = [m for m in ports[1].messages if isinstance(m, Partner)]
        assert heard and heard[-1] == report, "the partner's Jetson hears the report unchanged"
        assert 8 <= len(heard) <= 10  # one report a period; the last may still be in the air
        status = [m for m in ports[1].messages if isinstance(m, PartnerStatus)]
        assert status[-1].link is PartnerLink.UP and reps[1].partner == "up"
        assert link.stats.max_delay_ms < 100
        # Brain b's Jetson never reported: Brain a hears nothing and stays connecting.
        assert reps[0].partner == "connecting"

        link.cut = True  # the vexlink-lost fault
        for h in hosts:
            h.set_radio("unlinked")
        for _ in range(120):
            t += 10
            if t % 100 == 0:
                ports[0].send(report)
            reps = [h.until(t, rx=p.written) for h, p in zip(hosts, ports, strict=True)]
            link.relay(hosts[0], hosts[1], t)
        assert reps[1].partner == "lost"
        ports[1].collect(reps[1].tx)
        status = [m for m in ports[1].messages if isinstance(m, PartnerStatus)]
        assert status[-1].link is PartnerLink.LOST


class _PortCable:
    """What send_step/finish_step read of a cable, over a test Port: the bytes written to the
    Brain so far; what the Brain wrote is collected from the reports instead."""

    def __init__(self, port: Port) -> None:
        self.port = port

    @property
    def delivered_down(self) -> int:
        return self.port.written

    def pump_up(self, tx: int) -> None:
        pass


@pytest.mark.skipif(not DEFAULT_BINARY.exists(), reason="brain_host is not built: run `make build`")
def test_the_radio_rides_in_each_brains_step_batch_one_round_trip_a_step() -> None:
    # A lockstep match's two Brains (sim.fullstack.partner_stack): both steps sent before
    # either is read, the radio's bytes in the same batches; the report crosses as by relay().
    radios = [Radio(), Radio()]
    link = Vexlink(VexlinkConfig(loss=0.0), np.random.default_rng(0))
    with two_brains(0x5EED0020) as (hosts, ports):
        cables = [_PortCable(p) for p in ports]
        report = Partner(
            x_mm=300, y_mm=-600, heading_cdeg=9000, flags=PartnerFlags.POSE_OK, goal=0,
            rings=2, target=TargetKind.RING, target_id=7, target_x_mm=100, target_y_mm=200,
            match_ms=0,
        )  # fmt: skip
        trips = [h.round_trips for h in hosts]
        t = 0
        for step in range(100):
            t += 10
            if step % 10 == 0:
                ports[1].send(report)  # the other way this time: b's Jetson reports to a's
            sent = [
                send_step(h, c, [], t, r) for h, c, r in zip(hosts, cables, radios, strict=True)
            ]
            reps = [finish_step(s, c) for s, c in zip(sent, cables, strict=True)]
            link.relay(radios[0], radios[1], t)
        assert [h.round_trips - n for h, n in zip(hosts, trips, strict=True)] == [100, 100]
        ports[0].collect(reps[0].tx)
        heard = [m for m in ports[0].messages if isinstance(m, Partner)]
        assert heard and heard[-1] == report
        assert 8 <= len(heard) <= 10
        assert reps[0].partner == "up" and reps[1].partner == "connecting"
