"""The daemon against a fake Brain written in Python (jetson.testing.FakeBrain) over a pty pair:
handshake, mismatch, Commands answering States, the Brain vanishing and coming back, corrupted
bytes, a failing camera, a failing policy, recording and replay.

The daemon runs in a thread of the test process; the fake Brain in another. Waits poll a
condition with deadlines of seconds (the machine may be busy), so a passing test takes only as
long as the behaviour needs.
"""

from __future__ import annotations

import contextlib
import io
import itertools
import json
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from jetson import cli
from jetson.autonomy.policy import OnnxPolicy
from jetson.camera_feed import CameraWorker, SyncPerception
from jetson.clock import MonotonicClock
from jetson.decide import Decider
from jetson.log import EventLog
from jetson.loop import Daemon
from jetson.recorder import RecordingDir
from jetson.replay import replay
from jetson.settings import DecisionConfig, LinkConfig
from jetson.testing import FakeBrain, ProbePolicy, write_mlp_policy
from protocol.messages import (
    FINGERPRINT,
    LogLevel,
    Partner,
    PartnerFlags,
    PartnerLink,
    PartnerStatus,
    Role,
    TargetKind,
)

# A daemon or camera thread that dies of an exception fails the test, not just warns.
pytestmark = pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning")
WAIT_S = 5.0


def wait_for(cond: Callable[[], bool], timeout_s: float = WAIT_S) -> bool:
    deadline = time.monotonic() + timeout_s
    while not cond():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True


@dataclass
class Running:
    daemon: Daemon
    out: io.StringIO

    def records(self, event: str | None = None) -> list[dict[str, Any]]:
        lines = [json.loads(x) for x in self.out.getvalue().splitlines() if x]
        return [r for r in lines if event is None or r["event"] == event]


@contextlib.contextmanager
def daemon_on(
    port: str,
    policy: Any = None,
    perception: Any = None,
    decision: DecisionConfig | None = None,
    recordings: RecordingDir | None = None,
    fingerprint: int = FINGERPRINT,
    header: dict[str, Any] | None = None,
) -> Iterator[Running]:
    clock = MonotonicClock()
    out = io.StringIO()
    log = EventLog(out, None, clock, "debug")
    daemon = Daemon(
        Decider(policy or ProbePolicy(), decision or DecisionConfig()),
        clock,
        log,
        perception=perception,
        link=LinkConfig(port=port),
        recordings=recordings,
        header=header,
        fingerprint=fingerprint,
        summary_period_s=0.25,
    )
    stop = threading.Event()
    thread = threading.Thread(target=daemon.run, args=(stop,), daemon=True)
    thread.start()
    try:
        yield Running(daemon, out)
    finally:
        stop.set()
        thread.join(5.0)
        assert not thread.is_alive(), "the daemon did not stop"


@pytest.fixture
def brain(tmp_path: Path) -> Iterator[FakeBrain]:
    b = FakeBrain(link_path=tmp_path / "pete-brain")
    yield b
    b.close()


def driving(b: FakeBrain) -> list:
    return [c.command for c in b.commands if c.command.linear != 0.0]


