"""sim.world.sensors' GPS occlusion model and the full stack's IMU: the readings the Brain's pose
filter takes, as the twin gives them."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from sim.config import WorldConfig
from sim.fullstack.hardware import RobotHardware
from sim.world import sensors
from sim.world.physics import World
from sim.world.sensors import GpsOcclusion


@pytest.fixture()
def world() -> Iterator[World]:
    w = World(WorldConfig(control_hz=100.0, blue=()))
    w.reset(np.random.default_rng(0))
    yield w
    w.close()


def park(world: World, x: float, y: float, heading: float) -> None:
    """Put robot 0 at a pose (and its GPS history with it), goals out of the way."""
    r = world.robots[0]
    r.x, r.y, r.heading = x, y, heading
    r.history.clear()
    r.history.append((world.time_s, x, y, heading))
    for k, g in enumerate(world.goals):  # along the far wall, behind the robot's right side
        g.x, g.y = -1.5 + 0.3 * k, -1.6


def test_off_the_reading_is_exactly_the_old_one(world: World) -> None:
    for seed in range(3):
        old = sensors.gps(world, 0, np.random.default_rng(seed))
        new = sensors.gps_with_occlusion(world, 0, np.random.default_rng(seed), None)
        assert new == old


def test_an_open_view_reads_with_the_published_error(world: World) -> None:
    park(world, 0.0, 0.0, 0.0)  # facing +y: the sensor looks right, at the +x wall 1.8 m away
    model = GpsOcclusion()
    assert sensors.gps_strip_in_view(world, 0, model) == 1.0
    reading = sensors.gps_with_occlusion(world, 0, np.random.default_rng(1), model)
    assert reading is not None
    assert reading.error_m == pytest.approx(0.013)
    assert (reading.x, reading.y) == pytest.approx((0.0, 0.0), abs=0.06)
    xs = [
        sensors.gps_with_occlusion(world, 0, np.random.default_rng(s), model).x  # type: ignore[union-attr]
        for s in range(400)
    ]
    assert float(np.std(xs)) == pytest.approx(0.013, rel=0.15)


def test_goals_beside_the_sensor_hide_the_strip(world: World) -> None:
    park(world, 0.0, 0.0, 0.0)
    a, b = world.goals[0], world.goals[1]
    a.x, a.y = 0.3, -0.05  # two goals right beside the robot, on the side the sensor looks at
    b.x, b.y = 0.3, 0.2
    model = GpsOcclusion()
    assert sensors.gps_strip_in_view(world, 0, model) < model.min_visible
    assert sensors.gps_with_occlusion(world, 0, np.random.default_rng(0), model) is None
    # Looking the other way (a sensor mounted on the left) the strip is in view.
    left = GpsOcclusion(facing_deg=-90.0)
    assert sensors.gps_strip_in_view(world, 0, left) == 1.0


def test_a_partial_view_reads_noisier(world: World) -> None:
    park(world, 0.0, 0.0, 0.0)
    g = world.goals[0]
    g.x, g.y = 0.45, 0.0  # one goal hides part of the sensor's view of the +x wall
    model = GpsOcclusion()
    frac = sensors.gps_strip_in_view(world, 0, model)
    assert model.min_visible <= frac < 1.0
    reading = sensors.gps_with_occlusion(world, 0, np.random.default_rng(0), model)
    assert reading is not None
    assert reading.error_m == pytest.approx(0.013 / frac**0.5)


def test_a_raised_platform_hides_the_wall_behind_it(world: World) -> None:
    park(world, 0.9, 0.0, 0.0)  # the red/blue platform between the sensor and the +x wall
    assert sensors.gps_strip_in_view(world, 0, GpsOcclusion()) == 1.0, "flat: seen over"
    assert sensors.gps_strip_in_view(world, 0, GpsOcclusion(platform_height_m=0.2)) == 0.0


def test_too_close_to_the_wall_is_the_sensor_s_dead_zone(world: World) -> None:
    park(world, 1.55, 0.0, 0.0)  # the +x wall 0.25 m to the right
    model = GpsOcclusion()
    assert sensors.gps_strip_in_view(world, 0, model) < model.min_visible
    assert sensors.gps_with_occlusion(world, 0, None, model) is None


def test_another_robot_between_the_sensor_and_the_wall_hides_it() -> None:
    w = World(WorldConfig(control_hz=100.0))  # red and blue robots
    try:
        w.reset(np.random.default_rng(0))
        park(w, 0.0, 0.0, 0.0)
        other = w.robots[1]
        other.x, other.y, other.heading = 0.45, 0.0, 0.0
        assert sensors.gps_strip_in_view(w, 0, GpsOcclusion()) < GpsOcclusion().min_visible
    finally:
        w.close()


@pytest.mark.parametrize(
    "bad",
    [
        {"fov_deg": 0.0},
        {"rays": 0},
        {"strip_top_m": 0.0},
        {"min_visible": 0.0},
        {"noise_xy_m": float("nan")},
        {"max_range_m": 0.1},
    ],
)
def test_a_bad_model_is_refused(bad: dict[str, float]) -> None:
    with pytest.raises(ValueError, match="GpsOcclusion"):
        GpsOcclusion(**bad)  # type: ignore[arg-type]


def test_the_full_stack_hardware_gives_dropouts_and_the_imu(world: World) -> None:
    park(world, 0.0, 0.0, 350.0)
    hw = RobotHardware(world, 0, rng=None, gps_occlusion=GpsOcclusion())
    other = world.goals[1]
    first = hw.read("driver")
    assert first.gps is not None and first.imu_deg == 0.0
    r = world.robots[0]
    r.heading = 10.0  # 20 degrees clockwise, across north
    assert hw.read("driver").imu_deg == pytest.approx(20.0)
    r.heading = 300.0  # 70 degrees anticlockwise
    assert hw.read("driver").imu_deg == pytest.approx(-50.0)
    r.heading = 0.0  # the sensor looks at the +x wall, past two goals right beside it
    world.goals[0].x, world.goals[0].y = 0.3, -0.05
    other.x, other.y = 0.3, 0.2
    hidden = hw.read("driver")
    assert hidden.gps is None and hidden.gps_failure == "error"
    assert hw.gps_hidden_steps == 1
    lines = hw.sensor_lines(hidden)
    assert "gps error" in lines and any(line.startswith("imu ") for line in lines)
    no_imu = RobotHardware(world, 0, rng=None, imu=False)
    assert no_imu.read("driver").imu_deg is None
    assert "imu off" in no_imu.sensor_lines(no_imu.read("driver"))
