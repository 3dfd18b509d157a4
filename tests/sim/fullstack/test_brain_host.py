"""sim.fullstack.brain_host: the Python driver of brain_host, against the real binary."""

from __future__ import annotations

import os
import signal
from collections.abc import Iterator

import pytest

from protocol.messages import (
    FINGERPRINT,
    PROTOCOL_VERSION,
    Command,
    GpsStatus,
    Hello,
    MatchPhase,
    PoseFix,
    Role,
)
from sim.errors import BrainHostError
from sim.fullstack.brain_host import DEFAULT_BINARY, BrainHost, BrainReport, find_binary
from tests.sim.fullstack.pty_port import Port

pytestmark = pytest.mark.skipif(
    not DEFAULT_BINARY.exists(), reason="brain_host is not built: run `make build` first"
)


@pytest.fixture
def brain() -> Iterator[BrainHost]:
    host = BrainHost.start(boot_id=0x5EED0001)
    try:
        yield host
    finally:
        assert host.close() == 0


@pytest.fixture
def port(brain: BrainHost) -> Iterator[Port]:
    p = Port(brain.pty_path)
    yield p
    p.close()


def hello(fingerprint: int = FINGERPRINT) -> Hello:
    return Hello(fingerprint, PROTOCOL_VERSION, Role.JETSON, 0xA11CE, "test")


def test_ready_line_names_the_pty_and_the_schema(brain: BrainHost) -> None:
    assert os.path.exists(brain.pty_path)
    assert brain.ready.mode == "lockstep"
    assert brain.period_ms == 10
    assert brain.ready.boot_id == 0x5EED0001
    assert brain.ready.fingerprint == FINGERPRINT


def test_handshake_and_a_command_drive_the_wheels(brain: BrainHost, port: Port) -> None:
    brain.set_phase("driver")
    brain.set_gps(0.5, -1.25, 90.0, 0.02)
    port.send(hello())
    report = brain.until(10, rx=port.written)
    assert isinstance(report, BrainReport)
    assert report.link == "connected" and report.phase == "driver"
    assert report.stopped and not report.moving, "connected, but no Command yet"
    assert "command_timeout" in report.faults
    port.send(Command(seq=1, linear=0.4, angular=0.0, intake=True, valid_ms=250))
    report = brain.until(100, rx=port.written)
    assert report.source == "jetson" and report.moving and report.intake
    assert report.last_command_seq == 1
    assert report.left_mps == pytest.approx(report.right_mps)
    assert 0.0 < report.left_mps <= 0.4 + 1e-6
    assert report.steps == 10 and report.t_ms == 100 and report.last_step_ms == 90
    port.collect(report.tx)
    states = port.states()
    assert states, "States follow the handshake"
    last = states[-1]
    assert last.phase == MatchPhase.DRIVER and last.gps_status == GpsStatus.OK
    # The pose is the Brain's filter's: here the GPS says the robot stands still while its
    # (ideal) wheels drive at up to 0.4 m/s, so the pose sits between them, within 2 cm.
    assert last.pose_fix == PoseFix.GPS
    assert (last.x, last.y, last.heading) == pytest.approx((0.5, -1.25, 90.0), abs=0.02)
    assert 0.0 < last.pose_std < 0.02


def test_the_command_expires_after_its_validity_window(brain: BrainHost, port: Port) -> None:
    brain.set_phase("autonomous")
    port.send(hello())
    port.send(Command(seq=1, linear=0.3, angular=0.0, intake=False, valid_ms=100))
    assert brain.until(50, rx=port.written).moving
    report = brain.until(200)
    assert report.stopped and report.timeouts == 1 and "command_timeout" in report.faults


def test_measured_speeds_reach_the_state(brain: BrainHost, port: Port) -> None:
    brain.set_phase("disabled")
    port.send(hello())
    brain.set_measured(0.25, -0.125)
    report = brain.until(60, rx=port.written)
    port.collect(report.tx)
    state = port.states()[-1]
    assert (state.left_speed, state.right_speed) == pytest.approx((0.25, -0.125), abs=1e-3)
    brain.measured_auto()