def test_handshake_then_each_state_is_answered_by_its_command(brain: FakeBrain) -> None:
    policy = ProbePolicy()
    brain.start()
    with daemon_on(brain.path, policy) as run:
        assert wait_for(lambda: len(brain.commands) >= 40)
        brain.send_log("jetson connected", LogLevel.WARNING)
        brain.send_text("pete brain 0.1.0 boot 5EED0001")
        assert wait_for(lambda: run.records("brain_text") and run.records("brain_log"))
    # The daemon stopped: its last Command, a stop, reaches the Brain.
    assert wait_for(lambda: not brain.commands[-1].command.intake)
    hello = brain.jetson_hellos[0]
    assert hello.role is Role.JETSON and hello.fingerprint == FINGERPRINT
    # Each Command is the probe policy's answer to one State that was sent, in order.
    by_answer = {
        float(np.float32(policy.expected(s, 0)[0])): seq for seq, s in brain.states_sent.items()
    }
    answered = [by_answer[c.command.linear] for c in brain.commands[:-1]]
    assert answered == sorted(answered) and len(set(answered)) == len(answered)
    cmds = [c.command for c in brain.commands]
    assert [c.seq for c in cmds] == list(range(1, len(cmds) + 1))
    assert all(c.valid_ms == 250 and c.intake for c in cmds[:-1])
    # Almost every State was answered (a busy machine may batch a few: the newest wins).
    counters = run.daemon.counters
    assert counters.states + counters.states_skipped >= len(answered)
    assert counters.states_skipped <= counters.states // 5
    # The last Command, sent when the daemon stopped, is a stop.
    last = cmds[-1]
    assert (last.linear, last.angular, last.intake) == (0.0, 0.0, False)
    brain_log = run.records("brain_log")[0]
    assert brain_log["level"] == "warning" and "jetson connected" in brain_log["msg"]
    assert "pete brain 0.1.0" in run.records("brain_text")[0]["msg"]
    summary = run.records("summary")[-2]
    assert summary["latency"]["n"] > 0 and summary["link"] == "up"
    assert "latency p50" in summary["msg"] and "errors none" in summary["msg"]


def test_a_fingerprint_mismatch_is_a_loud_refusal_and_no_command_is_sent(tmp_path: Path) -> None:
    rogue = FakeBrain(link_path=tmp_path / "b", fingerprint=0x12345678, states_on_mismatch=True)
    rogue.start()
    try:
        with daemon_on(rogue.path) as run:
            assert wait_for(lambda: len(rogue.states_sent) >= 25)
            assert wait_for(lambda: run.records("fingerprint_mismatch"))
            state = run.daemon.state
    finally:
        rogue.close()
    assert state == "mismatch"
    assert rogue.commands == [] and run.daemon.counters.commands == 0
    assert run.daemon.counters.states_unverified >= 20  # its States were seen and ignored
    err = run.records("fingerprint_mismatch")[0]
    assert err["level"] == "error" and "REFUSING TO DRIVE" in err["msg"]
    assert "0x12345678" in err["msg"] and f"0x{FINGERPRINT:08X}" in err["msg"]
    assert any("SCHEMA MISMATCH" in s["msg"] for s in run.records("summary"))
    # We still said Hello, so that the Brain can log the mismatch too.
    assert rogue.jetson_hellos and all(h.fingerprint == FINGERPRINT for h in rogue.jetson_hellos)


def test_the_brain_vanishing_and_coming_back_reconnects_within_a_second(brain: FakeBrain) -> None:
    brain.start()
    with daemon_on(brain.path) as run:
        assert wait_for(lambda: len(brain.commands) >= 10)
        brain.vanish()
        assert wait_for(lambda: run.daemon.state == "waiting for port")
        time.sleep(0.3)
        n = len(brain.commands)
        brain.reappear(boot_id=0x5EED0002)  # a power cycle: a new boot id on a new pty
        assert wait_for(lambda: len(brain.commands) >= n + 10)
        assert brain.first_hello_after_appearing is not None and brain.appeared_at is not None
        reconnect_s = brain.first_hello_after_appearing - brain.appeared_at
        assert reconnect_s < 1.0, f"reconnected {reconnect_s:.3f} s after the port reappeared"
        # Unplugged again, and the same Brain back (same boot id): it works every time.
        brain.vanish()
        assert wait_for(lambda: run.daemon.state == "waiting for port")
        m = len(brain.commands)
        brain.reappear()
        assert wait_for(lambda: len(brain.commands) >= m + 10)
    assert run.daemon.counters.connects == 3 and run.daemon.counters.disconnects == 2
    down = run.records("link_down")
    assert len(down) == 2 and all(r["level"] == "warning" for r in down)
    ups = [r["brain_boot_id"] for r in run.records("link_up")]
    assert ups == ["5EED0001", "5EED0002", "5EED0002"]


