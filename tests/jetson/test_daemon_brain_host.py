"""The daemon against brain_host: the Brain firmware's real core on fake hardware, over a pty
carrying exactly a V5's USB bytes (brain/README.md, "brain_host").

Lockstep tests run the daemon in this process on a ManualClock and brain_host on simulated time,
the way a simulator would (jetson/README.md, "In a simulator"): no thread, no wall-clock timing,
the same bytes every run. Realtime tests run both on the wall clock for what needs a process to
die or bytes to be damaged in flight.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import pty
import select
import signal
import subprocess
import sys
import threading
import time
import tty
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from jetson.camera_feed import SyncPerception
from jetson.clock import ManualClock, MonotonicClock
from jetson.decide import Decider
from jetson.log import EventLog
from jetson.loop import Daemon
from jetson.service import build
from jetson.settings import LinkConfig, Settings
from jetson.testing import ProbePolicy, write_mlp_policy
from protocol.messages import FINGERPRINT, Alliance, GpsStatus, MatchPhase, PoseFix, State

ROOT = Path(__file__).resolve().parents[2]
BRAIN_HOST = ROOT / "build" / "host" / "bin" / "brain_host"
TIMEOUT_S = 10.0
X, Y, HEADING = 0.5, -0.5, 90.0

pytestmark = [
    pytest.mark.skipif(
        not BRAIN_HOST.exists(), reason=f"{BRAIN_HOST} is not built: run `make build` first"
    ),
    # A daemon thread that dies of an exception fails the test, not just warns.
    pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning"),
]


def expected_linear(policy: ProbePolicy) -> float:
    state = State(x=X, alliance=Alliance.RED, phase=MatchPhase.AUTONOMOUS, gps_status=GpsStatus.OK)
    return float(np.float32(policy.expected(state, 0)[0]))


class Host:
    """brain_host with its side channel on pipes; its pty is for the daemon."""

    def __init__(self, *args: str, lockstep: bool = True, boot_id: str = "5EED0001") -> None:
        mode = "--lockstep" if lockstep else "--realtime"
        self.proc = subprocess.Popen(
            [str(BRAIN_HOST), mode, "--boot-id", boot_id, *args],
            stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=subprocess.DEVNULL,
            text=True, bufsize=1,
        )  # fmt: skip
        self._buf = b""
        ready = self._line()
        assert ready.startswith("ready "), ready
        self.pty = dict(kv.split("=", 1) for kv in ready.split()[1:])["pty"]

    def _line(self) -> str:
        assert self.proc.stdout is not None
        fd = self.proc.stdout.fileno()
        deadline = time.monotonic() + TIMEOUT_S
        while b"\n" not in self._buf:
            left = deadline - time.monotonic()
            assert left > 0, "brain_host did not answer"
            if select.select([fd], [], [], left)[0]:
                chunk = os.read(fd, 65536)
                assert chunk, "brain_host exited"
                self._buf += chunk
        line, _, self._buf = self._buf.partition(b"\n")
        return line.decode()

    def ok(self, line: str) -> dict[str, str]:
        assert self.proc.stdin is not None
        self.proc.stdin.write(line + "\n")
        self.proc.stdin.flush()
        reply = self._line()
        assert reply.startswith("ok"), f"{line!r} -> {reply!r}"
        return dict(kv.split("=", 1) for kv in reply.split()[1:] if "=" in kv)

    def close(self) -> None:
        if self.proc.poll() is None:
            with contextlib.suppress(AssertionError, BrokenPipeError, OSError):
                self.proc.stdin.write("quit\n")  # type: ignore[union-attr]
                self.proc.stdin.flush()  # type: ignore[union-attr]
        try:
            self.proc.wait(timeout=TIMEOUT_S)
        except subprocess.TimeoutExpired:
            self.proc.kill()
            self.proc.wait()
        for stream in (self.proc.stdin, self.proc.stdout):
            if stream is not None:
                with contextlib.suppress(OSError):
                    stream.close()


def point(link: Path, target: str) -> None:
    """Point the stable name at a port, atomically, as udev does when the Brain appears."""
    tmp = link.with_name(link.name + ".new")
    with contextlib.suppress(FileNotFoundError):
        tmp.unlink()
    tmp.symlink_to(target)
    os.replace(tmp, link)


class Lockstep:
    """brain_host on simulated time and the daemon in this process on the same clock, set up as
    jetson/README.md ("In a simulator") tells a simulator to."""

    def __init__(self, tmp_path: Path, policy: Any = None, fingerprint: int = FINGERPRINT) -> None:
        self.host = Host()
        self.link = tmp_path / "pete-brain"
        point(self.link, self.host.pty)
        self.clock = ManualClock()
        self.out = io.StringIO()
        settings = Settings().with_overrides(
            link={"port": str(self.link)},
            camera={"enabled": False},
            record={"dir": ""},
            log={"level": "debug"},
        )
        self.service = build(
            settings, self.clock, self.out, policy=policy or ProbePolicy(),
            boot_id=0x7E750001, fingerprint=fingerprint,
        )  # fmt: skip
        self.daemon = self.service.daemon
        self.daemon.service(0)  # opens the port and says Hello

    def step(self, ms: int = 10) -> dict[str, str]:
        """Brain steps with every byte the daemon wrote; then the daemon reads all it got."""
        report = self.host.ok(f"advance {ms} rx={self.daemon.tx_bytes}")
        self.clock.advance(ms / 1000)
        tx = int(report["tx"])
        assert self.daemon.pump_until(lambda: self.daemon.rx_bytes >= tx, TIMEOUT_S)
        return report

    def records(self, event: str) -> list[dict[str, Any]]:
        lines = [json.loads(x) for x in self.out.getvalue().splitlines()]
        return [r for r in lines if r["event"] == event]

    def close(self) -> None:
        self.daemon.shutdown("test over")
        self.host.close()


@pytest.fixture
def rig(tmp_path: Path) -> Iterator[Lockstep]:
    r = Lockstep(tmp_path)
    yield r
    r.close()


def test_lockstep_handshake_and_commands_drive_the_brain(rig: Lockstep) -> None:
    rig.host.ok("phase autonomous")
    rig.host.ok(f"gps {X} {Y} {HEADING} 0.01")
    # The wheels report standing still, as the fixed GPS says: the Brain's pose stays at X, Y
    # (its filter fuses them), so the probe policy's Command stays the same.
    rig.host.ok("measured 0 0")
    reports = [rig.step() for _ in range(100)]  # one simulated second
    last = reports[-1]
    assert last["link"] == "connected" and last["source"] == "jetson", last
    assert rig.daemon.state == "up"
    # The probe policy's Command, through the real core's kinematics and slew limits.
    linear = expected_linear(rig.daemon.decider.policy)
    assert float(last["linear"]) == pytest.approx(linear, abs=1e-4)
    assert float(last["angular"]) == pytest.approx(0.0, abs=1e-6)
    assert last["intake"] == "1" and last["timeouts"] == "0"
    # Every State was answered, and the Brain applied the newest Command before each step.
    states = rig.daemon.counters.states
    assert 45 <= states <= 51 and rig.daemon.counters.states_skipped == 0
    assert rig.daemon.latency.count == states
    sent_before_last = rig.daemon.last_command.seq  # type: ignore[union-attr]
    assert int(rig.step()["last_command_seq"]) == sent_before_last
    # The Brain's own text and Log messages are in the daemon's log.
    assert any("pete brain 0.1.0 boot 5EED0001" in r["msg"] for r in rig.records("brain_text"))
    assert any("jetson connected" in r["msg"] for r in rig.records("brain_log"))
    assert rig.daemon.link_errors() == {}


def test_lockstep_rings_set_by_the_simulator_reach_the_policy(tmp_path: Path) -> None:
    rig = Lockstep(tmp_path)
    perception = SyncPerception(lambda frame: frame, rig.clock)
    rig.daemon.perception = perception
    try:
        rig.host.ok("phase autonomous")
        rig.host.ok(f"gps {X} {Y} {HEADING} 0.01")
        for i in range(60):
            if i % 4 == 0:  # a camera frame every 40 ms of simulated time
                perception.set_rings([[0.1, 0.7], [-0.2, 1.0]])
            report = rig.step()
        turning = float(report["angular"])
        for _ in range(60):  # no new frame: after 0.3 s the rings are stale, then none
            report = rig.step()
        straight = float(report["angular"])
    finally:
        rig.close()
    assert turning == pytest.approx(2 / 10 * 2.0, abs=1e-4)  # the probe turns 0.2 rad/s a ring
    assert straight == pytest.approx(0.0, abs=1e-6) and report["source"] == "jetson"


def test_lockstep_the_policy_drives_only_when_enabled(rig: Lockstep) -> None:
    rig.host.ok(f"gps {X} {Y} {HEADING} 0.01")
    report = [rig.step() for _ in range(30)][-1]
    assert report["link"] == "connected" and report["phase"] == "disabled"
    assert rig.daemon.last_decision.reason == "phase disabled"  # type: ignore[union-attr]
    assert rig.daemon.counters.states == rig.daemon.counters.stops > 0
    rig.host.ok("phase autonomous")
    report = [rig.step() for _ in range(30)][-1]
    assert report["source"] == "jetson" and float(report["linear"]) > 0.05


def test_lockstep_a_fingerprint_mismatch_never_drives(tmp_path: Path) -> None:
    rig = Lockstep(tmp_path, fingerprint=0x12345678)
    try:
        rig.host.ok("phase autonomous")
        rig.host.ok(f"gps {X} {Y} {HEADING} 0.01")
        reports = [rig.step() for _ in range(150)]
        state = rig.daemon.state
    finally:
        rig.close()
    assert all(r["source"] == "none" and r["last_command_seq"] == "0" for r in reports)
    assert reports[-1]["link"] == "mismatch" and "fingerprint_mismatch" in reports[-1]["faults"]
    assert state == "mismatch" and rig.daemon.counters.commands == 0
    [ours] = rig.records("fingerprint_mismatch")  # once, loudly (then every 10 s)
    assert "REFUSING TO DRIVE" in ours["msg"] and f"0x{FINGERPRINT:08X}" in ours["msg"]
    # ... and the Brain says why too, in our log.
    assert any("mismatch" in r["msg"] and r["level"] == "error" for r in rig.records("brain_log"))


def wait_for(cond: Callable[[], bool], timeout_s: float = TIMEOUT_S) -> bool:
    deadline = time.monotonic() + timeout_s
    while not cond():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True


@contextlib.contextmanager
def threaded_daemon(port: Path, policy: Any = None) -> Iterator[tuple[Daemon, io.StringIO]]:
    clock = MonotonicClock()
    out = io.StringIO()
    daemon = Daemon(
        Decider(policy or ProbePolicy()), clock, EventLog(out, None, clock, "debug"),
        link=LinkConfig(port=str(port)),
    )  # fmt: skip
    stop = threading.Event()
    thread = threading.Thread(target=daemon.run, args=(stop,), daemon=True)
    thread.start()
    try:
        yield daemon, out
    finally:
        stop.set()
        thread.join(5.0)


def realtime_host(boot_id: str) -> Host:
    host = Host("--phase", "autonomous", lockstep=False, boot_id=boot_id)
    host.ok(f"gps {X} {Y} {HEADING} 0.01")
    host.ok("measured 0 0")  # standing still, as the GPS says: the Brain's pose stays at X, Y
    return host


def test_brain_host_dying_and_a_new_one_appearing_reconnects_within_a_second(
    tmp_path: Path,
) -> None:
    link = tmp_path / "pete-brain"
    first = realtime_host("5EED0001")
    point(link, first.pty)
    with threaded_daemon(link) as (daemon, out):
        assert wait_for(lambda: first.ok("get")["source"] == "jetson")
        first.proc.kill()  # power off: no goodbye
        first.close()
        link.unlink()  # udev removes the name with the device
        assert wait_for(lambda: daemon.state == "waiting for port")
        time.sleep(0.2)
        second = realtime_host("5EED0002")
        try:
            point(link, second.pty)
            appeared = time.monotonic()
            assert wait_for(lambda: daemon.counters.connects == 2)
            reconnected_s = time.monotonic() - appeared
            assert wait_for(lambda: second.ok("get")["source"] == "jetson")
            up_s = time.monotonic() - appeared
            report = second.ok("get")
        finally:
            second.close()
    assert reconnected_s < 1.0, f"port reopened {reconnected_s:.3f} s after it appeared"
    assert up_s < 2.0, f"driving again {up_s:.3f} s after the Brain appeared"
    assert report["link"] == "connected"
    ups = [json.loads(x) for x in out.getvalue().splitlines() if '"link_up"' in x]
    assert [u["brain_boot_id"] for u in ups] == ["5EED0001", "5EED0002"]


class CorruptingRelay:
    """Sits on the cable: copies bytes both ways between brain_host's pty and a new pty the
    daemon opens, flipping a random bit in a fraction of them."""

    def __init__(self, brain_pty: str, p: float, seed: int = 3) -> None:
        self.rng = np.random.default_rng(seed)
        self.p = p
        self.brain = os.open(brain_pty, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        self.master, self._slave = pty.openpty()
        tty.setraw(self._slave)
        self.path = os.ttyname(self._slave)
        self.flipped = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _damage(self, data: bytes) -> bytes:
        hits = np.nonzero(self.rng.random(len(data)) < self.p)[0]
        out = bytearray(data)
        for i in hits:
            out[i] ^= 1 << int(self.rng.integers(8))
        self.flipped += len(hits)
        return bytes(out)

    def _run(self) -> None:
        pairs = {self.brain: self.master, self.master: self.brain}
        while not self._stop.is_set():
            ready, _, _ = select.select(list(pairs), [], [], 0.05)
            for src in ready:
                with contextlib.suppress(BlockingIOError, OSError):
                    data = os.read(src, 65536)
                    os.write(pairs[src], self._damage(data))

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        for fd in (self.brain, self.master, self._slave):
            os.close(fd)


def test_a_gps_dropout_is_driven_through_as_the_brains_trust_wears(rig: Lockstep) -> None:
    """The field strip hidden (issue 44): the real Brain core keeps its pose on the wheels and the
    IMU, the daemon keeps driving on it, and keeps driving (slower) when pose_std passes
    [decision] pose_max_std_m (0.15 m): here the wheels do not do what they are told, which the
    Brain sees as slip and trusts its pose less for."""
    rig.host.ok("phase autonomous")
    rig.host.ok(f"gps {X} {Y} {HEADING} 0.01")
    rig.host.ok("imu 0")
    rig.host.ok("measured 0 0")
    for _ in range(50):
        rig.step()
    assert rig.daemon.last_decision is not None and rig.daemon.last_decision.drove
    rig.host.ok("gps error")  # the strip is out of sight from here on

    def shuttle(steps: int) -> list[dict[str, str]]:
        """The wheels say 1.5 m/s forward for a second, then back for one, and so on (the
        Brain's odometry, whatever the probe policy asks): 1.5 m out along +x and back."""
        out = []
        for k in range(steps):
            if k % 100 == 0:
                rig.host.ok("measured 1.5 1.5" if (k // 100) % 2 == 0 else "measured -1.5 -1.5")
            out.append(rig.step())
        return out

    reports = shuttle(200)  # 2 s, 3 m driven
    assert all(r["source"] == "jetson" for r in reports), "driven through the dropout"
    assert reports[-1]["pose"] == "odometry" and reports[-1]["gps"] == "error"
    state = rig.daemon.last_state
    assert state is not None and state.pose_fix == PoseFix.ODOMETRY
    assert float(reports[-1]["pose_x"]) == pytest.approx(X, abs=0.05)  # out and back along +x
    # The wheels ran at 1.5 m/s whatever they were told: slip, so the pose is trusted less ...
    assert state.pose_std > 0.15
    # ... and the daemon drives on it all the same (slower: jetson.decide.pose_speed_scale).
    decision = rig.daemon.last_decision
    assert decision is not None and decision.drove, decision
    assert reports[-1]["stopped"] == "0"
    # The strip comes back where the odometry says the robot is: the pose rests on the GPS again
    # and the robot drives.
    report = rig.step()
    rig.host.ok("measured 0 0")
    rig.host.ok(f"gps {report['pose_x']} {report['pose_y']} {report['pose_heading']} 0.01")
    for _ in range(30):
        report = rig.step()
    assert report["pose"] == "gps" and report["source"] == "jetson"
    assert float(report["pose_std"]) < 0.05, "the returning GPS is believed at once"
    assert rig.daemon.last_decision is not None and rig.daemon.last_decision.drove


def test_one_percent_of_bytes_corrupted_both_ways_is_counted_and_never_applied(
    tmp_path: Path,
) -> None:
    policy = ProbePolicy()
    linear = expected_linear(policy)
    host = realtime_host("5EED0001")
    relay = CorruptingRelay(host.pty, 0.01)
    link = tmp_path / "pete-brain"
    point(link, relay.path)
    reports = []
    try:
        with threaded_daemon(link, policy) as (daemon, _):
            # Watch the Brain for 1.5 s of driving.
            give_up = time.monotonic() + TIMEOUT_S
            until = None
            while until is None or time.monotonic() < until:
                reports.append(host.ok("get"))
                if until is None and reports[-1]["source"] == "jetson":
                    until = time.monotonic() + 1.5
                assert time.monotonic() < give_up, "the daemon never drove through the noise"
                time.sleep(0.01)
            uplink_errors = daemon.link_errors()
    finally:
        relay.close()
        host.close()
    assert relay.flipped > 20
    assert sum(uplink_errors.values()) > 0, "damaged uplink frames are counted by kind"
    assert any("link_errors" in r["faults"] for r in reports), "the Brain counted damage too"
    driven = [r for r in reports if r["source"] == "jetson"]
    assert len(driven) >= 50
    # The Brain only ever applied the probe policy's Command, ramping up to it: a damaged
    # Command (another speed, a turn) was never executed.
    for r in reports:
        assert -1e-6 <= float(r["linear"]) <= linear + 1e-4, r
        assert abs(float(r["angular"])) <= 1e-6, r


def test_sigterm_makes_the_daemon_process_send_a_stop(tmp_path: Path) -> None:
    policy = write_mlp_policy(tmp_path / "policy", seed=5)
    host = Host()
    link = tmp_path / "pete-brain"
    point(link, host.pty)
    log = tmp_path / "daemon.jsonl"
    proc = subprocess.Popen(
        [
            sys.executable, "-m", "jetson.cli", "run", "--port", str(link), "--policy",
            str(policy), "--no-camera", "--no-record", "--quiet", "--log", str(log),
            "--valid-ms", "1000",
        ],
        cwd=ROOT, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        host.ok("phase autonomous")
        host.ok(f"gps {X} {Y} {HEADING} 0.01")
        deadline = time.monotonic() + 30.0
        report = host.ok("advance 10")
        # Simulated time waits for the daemon to start and answer.
        while not (report["source"] == "jetson" and abs(float(report["linear"])) > 0.02):
            assert time.monotonic() < deadline, f"the daemon never drove: {report}"
            time.sleep(0.003)
            report = host.ok("advance 10")
        for _ in range(30):
            time.sleep(0.003)
            moving = host.ok("advance 10")
        proc.send_signal(signal.SIGTERM)
        assert proc.wait(timeout=TIMEOUT_S) == 0, proc.stderr.read()  # type: ignore[union-attr]
        after = [host.ok("advance 10") for _ in range(40)]  # 0.4 s, inside the 1 s validity
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        host.close()
    assert moving["source"] == "jetson" and abs(float(moving["linear"])) > 0.02
    # The stop Command (not a timeout: its validity is 1 s) brought the wheels to rest.
    assert float(after[-1]["linear"]) == 0.0 and float(after[-1]["angular"]) == 0.0
    assert after[-1]["source"] == "jetson" and after[-1]["timeouts"] == "0"
    assert int(after[-1]["last_command_seq"]) > int(moving["last_command_seq"])
    events = [json.loads(x)["event"] for x in log.read_text().splitlines()]
    assert "signal" in events and "stop_sent" in events and events[-1] == "exit"