def test_the_ring_counter_reaches_the_state(brain: BrainHost, port: Port) -> None:
    port.send(hello())
    report = brain.until(40, rx=port.written)
    assert report.rings == 255, "no counter fitted by default"
    brain.set_rings(3)
    report = brain.until(80)
    assert report.rings == 3
    port.collect(report.tx)
    assert port.states()[-1].rings_held == 3
    brain.set_rings(None)
    assert brain.until(100).rings == 255
    with pytest.raises(ValueError, match=r"0\.\.254"):
        brain.set_rings(300)


def test_the_clamp_sensor_reaches_the_state(brain: BrainHost, port: Port) -> None:
    port.send(hello())
    report = brain.until(40, rx=port.written)
    assert report.clamp == 255 and not report.clamp_closed, "no sensor fitted by default"
    brain.set_clamp(False)
    brain.set_phase("autonomous")
    assert brain.until(60).clamp == 0
    brain.set_clamp(True)  # a goal at the back: the Brain closes the clamp
    report = brain.until(100)
    assert report.clamp == 1 and report.clamp_closed
    port.collect(report.tx)
    assert port.states()[-1].goal_clamped == 1
    brain.set_clamp(None)
    report = brain.until(120)
    assert report.clamp == 255 and report.clamp_closed
    assert BrainHost.clamp_line(True) == "clamp 1"
    assert BrainHost.sticks_line(0.0, 0.0, clamp=True) == "sticks 0.0 0.0 clamp"
    assert BrainHost.sticks_line(0.0, 0.0, lift=True) == "sticks 0.0 0.0 lift"


def test_the_imu_and_a_gps_dropout_reach_the_pose(brain: BrainHost, port: Port) -> None:
    port.send(hello())
    brain.set_gps(-1.2, 0.5, 90.0, 0.013)  # in red's half
    brain.set_imu(0.0)
    brain.set_measured(0.0, 0.0)
    report = brain.until(100, rx=port.written)
    assert report.pose == "gps" and report.pose_x == pytest.approx(-1.2, abs=1e-3)
    assert report.period == "before" and report.alliance == "red"  # brain_host's screen pick
    brain.set_gps_failure("error")
    brain.set_measured(0.5, 0.5)  # facing +x at 0.5 m/s
    report = brain.until(1100)
    assert report.pose == "odometry" and report.gps == "error"
    assert report.pose_x == pytest.approx(-0.7, abs=0.02) and report.pose_std > 0.02
    port.collect(report.tx)
    last = port.states()[-1]
    assert last.pose_fix == PoseFix.ODOMETRY and last.x == pytest.approx(-0.7, abs=0.02)
    assert BrainHost.imu_line(12.5) == "imu 12.5" and BrainHost.imu_line(None) == "imu off"
    with pytest.raises(ValueError, match="imu rotation"):
        BrainHost.imu_line(float("nan"))


def test_without_a_screen_pick_the_alliance_comes_from_the_gps_start_pose() -> None:
    with BrainHost.start(alliance="unknown") as host:
        host.set_gps(1.3, -1.2, 270.0, 0.013)  # blue's half
        assert host.until(50).alliance == "blue"
        host.command("screen red")
        assert host.until(100).alliance == "red"


def test_a_batch_is_one_round_trip(brain: BrainHost) -> None:
    before = brain.round_trips
    replies = brain.run_batch(
        [brain.phase_line("driver"), brain.gps_line(0, 0, 0), brain.step_line("until", 30, None)]
    )
    assert brain.round_trips == before + 1
    assert replies[0] == {} and replies[1] == {}
    assert BrainReport.parse(replies[2]).steps == 3