def test_a_brain_restart_on_the_same_port_is_handshaken_again(brain: FakeBrain) -> None:
    brain.start()
    with daemon_on(brain.path) as run:
        assert wait_for(lambda: len(brain.commands) >= 10)
        brain.restart(0x0BADB007)
        n = len(brain.commands)
        assert wait_for(lambda: len(brain.commands) >= n + 10)
    restart = run.records("brain_restart")
    assert restart and restart[0]["brain_boot_id"] == "0BADB007"
    assert run.daemon.counters.connects == 1  # the port never closed


def test_one_percent_of_bytes_corrupted_never_makes_a_wrong_command(tmp_path: Path) -> None:
    policy = ProbePolicy()
    noisy = FakeBrain(
        link_path=tmp_path / "b", corrupt_uplink=0.01, corrupt_downlink=0.01,
        state_period_s=0.005, seed=7,
    )  # fmt: skip
    noisy.start()
    try:
        with daemon_on(noisy.path, policy) as run:
            assert wait_for(lambda: len(noisy.commands) >= 120, timeout_s=15.0)
            assert wait_for(lambda: sum(run.daemon.link_errors().values()) >= 5)
            errors = run.daemon.link_errors()
            summaries = run.records("summary")
    finally:
        noisy.close()
    # Every Command the Brain decoded is exactly the answer to a State the Brain really sent
    # (or the final stop): a damaged State or Command never turned into a command.
    valid = {float(np.float32(policy.expected(s, 0)[0])) for s in noisy.states_sent.values()}
    for got in noisy.commands:
        c = got.command
        assert c.linear in valid or (c.linear, c.intake) == (0.0, False), c
        assert c.angular == 0.0 and c.valid_ms == 250
    seqs = [c.command.seq for c in noisy.commands]
    assert seqs == sorted(set(seqs))
    # Damage was counted on both sides, by kind.
    assert sum(errors.values()) >= 5 and set(errors) <= {
        "bad_cobs", "truncated", "bad_crc", "bad_length", "unknown_id", "bad_value",
        "wrong_direction", "unknown_stream", "garbage", "oversize",
    }  # fmt: skip
    assert sum(noisy.decoder.stats.errors.values()) >= 1
    assert any("errors " in s["msg"] and "=" in s["msg"].split("errors ")[1] for s in summaries)
    assert any(s["link_errors"] for s in summaries)


class FlakyCamera:
    """A camera that delivers a frame every 10 ms until broken, then fails to read or open."""

    def __init__(self) -> None:
        self.broken = threading.Event()
        self.index = 0

    def open(self) -> FlakyCamera:
        if self.broken.is_set():
            raise OSError("no RealSense device connected")
        return self

    def read(self) -> SimpleNamespace:
        time.sleep(0.01)
        if self.broken.is_set():
            raise OSError("frame didn't arrive within 5000 ms")
        self.index += 1
        return SimpleNamespace(timestamp_s=0.0, index=self.index)

    def close(self) -> None:
        pass


def test_a_camera_failing_mid_run_means_no_rings_not_no_commands(brain: FakeBrain) -> None:
    camera = FlakyCamera()
    seen = SimpleNamespace(rings_robot_xy=np.array([[0.0, 0.6]]), detections=[1])
    clock = MonotonicClock()
    out = io.StringIO()
    worker = CameraWorker(camera.open, lambda frame: seen, clock, EventLog(out), retry_s=0.05)
    worker.start()
    brain.start()
    one_ring = 1 / 10 * 2.0  # the probe policy's angular for one ring in view
    try:
        with daemon_on(
            brain.path, perception=worker, decision=DecisionConfig(perception_max_age_s=0.15)
        ) as run:
            assert wait_for(
                lambda: driving(brain) and driving(brain)[-1].angular == pytest.approx(one_ring)
            )
            camera.broken.set()
            t_broken = time.monotonic()
            assert wait_for(lambda: driving(brain)[-1].angular == 0.0)
            n = len(brain.commands)
            time.sleep(0.3)
            assert len(brain.commands) >= n + 8  # still commanding while the camera is out
            assert (
                run.daemon.last_decision is not None
                and run.daemon.last_decision.perception == "stale"
            )
            camera.broken.clear()
            assert wait_for(lambda: driving(brain)[-1].angular == pytest.approx(one_ring))
            t_back = time.monotonic()
    finally:
        worker.stop()
    # Commands flowed all through the outage at the Brain's rate.
    gap = max(b.t - a.t for a, b in itertools.pairwise(brain.commands) if t_broken <= a.t <= t_back)
    assert gap < 0.25  # within the Command validity window
    assert worker.errors >= 1 and worker.opens >= 2
    cam_log = [json.loads(x) for x in out.getvalue().splitlines()]
    assert any(r["event"] == "camera_error" and "didn't arrive" in r["msg"] for r in cam_log)
    assert any(r["event"] == "camera_error" and "no RealSense" in r["msg"] for r in cam_log)
    stale = [r for r in run.records("perception") if r["status"] == "stale"]
    assert stale and stale[0]["level"] == "warning"
    assert any(r["status"] == "fresh" for r in run.records("perception"))


