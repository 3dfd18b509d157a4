"""The robot detector (jetson/perception/robots.py) on the twin's renders: a robot's licence plate
within 2 m places the robot behind it; a robot side on or turned away shows none (the twin's
robots carry one plate, across the front); an alliance goal and a platform of the same colours
are not robots. The pipeline `[camera] robots` builds reports the same robot on the same render,
and none without it."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from jetson.autonomy.geometry import field_to_robot
from jetson.perception.camera import CameraConfig as JetsonCamera
from jetson.perception.frame import Frame
from jetson.perception.pipeline import make_pipeline
from jetson.perception.robots import ROBOT_ALLIANCE_CODES, RobotDetector
from jetson.settings import Settings
from sim.camera import render_camera
from sim.config import world_preset
from sim.world.physics import World

# The goals along the walls, out of the camera's way unless a test brings one in.
SPOTS = [(0.0, 1.6), (0.5, 1.6), (-0.5, 1.6), (1.0, 1.6), (0.5, -1.6), (-0.5, -1.6), (1.0, -1.6)]


@pytest.fixture(scope="module")
def world() -> Iterator[World]:
    w = World(replace(world_preset("tipping_point_1v1", preloads=False), fidelity="training"))
    w.reset(np.random.default_rng(0))
    w.set_floor_rings(np.zeros((0, 2)))
    yield w
    w.close()


def look(w: World, d: float, rel: float, lat: float) -> tuple[list, np.ndarray]:
    """Red's robot at (-1, 0) facing +x; blue's d ahead, lat to the side, turned rel degrees
    from facing the same way. Returns the sightings and blue's middle in red's frame."""
    for g, (x, y) in zip(w.goals, SPOTS, strict=True):
        w.place_goal(g.index, x, y)
    w.place_robot(0, -1.0, 0.0, 90.0)
    w.place_robot(1, -1.0 + d, lat, 90.0 + rel)
    cam = w.robots[0].config.camera.scaled(240, 180)
    f = render_camera(w, 0, cam)
    detector = RobotDetector(JetsonCamera(cam.intrinsics, cam.mount))
    got = detector.detect(np.ascontiguousarray(f.rgb[:, :, ::-1]), f.depth, cam.intrinsics)
    r0, r1 = w.robots[0], w.robots[1]
    return got, field_to_robot(np.array([[r1.x, r1.y]]), r0.xy, r0.heading)[0]


@pytest.mark.parametrize("d", [1.4, 1.6, 2.0])
@pytest.mark.parametrize("rel", [180.0, 150.0, 210.0])  # facing us, aslant either way
def test_a_robot_facing_us_is_placed_behind_its_plate(world: World, d: float, rel: float) -> None:
    got, truth = look(world, d, rel, 0.0)
    assert len(got) == 1, got
    s = got[0]
    assert s.alliance == "blue"
    assert math.hypot(s.x - truth[0], s.y - truth[1]) < 0.06, (s, truth)


CUT = [(1.2, 180.0, 0.3), (1.0, 180.0, 0.0), (0.8, 210.0, 0.0)]


@pytest.mark.parametrize(("d", "rel", "lat"), CUT)
def test_a_plate_the_image_cuts_still_places_the_robot(
    world: World, d: float, rel: float, lat: float
) -> None:
    """Near, the narrow image cuts a 24" robot's plate: the end in view and a nominal length
    (between a 15" robot's plate and a 24"'s) place it, less closely."""
    got, truth = look(world, d, rel, lat)
    assert len(got) == 1
    assert got[0].plate_m == pytest.approx(0.45)
    assert math.hypot(got[0].x - truth[0], got[0].y - truth[1]) < 0.12


@pytest.mark.parametrize("rel", [90.0, 0.0])
def test_a_robot_side_on_or_turned_away_shows_no_plate(world: World, rel: float) -> None:
    got, _ = look(world, 1.2, rel, 0.0)
    assert got == []


def test_an_alliance_goal_and_the_platform_are_not_robots(world: World) -> None:
    # A red alliance goal 1 m ahead of red's robot (its post and base in red), blue's robot out
    # of view behind red's; then red's robot facing the blue platform across the field.
    red_goal = next(g.index for g in world.goals if g.spec.name.startswith("red"))
    from jetson.perception.goals import GoalDetector

    look(world, -0.6, 0.0, 1.4)  # blue's robot behind red's, out of view
    world.place_goal(red_goal, 0.0, 0.0)
    cam = world.robots[0].config.camera.scaled(240, 180)
    jc = JetsonCamera(cam.intrinsics, cam.mount)
    detector = RobotDetector(jc)
    for x, what in ((-1.0, "red"), (0.6, None)):  # the red goal ahead; the blue platform ahead
        world.place_robot(0, x, 0.0, 90.0)
        f = render_camera(world, 0, cam)
        bgr = np.ascontiguousarray(f.rgb[:, :, ::-1])
        assert detector.detect(bgr, f.depth) == []
        if what is not None:  # the goal is in view: the goal detector finds it
            assert [g.colour for g in GoalDetector(jc).detect(bgr, f.depth)] == [what]


def test_the_report_is_x_y_and_the_alliance_code(world: World) -> None:
    got, _ = look(world, 1.6, 180.0, 0.0)
    arr = RobotDetector.as_array(got)
    assert arr.shape == (1, 3) and arr[0, 2] == ROBOT_ALLIANCE_CODES["blue"]


@pytest.mark.parametrize("robots", [True, False])
def test_the_pipeline_finds_the_robot_when_robots_is_on(
    world: World, robots: bool, tmp_path: Path
) -> None:
    """The daemon's pipeline, as `[camera] robots` and the twin's camera config build it, on the
    twin's render of blue's robot facing red's 1.6 m ahead."""
    _, truth = look(world, 1.6, 180.0, 0.0)
    cam = world.robots[0].config.camera.scaled(240, 180)
    config = tmp_path / "camera.json"
    JetsonCamera(cam.intrinsics, cam.mount).save(config)
    settings = Settings().with_overrides(
        camera={"detector": "classical", "config": str(config), "robots": robots}
    )
    _, pipeline = make_pipeline(replace(settings.camera, robots=settings.detects_robots()))
    f = render_camera(world, 0, cam)
    frame = Frame(np.ascontiguousarray(f.rgb[:, :, ::-1]), f.depth, cam.intrinsics, 0.0, 1)
    result = pipeline.process(frame)
    if not robots:
        assert result.robots_robot.shape == (0, 3) and "robots" not in result.timings_ms
        return
    ((x, y, code),) = result.robots_robot
    assert code == ROBOT_ALLIANCE_CODES["blue"]
    assert math.hypot(x - truth[0], y - truth[1]) < 0.06, (x, y, truth)
