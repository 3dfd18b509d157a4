"""sim.fullstack.hardware: the bridge between the World and the Brain's side channel."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace

import numpy as np
import pytest

from sim.config import WorldConfig
from sim.fullstack.brain_host import BrainReport
from sim.fullstack.hardware import RobotHardware, competition_phase
from sim.world import DriveCommand, World


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