def test_an_exception_in_perception_sends_a_stop_and_serving_goes_on(brain: FakeBrain) -> None:
    camera = FlakyCamera()
    failing = threading.Event()

    def process(frame: SimpleNamespace) -> SimpleNamespace:
        if failing.is_set():
            raise ValueError("depth frame has the wrong size")
        return SimpleNamespace(rings_robot_xy=np.array([[0.0, 0.6]]), detections=[1])

    out = io.StringIO()
    worker = CameraWorker(camera.open, process, MonotonicClock(), EventLog(out), retry_s=0.05)
    worker.start()
    brain.start()
    try:
        with daemon_on(brain.path, perception=worker) as run:
            assert wait_for(lambda: len(driving(brain)) >= 5)
            failing.set()
            assert wait_for(lambda: run.daemon.last_decision.reason == "perception error")
            n = len(brain.commands)
            assert wait_for(lambda: len(brain.commands) >= n + 5)
            stops = brain.commands[n : n + 5]
            failing.clear()
            m = len(driving(brain))
            assert wait_for(lambda: len(driving(brain)) >= m + 5)
    finally:
        worker.stop()
    assert all(
        (c.command.linear, c.command.angular, c.command.intake) == (0, 0, False) for c in stops
    )
    assert "depth frame has the wrong size" in out.getvalue()  # the camera thread logged it
    decide = run.records("decide")
    assert decide and "depth frame has the wrong size" in decide[0]["msg"]
    reasons = [r["reason"] for r in run.records("decision")]
    assert reasons[:3] == ["policy", "perception error", "policy"]


def test_a_perception_feed_that_raises_is_a_stop_not_a_crash(brain: FakeBrain) -> None:
    class BrokenFeed:
        def latest(self):
            raise KeyError("shared memory gone")

    brain.start()
    with daemon_on(brain.path, perception=BrokenFeed()) as run:
        assert wait_for(lambda: len(brain.commands) >= 10)
    assert all(not c.command.intake and c.command.linear == 0.0 for c in brain.commands)
    assert run.daemon.counters.errors >= 10 and run.daemon.counters.stops >= 10
    [logged] = run.records("decide")
    assert "shared memory gone" in logged["msg"]


def test_an_exception_in_the_policy_sends_a_stop_and_serving_goes_on(brain: FakeBrain) -> None:
    policy = ProbePolicy()
    brain.start()
    with daemon_on(brain.path, policy) as run:
        assert wait_for(lambda: len(driving(brain)) >= 5)
        policy.fail = lambda obs: True
        assert wait_for(lambda: run.daemon.counters.errors >= 5)
        n = len(brain.commands)
        assert wait_for(lambda: len(brain.commands) >= n + 3)
        stops = brain.commands[n:]
        policy.fail = None
        m = len(driving(brain))
        assert wait_for(lambda: len(driving(brain)) >= m + 5)
    assert all(
        (c.command.linear, c.command.angular, c.command.intake) == (0, 0, False) for c in stops
    )
    errors = run.records("decide")
    assert errors and "probe policy told to fail" in errors[0]["msg"]
    assert len(errors) == 1  # the same error is logged once, not 50 times a second
    reasons = [r["reason"] for r in run.records("decision")]
    assert reasons[:3] == ["policy", "error", "policy"]


