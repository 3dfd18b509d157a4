"""sim.fullstack.hardware: the bridge between the World and the Brain's side channel."""

from __future__ import annotations

import os
import select
import time
from collections.abc import Iterator
from dataclasses import replace

import numpy as np
import pytest

from protocol import framing
from protocol.framing import Received
from protocol.messages import (
    FINGERPRINT,
    PROTOCOL_VERSION,
    ClampAction,
    Command,
    Hello,
    Role,
    State,
)
from sim.config import WorldConfig
from sim.fullstack.brain_host import DEFAULT_BINARY, BrainHost, BrainReport
from sim.fullstack.hardware import RobotHardware, competition_phase
from sim.world.physics import World
from sim.world.state import DriveCommand


@pytest.fixture(scope="module")
def world() -> Iterator[World]:
    w = World(WorldConfig(control_hz=100.0, blue=()))
    w.reset(np.random.default_rng(0))
    yield w
    w.close()


def report(**overrides: object) -> BrainReport:
    base = BrainReport(
        t_ms=10, last_step_ms=0, phase="driver", phase_ms=0, link="connected", source="jetson",
        stopped=False, left_rpm=0.0, right_rpm=0.0, left_mps=0.0, right_mps=0.0, linear=0.0,
        angular=0.0, intake=True, gps="ok", faults=(), last_command_seq=1, steps=1, timeouts=0,
        rx=0, tx=0,
    )  # fmt: skip
    return replace(base, **overrides)


def test_competition_phase_follows_the_match() -> None:
    assert competition_phase(0.0, 15.0, started=False, over=False) == "disabled"
    assert competition_phase(3.0, 15.0, started=True, over=False) == "autonomous"
    assert competition_phase(15.0, 15.0, started=True, over=False) == "driver"
    assert competition_phase(0.0, 0.0, started=True, over=False) == "driver"
    assert competition_phase(105.0, 0.0, started=True, over=True) == "disabled"


def test_sensor_lines_carry_gps_encoders_and_phase_once(world: World) -> None:
    hw = RobotHardware(world, 0, rng=None)
    r = world.robots[0]
    first = hw.sensor_lines(hw.read("driver"))
    assert first[0] == "phase driver"
    assert "rings 0" in first, "the ring counter, once"
    gps = next(line for line in first if line.startswith("gps ")).split()
    x, y, heading, err = (float(v) for v in gps[1:])
    assert (x, y, heading) == pytest.approx((r.x, r.y, r.heading), abs=1e-9), "noiseless GPS"
    assert err == r.config.gps.noise_xy_m
    assert first[-1].startswith("measured ")
    again = hw.sensor_lines(hw.read("driver"))
    assert not any(line.startswith("phase") for line in again), "the phase only on a change"
    assert hw.sensor_lines(hw.read("disabled"))[0] == "phase disabled"
    hw.gps_failure = "calibrating"
    assert "gps calibrating" in hw.sensor_lines(hw.read("disabled"))


def test_the_ring_counter_reports_what_the_intake_holds(world: World) -> None:
    hw = RobotHardware(world, 0, rng=None)
    r = world.robots[0]
    r.held = 3
    assert "rings 3" in hw.sensor_lines(hw.read("driver"))
    assert not any(x.startswith("rings") for x in hw.sensor_lines(hw.read("driver")))
    r.held = 4
    assert "rings 4" in hw.sensor_lines(hw.read("driver"))
    r.held = 0
    bare = RobotHardware(world, 0, rng=None, ring_counter=False)
    assert bare.read("driver").rings is None
    assert not any(x.startswith("rings") for x in bare.sensor_lines(bare.read("driver")))


def test_the_clamp_sensor_reports_whether_the_robot_holds_a_goal(world: World) -> None:
    hw = RobotHardware(world, 0, rng=None)
    r = world.robots[0]
    assert r.carried_goal is None
    assert hw.read("driver").goal_at_back is False
    assert "clamp 0" in hw.sensor_lines(hw.read("driver")), "the sensor, once"
    assert not any(x.startswith("clamp") for x in hw.sensor_lines(hw.read("driver")))
    r.carried_goal = 1
    try:
        assert "clamp 1" in hw.sensor_lines(hw.read("driver")), "and again on a change"
        assert not any(x.startswith("clamp") for x in hw.sensor_lines(hw.read("driver")))
    finally:
        r.carried_goal = None
    assert "clamp 0" in hw.sensor_lines(hw.read("driver"))
    bare = RobotHardware(world, 0, rng=None, clamp_sensor=False)
    assert bare.read("driver").goal_at_back is None
    assert not any(x.startswith("clamp") for x in bare.sensor_lines(bare.read("driver")))