def test_sticks_drive_in_driver_control(brain: BrainHost) -> None:
    brain.set_phase("driver")
    brain.set_sticks(0.8, 0.0)
    report = brain.until(100)
    assert report.source == "driver" and report.moving
    brain.sticks_off()


def test_refusals_carry_brain_hosts_reason(brain: BrainHost) -> None:
    brain.until(50)
    with pytest.raises(BrainHostError, match="before now"):
        brain.until(20)
    with pytest.raises(BrainHostError, match="unknown command"):
        brain.command("jump 3")
    # The driver refuses bad values itself, before anything is sent.
    with pytest.raises(ValueError, match="phase"):
        brain.set_phase("overtime")  # type: ignore[arg-type]
    with pytest.raises(ValueError, match="finite"):
        brain.set_gps(float("nan"), 0.0, 0.0)
    with pytest.raises(ValueError, match=r"\[-1, 1\]"):
        brain.set_sticks(2.0, 0.0)
    assert brain.get().t_ms == 50, "nothing changed on an error"


def test_gps_failures_are_reported(brain: BrainHost, port: Port) -> None:
    port.send(hello())
    brain.set_gps_failure("calibrating")
    report = brain.until(40, rx=port.written)
    assert report.gps == "calibrating" and "gps_fault" in report.faults
    with pytest.raises(ValueError, match="GPS failure"):
        brain.set_gps_failure("lost")


def test_a_dead_brain_host_is_named() -> None:
    host = BrainHost.start()
    os.kill(host.proc.pid, signal.SIGKILL)
    host.proc.wait()
    with pytest.raises(BrainHostError, match=r"exited|gone"):
        host.until(10)
    assert host.close() == -signal.SIGKILL


def test_missing_binary_says_how_to_build(tmp_path) -> None:
    with pytest.raises(BrainHostError, match="make build"):
        find_binary(tmp_path / "nope")
    with pytest.raises(BrainHostError, match="make build"):
        BrainHost.start(binary=tmp_path / "nope")


def test_stderr_goes_to_a_file(tmp_path) -> None:
    log = tmp_path / "brain_host.stderr"
    host = BrainHost.start(stderr_path=log, extra_args=["--alliance", "blue"])
    try:
        assert host.get().t_ms == 0
    finally:
        assert host.close() == 0
    assert log.exists()


def _turning_wheels(track_width_m: float | None) -> tuple[float, float]:
    """The wheel speeds of a brain_host told to turn in place at 1 rad/s."""
    with BrainHost.start(boot_id=0x5EED0002, track_width_m=track_width_m) as host:
        port = Port(host.pty_path)
        try:
            host.set_phase("driver")
            host.set_gps(0.0, 0.0, 0.0, 0.02)
            port.send(hello())
            host.until(10, rx=port.written)
            port.send(Command(seq=1, linear=0.0, angular=1.0, intake=False, valid_ms=250))
            report = host.until(200, rx=port.written)  # past the turn's slew limit
            return report.left_mps, report.right_mps
        finally:
            port.close()


def test_the_track_width_given_sets_the_turns_wheel_speeds() -> None:
    """A robot of another size (the 24" robot's 0.52 m track): the Brain turns it at the rate
    asked only when it knows where its wheels are."""
    left, right = _turning_wheels(None)
    wide_left, wide_right = _turning_wheels(0.52)
    assert left == pytest.approx(-right) and wide_left == pytest.approx(-wide_right)
    assert abs(left - right) == pytest.approx(1.0 * 0.30, rel=0.02)  # kRobotConfig's track
    assert abs(wide_left - wide_right) == pytest.approx(1.0 * 0.52, rel=0.02)


def test_a_track_width_out_of_range_is_refused_with_its_reason(tmp_path) -> None:
    with pytest.raises(BrainHostError, match=r"exited \(status 2\)"):
        BrainHost.start(track_width_m=2.0, stderr_path=tmp_path / "stderr")
    assert "--track-width-m 2: track_width_m out of range" in (tmp_path / "stderr").read_text()
