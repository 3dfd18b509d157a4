"""brain_host over a real pty, against the Python codec: the Brain firmware's core on fake hardware
puts exactly the bytes a V5 Brain would on its USB port, and its side channel plays the hardware.

brain_host is build/host/bin/brain_host (brain/host/), built by `make build` under ASan and UBSan.
Most tests run it in lockstep: the test owns the clock, and `advance MS rx=BYTES` makes brain_host
wait for every downlink byte the test wrote, so the results do not depend on scheduling.
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import subprocess
import sys
import time
from collections.abc import Iterator
from pathlib import Path
from typing import Any

import pytest

from protocol import framing
from protocol.framing import LinkError, Received, TextLine
from protocol.messages import (
    FINGERPRINT,
    PROTOCOL_VERSION,
    Command,
    Fault,
    GpsStatus,
    Hello,
    Log,
    LogLevel,
    MatchPhase,
    Role,
    State,
)

ROOT = Path(__file__).resolve().parents[2]
BRAIN_HOST = ROOT / "build" / "host" / "bin" / "brain_host"
TIMEOUT_S = 10.0
PERIOD_MS = 10

pytestmark = pytest.mark.skipif(
    not BRAIN_HOST.exists(), reason=f"{BRAIN_HOST} is not built: run `make build` (cmake) first"
)


def jetson_hello(fingerprint: int = FINGERPRINT, boot_id: int = 0xA11CE) -> Hello:
    return Hello(fingerprint, PROTOCOL_VERSION, Role.JETSON, boot_id, "test")


def command(seq: int, linear: float, angular: float, valid_ms: int = 250) -> Command:
    return Command(seq=seq, linear=linear, angular=angular, intake=False, valid_ms=valid_ms)


class LineReader:
    """Lines from a pipe with a timeout. select() on a buffered file object misses lines already
    in its buffer, so this reads the descriptor itself."""

    def __init__(self, fd: int) -> None:
        self.fd = fd
        self.buf = bytearray()

    def readline(self, timeout: float = TIMEOUT_S) -> str | None:
        deadline = time.monotonic() + timeout
        while b"\n" not in self.buf:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            ready, _, _ = select.select([self.fd], [], [], left)
            if ready:
                chunk = os.read(self.fd, 65536)
                if not chunk:
                    return None
                self.buf += chunk
        line, _, rest = bytes(self.buf).partition(b"\n")
        self.buf = bytearray(rest)
        return line.decode()


class BrainHost:
    """brain_host in lockstep, its side channel on pipes and its serial link on a pty we hold."""

    def __init__(self, *args: str) -> None:
        self.proc = subprocess.Popen(
            [str(BRAIN_HOST), "--lockstep", "--boot-id", "5EED0001", *args],
            stdin=subprocess.PIPE,
            stdout=subprocess.PIPE,
            stderr=subprocess.PIPE,
            text=True,
            bufsize=1,
        )
        assert self.proc.stdout is not None
        self.replies = LineReader(self.proc.stdout.fileno())
        ready = self._line()
        assert ready.startswith("ready "), ready
        self.ready = dict(kv.split("=", 1) for kv in ready.split()[1:])
        self.pty_path = self.ready["pty"]
        self.fd: int | None = None
        self.written = 0
        self.read_total = 0
        self.decoder = framing.UplinkDecoder()
        self.raw = bytearray()
        self.events: list[Any] = []

    def _line(self) -> str:
        line = self.replies.readline()
        assert line is not None, "brain_host did not answer on its side channel"
        return line

    def open_pty(self) -> None:
        self.fd = os.open(self.pty_path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)

    def side(self, line: str) -> str:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        return self._line()

    def ok(self, line: str) -> dict[str, str]:
        reply = self.side(line)
        assert reply.startswith("ok"), f"{line!r} -> {reply!r}"
        return dict(kv.split("=", 1) for kv in reply.split()[1:] if "=" in kv)

    def send(self, data: bytes) -> None:
        assert self.fd is not None
        os.write(self.fd, data)
        self.written += len(data)

    def advance(self, ms: int) -> dict[str, str]:
        """Run the loop for `ms`, after brain_host has every byte we wrote; then collect the
        uplink bytes it wrote (the reply says how many)."""
        report = self.ok(f"advance {ms} rx={self.written}")
        if self.fd is not None:
            self._read_until(int(report["tx"]))
        return report

    def _read_until(self, total: int) -> None:
        assert self.fd is not None
        deadline = time.monotonic() + TIMEOUT_S
        while self.read_total < total:
            left = deadline - time.monotonic()
            assert left > 0, f"uplink stalled at {self.read_total} of {total} bytes"
            ready, _, _ = select.select([self.fd], [], [], left)
            if ready:
                chunk = os.read(self.fd, 65536)
                self.read_total += len(chunk)
                self.raw += chunk
                self.events.extend(self.decoder.feed(chunk))

    def take(self) -> list[Any]:
        out, self.events = self.events, []
        return out

    def close(self) -> None:
        if self.proc.poll() is None:
            with contextlib.suppress(AssertionError, BrokenPipeError, OSError):
                self.side("quit")
        try:
            self.proc.wait(timeout=TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        if self.fd is not None:
            os.close(self.fd)
        for stream in (self.proc.stdin, self.proc.stdout, self.proc.stderr):
            if stream is not None:
                stream.close()


@pytest.fixture
def brain() -> Iterator[BrainHost]:
    host = BrainHost()
    host.open_pty()
    try:
        yield host
    finally:
        host.close()
    assert host.proc.returncode == 0, f"brain_host exited with {host.proc.returncode}"


def messages(events: list[Any], cls: type) -> list[Any]:
    return [e.message for e in events if isinstance(e, Received) and isinstance(e.message, cls)]


def connect(brain: BrainHost, phase: str = "autonomous") -> None:
    brain.ok(f"phase {phase}")
    brain.ok("gps 0.5 -1.0 90")
    brain.send(framing.encode_downlink(jetson_hello(), 0))
    report = brain.advance(PERIOD_MS)
    assert report["link"] == "connected", report


def test_handshake_hello_then_state_at_50_hz(brain: BrainHost) -> None:
    brain.advance(400)
    events = brain.take()
    hellos = messages(events, Hello)
    assert [h.role for h in hellos] == [Role.BRAIN] * 2, "Hello at t=0 and t=200, nothing else"
    assert hellos[0].fingerprint == FINGERPRINT
    assert hellos[0].boot_id == 0x5EED0001
    assert hellos[0].software_version == "0.1.0"
    assert messages(events, State) == []
    assert [e.text for e in events if isinstance(e, TextLine)] == ["pete brain 0.1.0 boot 5EED0001"]

    brain.send(framing.encode_downlink(jetson_hello(), 0))
    brain.advance(1000)
    events = brain.take()
    states = messages(events, State)
    assert len(messages(events, Hello)) == 1, "one Hello in reply to the Jetson's"
    assert len(states) == 50, "State every 20 ms for one second"
    assert [s.seq for s in states] == list(range(1, 51))
    assert [s.time_ms for s in states] == list(range(400, 1400, 20))
    assert all(s.gps_status == GpsStatus.ABSENT for s in states), "no GPS reading was given"
    assert brain.decoder.stats.error_total == 0
    assert brain.decoder.stats.lost == 0


def test_uplink_is_exactly_pros_stream_framing(brain: BrainHost) -> None:
    """Every byte re-encodes: the banner as one `sout` frame, each packet as one `pete` frame."""
    connect(brain)
    brain.advance(100)
    expected = bytearray()
    for event in brain.take():
        assert not isinstance(event, LinkError), event
        if isinstance(event, TextLine):
            expected += framing.stream_frame(b"sout", event.text.encode() + b"\n")
        else:
            expected += framing.encode_uplink(event.message, event.seq)
    assert bytes(brain.raw) == bytes(expected)


def test_pete_protocol_decode_reads_brain_host_over_the_pty() -> None:
    host = BrainHost()
    decode = subprocess.Popen(
        [sys.executable, "-m", "protocol.cli", "decode", "--link", "up", "--input", host.pty_path],
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
        text=True,
        cwd=ROOT,
    )
    seen: list[dict[str, Any]] = []
    assert decode.stdout is not None
    decoded = LineReader(decode.stdout.fileno())

    def read_decoded(until: float) -> bool:
        line = decoded.readline(max(0.0, until - time.monotonic()))
        if line is None:
            return False
        seen.append(json.loads(line))
        return True

    try:
        # `pete-protocol decode` opens the pty as a serial port, which flushes what was queued
        # before (as when a Jetson opens a live Brain's port): run the Brain until it is reading.
        deadline = time.monotonic() + TIMEOUT_S
        while not seen:
            assert time.monotonic() < deadline, "pete-protocol decode never read the pty"
            host.ok("advance 200")  # one Hello per 200 ms while waiting for the Jetson
            read_decoded(time.monotonic() + 0.2)
        # Now the test plays the Jetson (writing only; decode is the pty's only reader).
        host.fd = os.open(host.pty_path, os.O_WRONLY | os.O_NOCTTY)
        host.ok("phase autonomous")
        host.ok("gps 0.25 0.75 180 0.03")
        host.send(framing.encode_downlink(jetson_hello(), 0))
        host.ok(f"advance 60 rx={host.written}")
        while sum(e.get("name") == "State" for e in seen) < 3:
            assert read_decoded(deadline), f"expected 3 States, decoded {seen}"
    finally:
        decode.kill()
        decode.wait()
        host.close()
    assert not [e for e in seen if e["type"] == "error"], seen
    hellos = [e["fields"] for e in seen if e.get("name") == "Hello"]
    assert hellos[0]["role"] == "brain"
    assert hellos[0]["fingerprint"] == FINGERPRINT
    assert hellos[0]["boot_id"] == 0x5EED0001
    logs = [e["fields"]["text"] for e in seen if e.get("name") == "Log"]
    assert "phase autonomous" in logs
    assert any(text.startswith("jetson connected") for text in logs)
    states = [e["fields"] for e in seen if e.get("name") == "State"]
    assert len(states) == 3
    assert [s["seq"] for s in states] == [1, 2, 3]
    assert states[0]["phase"] == "autonomous"
    assert states[0]["gps_status"] == "ok"
    assert states[0]["x"] == pytest.approx(0.25)
    assert states[0]["y"] == pytest.approx(0.75)
    assert states[0]["heading"] == pytest.approx(180.0)
    assert states[0]["alliance"] == "red"
    assert "command_timeout" in states[0]["faults"]


def test_a_command_drives_the_wheels(brain: BrainHost) -> None:
    connect(brain)
    seq = 1
    report: dict[str, str] = {}
    for _ in range(50):  # 0.5 s of Commands at 100 Hz: the slew limit is long satisfied
        brain.send(framing.encode_downlink(command(seq, 0.5, 0.0), seq & 0xFF))
        report = brain.advance(PERIOD_MS)
        seq += 1
    assert report["source"] == "jetson"
    assert float(report["left_mps"]) == pytest.approx(0.5, abs=1e-4)
    assert float(report["right_mps"]) == pytest.approx(0.5, abs=1e-4)
    assert float(report["left_rpm"]) > 0

    for _ in range(50):  # positive angular is clockwise: the left side runs faster
        brain.send(framing.encode_downlink(command(seq, 0.3, 1.0), seq & 0xFF))
        report = brain.advance(PERIOD_MS)
        seq += 1
    assert float(report["left_mps"]) == pytest.approx(0.3 + 0.15, abs=1e-3)
    assert float(report["right_mps"]) == pytest.approx(0.3 - 0.15, abs=1e-3)
    states = messages(brain.take(), State)
    assert states[-1].last_command_seq >= seq - 3
    assert states[-1].left_speed == pytest.approx(0.45, abs=1e-3), "the ideal fake motor"


def test_command_timeout_stops_the_wheels(brain: BrainHost) -> None:
    connect(brain)
    brain.send(framing.encode_downlink(command(1, 0.4, 0.0, valid_ms=100), 1))
    report = brain.advance(100)  # steps at 10 .. 100: the Command arrived at 10
    assert report["source"] == "jetson"
    assert report["stopped"] == "0"
    report = brain.advance(PERIOD_MS)  # step at 110: 100 ms old
    assert report["source"] == "none"
    assert report["stopped"] == "1"
    assert float(report["left_rpm"]) == 0.0
    assert "command_timeout" in report["faults"].split(",")
    brain.advance(40)
    events = brain.take()
    logs = messages(events, Log)
    assert any(
        log.level == LogLevel.WARNING and log.text.startswith("command timeout") for log in logs
    )
    assert Fault.COMMAND_TIMEOUT in messages(events, State)[-1].faults


def test_fingerprint_mismatch_keeps_the_robot_stopped(brain: BrainHost) -> None:
    brain.ok("phase autonomous")
    brain.send(framing.encode_downlink(jetson_hello(fingerprint=FINGERPRINT ^ 0xFFFF), 0))
    for seq in range(1, 40):
        brain.send(framing.encode_downlink(command(seq, 1.0, 0.0), seq))
        report = brain.advance(PERIOD_MS)
        assert report["stopped"] == "1", report
        assert report["link"] == "mismatch"
    events = brain.take()
    assert messages(events, State) == [], "no State for a peer that cannot read it"
    assert messages(events, Hello), "Hello continues, so the Jetson can diagnose it too"
    errors = [log for log in messages(events, Log) if log.level == LogLevel.ERROR]
    assert errors, "a Log error names the mismatch"
    assert errors[0].text == (
        f"fingerprint mismatch peer={FINGERPRINT ^ 0xFFFF:08X} ours={FINGERPRINT:08X}"
    )


def test_disabled_ignores_commands_and_reenable_restarts_the_phase_clock(
    brain: BrainHost,
) -> None:
    connect(brain, phase="disabled")
    for seq in range(1, 20):
        brain.send(framing.encode_downlink(command(seq, 1.0, 0.0), seq))
        report = brain.advance(PERIOD_MS)
        assert report["stopped"] == "1"
    brain.ok("phase autonomous")
    report = brain.advance(500)
    assert report["phase"] == "autonomous"
    assert report["phase_ms"] == "490"
    brain.ok("phase disabled")
    brain.advance(100)
    brain.ok("phase autonomous")
    report = brain.advance(PERIOD_MS)
    assert report["phase_ms"] == "0", "a re-enable starts autonomous again"
    states = messages(brain.take(), State)
    assert states[-1].phase == MatchPhase.AUTONOMOUS


def test_garbage_on_the_serial_link_never_moves_the_robot(brain: BrainHost) -> None:
    connect(brain)
    junk = bytes((i * 97 + 13) & 0xFF for i in range(4000))
    for start in range(0, len(junk), 400):
        brain.send(junk[start : start + 400])
        report = brain.advance(PERIOD_MS)
        assert report["stopped"] == "1"
    assert "link_errors" in report["faults"].split(",")
    # The link recovers on the next good line.
    brain.send(b"\n" + framing.encode_downlink(command(1, 0.2, 0.0), 1))
    assert brain.advance(PERIOD_MS)["source"] == "jetson"


def test_side_channel_rejects_bad_input_with_a_reason(brain: BrainHost) -> None:
    assert brain.side("gps 1 two 3") == "error gps: 'two' is not a finite number"
    assert brain.side("teleport") == "error unknown command 'teleport' (try: help)"
    assert brain.side("until 0").startswith("ok t=0 ")
    brain.advance(50)
    assert brain.side("until 10").startswith("error time 10 is before now (50)")
    assert brain.side("rings 255").startswith("error rings N (0..254)")
    assert brain.side("rings 2.5").startswith("error rings N (0..254)")
    assert brain.side("clamp 2") == "error clamp 0|1|unknown"


def test_ring_counter_reaches_the_jetson_in_the_state(brain: BrainHost) -> None:
    assert brain.side("rings 3") == "ok"
    brain.advance(20)
    assert " rings=3 " in brain.side("get")
    assert brain.side("rings unknown") == "ok"
    brain.advance(20)
    assert " rings=255 " in brain.side("get")


def test_clamp_sensor_reaches_the_jetson_in_the_state(brain: BrainHost) -> None:
    connect(brain)
    brain.advance(20)
    assert messages(brain.take(), State)[-1].goal_clamped == 255, "no sensor by default"
    assert brain.side("clamp 1") == "ok"
    brain.advance(20)
    assert " clamp=1 clamp_closed=1 " in brain.side("get")
    assert messages(brain.take(), State)[-1].goal_clamped == 1
    assert brain.side("clamp 0") == "ok"
    brain.advance(20)
    assert " clamp=0 clamp_closed=1 " in brain.side("get")


def test_realtime_mode_streams_state_on_the_wall_clock() -> None:
    proc = subprocess.Popen(
        [str(BRAIN_HOST), "--realtime", "--phase", "autonomous"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        text=True,
        bufsize=1,
    )
    try:
        assert proc.stdout is not None and proc.stdin is not None
        ready = LineReader(proc.stdout.fileno()).readline()
        assert ready is not None and ready.startswith("ready "), ready
        info = dict(kv.split("=", 1) for kv in ready.split()[1:])
        assert info["mode"] == "realtime"
        fd = os.open(info["pty"], os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        decoder = framing.UplinkDecoder()
        states: list[State] = []
        os.write(fd, framing.encode_downlink(jetson_hello(), 0))
        start = time.monotonic()
        while time.monotonic() - start < 1.0:
            readable, _, _ = select.select([fd], [], [], 0.05)
            if readable:
                states += messages(decoder.feed(os.read(fd, 65536)), State)
        os.close(fd)
        proc.stdin.write("quit\n")
        proc.stdin.flush()
        assert proc.wait(timeout=TIMEOUT_S) == 0
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
    # 50 Hz for about a second; loose bounds, since the machine may be busy.
    assert 20 <= len(states) <= 60, len(states)
    times = [s.time_ms for s in states]
    assert times == sorted(times)
    assert decoder.stats.error_total == 0


def test_stdio_link_pipes_into_pete_protocol_decode() -> None:
    host = subprocess.Popen(
        [str(BRAIN_HOST), "--link", "stdio", "--duration-ms", "250", "--boot-id", "ABC"],
        stdin=subprocess.PIPE,
        stdout=subprocess.PIPE,
        stderr=subprocess.PIPE,
    )
    out, err = host.communicate(timeout=TIMEOUT_S)
    assert host.returncode == 0, err
    assert b"ready link=stdio" in err
    decode = subprocess.run(
        [sys.executable, "-m", "protocol.cli", "decode", "--link", "up", "--stats"],
        input=out,
        capture_output=True,
        cwd=ROOT,
        timeout=TIMEOUT_S,
        check=True,
    )
    lines = [json.loads(line) for line in decode.stdout.splitlines()]
    hellos = [e for e in lines if e.get("name") == "Hello"]
    assert len(hellos) == 2  # t=0 and t=200 ms
    assert hellos[0]["fields"]["boot_id"] == 0xABC
    assert lines[-1]["type"] == "stats"
    assert sum(lines[-1]["errors"].values()) == 0


def test_brain_host_refuses_bad_options() -> None:
    for args in (["--link", "usb"], ["--lockstep", "--link", "stdio"], ["--phase", "halftime"]):
        proc = subprocess.run(
            [str(BRAIN_HOST), *args], capture_output=True, text=True, timeout=TIMEOUT_S
        )
        assert proc.returncode == 2, args
        assert "brain_host:" in proc.stderr and "usage:" in proc.stderr


def test_loop_benchmark_reports_every_scenario() -> None:
    from bench.brain_loop import DEFAULT_BENCH, SCENARIOS, run_bench

    if not DEFAULT_BENCH.exists():
        pytest.skip(f"{DEFAULT_BENCH} is not built")
    data = run_bench(DEFAULT_BENCH, 200)  # raises SystemExit on any missing or absurd number
    assert data["loop_period_ms"] == PERIOD_MS
    for name in SCENARIOS:
        assert data[name]["steps"] == 200
        assert 0 < data[name]["p50_us"] < PERIOD_MS * 1000