def _states(fd: int, decoder: framing.UplinkDecoder, have: int, total: int) -> tuple[list, int]:
    """Read brain_host's uplink until `total` bytes in all; the States decoded on the way."""
    out = []
    deadline = time.monotonic() + 5.0
    while have < total:
        assert time.monotonic() < deadline, f"uplink stalled at {have}/{total}"
        if select.select([fd], [], [], 0.5)[0]:
            chunk = os.read(fd, 65536)
            have += len(chunk)
            out += [e.message for e in decoder.feed(chunk) if isinstance(e, Received)]
    return [m for m in out if isinstance(m, State)], have


@pytest.mark.skipif(not DEFAULT_BINARY.exists(), reason="brain_host is not built: `make build`")
def test_the_states_goal_clamped_follows_the_simulated_clamp() -> None:
    """World (auto clamp) -> clamp sensor -> brain_host -> the State the Jetson reads."""
    with World(WorldConfig(blue=())) as w, BrainHost.start(boot_id=0xC1A3) as brain:
        w.reset(np.random.default_rng(0))
        r, g = w.robots[0], w.goals[0]
        w.place_goal(0, -1.0, 0.0)
        w.place_robot(0, -1.0 + g.spec.base_radius + r.config.length_m / 2 + 0.05, 0.0, 90.0)
        hw = RobotHardware(w, 0, rng=None)
        fd = os.open(brain.pty_path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        decoder, have, written = framing.UplinkDecoder(), 0, 0
        t_ms = 0

        def brain_step(cmd: DriveCommand) -> tuple[list[State], BrainReport]:
            nonlocal have, t_ms
            lines = hw.sensor_lines(hw.read("autonomous"))
            t_ms += 100
            replies = brain.run_batch([*lines, BrainHost.step_line("until", t_ms, written)])
            report = BrainReport.parse(replies[-1])
            states, have = _states(fd, decoder, have, report.tx)
            w.step([cmd])
            return states, report

        try:
            hello = Hello(FINGERPRINT, PROTOCOL_VERSION, Role.JETSON, 0xA11CE, "test")
            written += os.write(fd, framing.encode_downlink(hello, 0))
            states, report = brain_step(DriveCommand(0.0, 0.0))
            assert states and states[-1].goal_clamped == 0, "sensor fitted, no goal"
            assert not report.clamp_closed
            for _ in range(10):  # back onto the goal until the World clamps it
                if r.carried_goal is not None:
                    break
                brain_step(DriveCommand(-0.3, 0.0))
            assert r.carried_goal == 0
            states, report = brain_step(DriveCommand(0.0, 0.0))
            assert states[-1].goal_clamped == 1, "the Jetson hears that the robot holds a goal"
            assert report.clamp == 1 and report.clamp_closed
            w.step([DriveCommand(0.0, 0.0, clamp=False)])  # the World lets go
            assert r.carried_goal is None
            states, report = brain_step(DriveCommand(0.0, 0.0))
            assert states[-1].goal_clamped == 0
            assert report.clamp_closed, "the Brain never opens the clamp by itself"
        finally:
            os.close(fd)
        bare = RobotHardware(w, 0, rng=None, clamp_sensor=False)
        assert bare.read("autonomous").goal_at_back is None


def test_noisy_gps_differs_from_the_truth(world: World) -> None:
    hw = RobotHardware(world, 0, rng=np.random.default_rng(1))
    r = world.robots[0]
    reading = hw.read("driver")
    assert reading.gps is not None
    assert reading.gps[:2] != (r.x, r.y)
    assert abs(reading.gps[0] - r.x) < 0.1 and abs(reading.gps[1] - r.y) < 0.1


def test_motor_outputs_become_the_worlds_command(world: World) -> None:
    hw = RobotHardware(world, 0, rng=None)
    track = world.robots[0].config.track_m
    cmd = hw.command(report(left_mps=0.5, right_mps=0.3, intake=True))
    assert cmd.linear == pytest.approx(0.4)
    assert cmd.angular == pytest.approx(0.2 / track), "left faster than right turns clockwise"
    assert cmd.intake
    stopped = hw.command(report(stopped=True, left_mps=0.5, right_mps=0.5, intake=False))
    assert (stopped.linear, stopped.angular, stopped.intake) == (0.0, 0.0, False)


def test_encoders_read_what_the_robot_did(world: World) -> None:
    hw = RobotHardware(world, 0, rng=None)
    for _ in range(50):
        world.step([DriveCommand(0.4, 0.0)])
    reading = hw.read("driver")
    assert reading.left_mps == pytest.approx(0.4, abs=0.02)
    assert reading.right_mps == pytest.approx(0.4, abs=0.02)


def test_a_robot_that_is_not_there_is_refused(world: World) -> None:
    with pytest.raises(ValueError, match="not in this world"):
        RobotHardware(world, 3, rng=None)


def test_the_jetsons_release_makes_the_world_let_go(world: World) -> None:
    """Command.clamp release -> the Brain opens its clamp -> the World releases the goal and
    keeps its clamp open until the Brain closes it again (issue 44)."""
    hw = RobotHardware(world, 0, rng=None)
    held = hw.command(report(clamp_closed=True))
    assert held.clamp is None, "closed: the World's own clamp as before"
    released = hw.command(report(clamp_closed=False))
    assert released.clamp is False, "the Brain opened it: release"
    assert hw.command(report(clamp_closed=False, stopped=True)).clamp is False, "kept open"
    assert hw.command(report(clamp_closed=True)).clamp is None, "closed again: the World grabs"
    fresh = RobotHardware(world, 0, rng=None)
    assert fresh.command(report(clamp_closed=False)).clamp is None, "never closed: auto clamp"


def test_the_pose_track_compares_the_brains_pose_with_the_truth(world: World) -> None:
    hw = RobotHardware(world, 0, rng=None)
    r = world.robots[0]
    hw.command(report(pose="gps", pose_x=r.x + 0.03, pose_y=r.y + 0.04, pose_std=0.02))
    hw.command(report(pose="odometry", pose_x=r.x, pose_y=r.y, pose_std=0.05))
    hw.command(report(pose="lost"))
    hw.command(BrainReport.off(100))  # a rebooting Brain is not counted
    d = hw.pose_track.as_dict()
    assert d["steps"] == 3 and d["by_fix"] == {"gps": 1, "odometry": 1, "lost": 1}
    assert d["error_max_m"] == pytest.approx(0.05) and d["error_mean_m"] == pytest.approx(0.025)
    assert d["std_max_m"] == pytest.approx(0.05) and d["gps_hidden_steps"] == 0


def test_a_release_through_brain_host_opens_the_clamp_in_the_world() -> None:
    """The whole path: a Jetson's Command with clamp release, the real Brain core, the World."""
    with World(WorldConfig(blue=())) as w, BrainHost.start(boot_id=0xC1A4) as brain:
        w.reset(np.random.default_rng(0))
        r, g = w.robots[0], w.goals[0]
        w.place_goal(0, -1.0, 0.0)
        w.place_robot(0, -1.0 + g.spec.base_radius + r.config.length_m / 2 + 0.05, 0.0, 90.0)
        hw = RobotHardware(w, 0, rng=None)
        fd = os.open(brain.pty_path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        written, t_ms, seq = 0, 0, 0

        def brain_step(linear: float, clamp: ClampAction) -> BrainReport:
            nonlocal written, t_ms, seq
            seq += 1
            cmd = Command(seq, linear, 0.0, False, 250, clamp=clamp)
            written += os.write(fd, framing.encode_downlink(cmd, seq & 0xFF))
            lines = hw.sensor_lines(hw.read("autonomous"))
            t_ms += 20
            replies = brain.run_batch([*lines, BrainHost.step_line("until", t_ms, written)])
            report = BrainReport.parse(replies[-1])
            w.step([hw.command(report)])
            return report

        try:
            hello = Hello(FINGERPRINT, PROTOCOL_VERSION, Role.JETSON, 0xA11CE, "test")
            written += os.write(fd, framing.encode_downlink(hello, 0))
            for _ in range(30):  # back onto the goal: the World grabs it, the Brain closes
                report = brain_step(-0.3, ClampAction.LEAVE)
                if r.carried_goal is not None and report.clamp_closed:
                    break
            assert r.carried_goal == 0 and report.clamp_closed
            for _ in range(3):
                report = brain_step(0.0, ClampAction.RELEASE)
            assert not report.clamp_closed, "the Brain opened its clamp"
            assert r.carried_goal is None, "and the World let the goal go"
            for _ in range(10):  # the goal still touches the back: release keeps it let go
                brain_step(0.0, ClampAction.RELEASE)
            assert r.carried_goal is None
        finally:
            os.close(fd)