def test_a_recorded_session_replays_identically_and_changes_are_reported(
    brain: FakeBrain, tmp_path: Path
) -> None:
    path_a = write_mlp_policy(tmp_path / "a", seed=1)
    path_b = write_mlp_policy(tmp_path / "b", seed=2)
    policy = OnnxPolicy(path_a)
    clock = MonotonicClock()
    perception = SyncPerception(lambda f: f, clock)
    perception.set_rings([[0.2, 0.8], [-0.3, 1.2]])
    header = {"policy": {"path": str(path_a), "sha256": policy.sha256}}
    recordings = RecordingDir(tmp_path / "sessions")
    brain.start()
    with daemon_on(brain.path, policy, perception, recordings=recordings, header=header) as run:
        assert wait_for(lambda: len(brain.commands) >= 15)
        perception.set_rings([[0.5, 0.5]])
        assert wait_for(lambda: len(brain.commands) >= 30)
        brain.send_text("phase change")  # a session holds more than cycles
    answered = run.daemon.counters.states
    [session] = sorted((tmp_path / "sessions").glob("session-*.jsonl.gz"))
    report = replay(session)
    assert report.ok and report.cycles == answered and report.identical == answered
    assert report.latency["n"] == answered and report.reasons == {"policy": answered}
    changed = replay(session, OnnxPolicy(path_b))
    assert not changed.ok and changed.differing_cycles > answered // 2
    assert any("sha256" in w for w in changed.warnings)
    assert {d.what for d in changed.differences} <= {"linear", "angular"}
    # The command line says the same, with exit status 0 / 1.
    assert cli.main(["replay", str(session)]) == 0
    assert cli.main(["replay", str(session), "--policy", str(path_b)]) == 1


def test_the_partner_is_heard_and_losing_it_is_said(brain: FakeBrain) -> None:
    """The Brain hands over the partner's report and the VEXlink link's state; a lost link is a
    warning that the robot plays alone, and the partner's last report is forgotten."""
    brain.start()
    with daemon_on(brain.path) as run:
        assert wait_for(lambda: len(brain.commands) >= 5)
        report = Partner(
            x_mm=-900, y_mm=350, heading_cdeg=27000, flags=PartnerFlags.POSE_OK, goal=255,
            rings=4, target=TargetKind.RING, target_id=255, target_x_mm=600, target_y_mm=-1200,
            match_ms=4000,
        )  # fmt: skip
        brain.send_message(PartnerStatus(PartnerLink.UP, 20, 1, 1, 0, 0, 0))
        brain.send_message(report)
        assert wait_for(lambda: run.daemon.partner == report)
        assert run.records("partner_link")[0]["msg"].endswith("playing as an alliance")
        brain.send_message(PartnerStatus(PartnerLink.LOST, 65535, 9, 9, 0, 0, 0))
        assert wait_for(lambda: len(run.records("partner_link")) == 2)
        lost = run.records("partner_link")[1]
        assert lost["level"] == "warning" and "playing alone" in lost["msg"]
        assert run.daemon.partner is None
        assert len(brain.commands) >= 5  # and it drives on


def test_the_daemon_reports_to_its_partner_ten_times_a_second(brain: FakeBrain) -> None:
    brain.start()
    with daemon_on(brain.path):
        assert wait_for(lambda: len(brain.commands) >= 50)  # a second of States at 50 Hz
        n_commands = len(brain.commands)
        reports = list(brain.partner_reports)
    # One report per 100 ms of answered States (five States), not one per State.
    assert n_commands / 5 - 2 <= len(reports) <= n_commands / 5 + 2
    last = reports[-1]
    assert PartnerFlags.ALONE in last.flags  # no PartnerStatus says the link is up
    assert last.target is TargetKind.NOTHING
