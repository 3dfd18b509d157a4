"""The robot detector in the perception pipeline (jetson/perception/pipeline.py, `[camera] robots`):
a licence plate in a synthetic frame (jetson.perception.synthetic: a thin box of a plate's size
and alliance colour standing up off the floor, facing the camera) comes out as
result.robots_robot, the robot behind its plate; without the detector there is none, the rings
are found exactly as without it, and a frame without depth has none. A goal and a plate in one
frame are each reported by their own detector only."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from jetson.autonomy.camera import CameraMount, Intrinsics
from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES
from jetson.perception.camera import CameraConfig
from jetson.perception.frame import Frame
from jetson.perception.goals import GoalDetector
from jetson.perception.pipeline import Pipeline, make_detector, make_pipeline
from jetson.perception.robots import ROBOT_ALLIANCE_CODES, RobotDetector, RobotDetectorConfig
from jetson.perception.synthetic import Obstacle, Ring, Scene, render
from jetson.settings import CameraSettings
from tests.jetson.perception.test_goal_pipeline import BASE_HEIGHT_M, BASE_RADIUS_M, GOAL_BGR

PLATE_M = 0.4  # the plate's length across the view
PLATE_Z = (0.10, 0.22)  # its bottom and top edge above the floor
PLATE_BGR = {"red": GOAL_BGR["red"], "blue": GOAL_BGR["blue"]}
PLACED_M = 0.05


def plate_frame(
    plates: list[tuple[str, float, float]],
    rings: list[tuple[float, float]] = (),  # type: ignore[assignment]
    goals: list[tuple[str, float, float]] = (),  # type: ignore[assignment]
    intr: Intrinsics | None = None,
) -> Frame:
    """A synthetic frame of licence plates (alliance, x, y robot frame: the middle of the
    plate's face towards the camera), rings and goal bases, on the default camera mount."""
    boxes = [
        Obstacle(
            (x - PLATE_M / 2, y, PLATE_Z[0]), (x + PLATE_M / 2, y + 0.02, PLATE_Z[1]), PLATE_BGR[a]
        )
        for a, x, y in plates
    ]
    r = BASE_RADIUS_M
    boxes += [
        Obstacle((x - r, y - r, 0.0), (x + r, y + r, BASE_HEIGHT_M), GOAL_BGR[c])
        for c, x, y in goals
    ]
    scene = Scene(rings=[Ring(x, y) for x, y in rings], obstacles=boxes)
    return render(scene, intr or Intrinsics(), CameraMount(), None).frame


def behind(x: float, y: float) -> tuple[float, float]:
    """Where the detector puts the robot whose plate's face is at (x, y): half the robot's depth
    (its plate's length over plate_share) beyond the plate."""
    return x, y + PLATE_M / RobotDetectorConfig().plate_share / 2


def assert_robot_at(report: np.ndarray, alliance: str, x: float, y: float) -> None:
    """One row of `report` is a robot of this alliance at (x, y)."""
    rows = report[report[:, 2] == ROBOT_ALLIANCE_CODES[alliance]]
    assert len(rows) == 1, report
    rx, ry = rows[0, :2]
    assert math.hypot(rx - x, ry - y) < PLACED_M, (rx, ry, x, y)


def pipelines(camera: CameraConfig) -> tuple[Pipeline, Pipeline]:
    detector = make_detector("classical", camera)
    return Pipeline(detector, camera), Pipeline(
        detector, camera, robot_detector=RobotDetector(camera)
    )


@pytest.mark.parametrize(("alliance", "x", "y"), [("red", 0.0, 1.0), ("blue", -0.3, 1.3)])
def test_the_pipeline_reports_a_robot_and_the_same_rings_as_without_robots(
    alliance: str, x: float, y: float
) -> None:
    frame = plate_frame([(alliance, x, y)], rings=[(0.25, 0.6), (-0.3, 0.75)])
    plain, with_robots = pipelines(CameraConfig())
    before, after = plain.process(frame), with_robots.process(frame)
    assert before.robots == [] and before.robots_robot.shape == (0, 3)
    assert "robots" not in before.timings_ms
    assert_robot_at(after.robots_robot, alliance, *behind(x, y))
    assert [s.alliance for s in after.robots] == [alliance]
    assert after.timings_ms["robots"] >= 0.0
    assert len(after.detections) == len(before.detections) == 2
    assert np.array_equal(after.rings_robot_xy, before.rings_robot_xy)


def test_a_frame_without_depth_has_no_robots_and_is_no_error() -> None:
    frame = plate_frame([("red", 0.0, 1.0)], rings=[(0.3, 0.8)])
    plain, with_robots = pipelines(CameraConfig())
    flat = replace(frame, depth_m=None)
    result = with_robots.process(flat)
    assert with_robots.process(frame).robots_robot.shape == (1, 3)  # with its depth, the robot
    assert result.robots_robot.shape == (0, 3) and "robots" not in result.timings_ms
    assert np.array_equal(result.rings_robot_xy, plain.process(flat).rings_robot_xy)


def test_a_goal_and_a_plate_are_each_reported_by_their_own_detector() -> None:
    camera = CameraConfig()
    frame = plate_frame([("blue", 0.3, 1.0)], goals=[("yellow", -0.4, 1.2)])
    both = Pipeline(
        make_detector("classical", camera),
        camera,
        goal_detector=GoalDetector(camera),
        robot_detector=RobotDetector(camera),
    )
    result = both.process(frame)
    assert_robot_at(result.robots_robot, "blue", *behind(0.3, 1.0))
    assert result.goals_robot[:, 2].tolist() == [GOAL_COLOUR_CODES["yellow"]]
    assert {"goals", "robots"} <= set(result.timings_ms)


def test_make_pipeline_builds_the_robot_detector_when_robots_is_on() -> None:
    assert make_pipeline(CameraSettings(detector="classical"))[1].robot_detector is None
    off = make_pipeline(CameraSettings(detector="classical", robots=False))[1]
    assert off.robot_detector is None
    camera, on = make_pipeline(CameraSettings(detector="classical", robots=True))
    assert isinstance(on.robot_detector, RobotDetector) and on.robot_detector.camera is camera
    assert on.goal_detector is None  # each detector has its own setting
    assert_robot_at(on.process(plate_frame([("red", 0.0, 1.0)])).robots_robot, "red", *behind(0, 1))
