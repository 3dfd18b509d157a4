"""The goal detector in the perception pipeline (jetson/perception/pipeline.py, `[camera] goals`):
a goal base in a synthetic frame (jetson.perception.synthetic: a box of the base's size and
colour standing on the floor) comes out as result.goals_robot, placed with the frame's own
intrinsics; the rings are found exactly as without it; a frame without depth has no goals."""

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
from jetson.perception.pipeline import Pipeline, make_detector
from jetson.perception.synthetic import Obstacle, Ring, Scene, render

BASE_RADIUS_M = 0.1651  # a 13 in goal base
BASE_HEIGHT_M = 0.0762
GOAL_BGR = {"yellow": (20, 210, 235), "red": (40, 30, 200), "blue": (190, 80, 30)}
# The detector places the base's middle (a base radius beyond its near face); the synthetic
# bases are boxes, whose corner nearest the camera is a little nearer than a round base's edge.
PLACED_M = 0.05


def goal_frame(
    goals: list[tuple[str, float, float]],
    rings: list[tuple[float, float]] = (),  # type: ignore[assignment]
    intr: Intrinsics | None = None,
) -> Frame:
    """A synthetic frame of goal bases (colour, x, y robot frame: the base's centre) and rings,
    on the default camera mount."""
    r = BASE_RADIUS_M
    boxes = [
        Obstacle((x - r, y - r, 0.0), (x + r, y + r, BASE_HEIGHT_M), GOAL_BGR[c])
        for c, x, y in goals
    ]
    scene = Scene(rings=[Ring(x, y) for x, y in rings], obstacles=boxes)
    return render(scene, intr or Intrinsics(), CameraMount(), None).frame


def assert_goal_at(report: np.ndarray, colour: str, x: float, y: float) -> None:
    """One row of `report` is a goal of this colour at (x, y), its base's middle."""
    rows = report[report[:, 2] == GOAL_COLOUR_CODES[colour]]
    assert len(rows) == 1, report
    gx, gy = rows[0, :2]
    assert math.hypot(gx - x, gy - y) < PLACED_M, (gx, gy)


def pipelines(camera: CameraConfig) -> tuple[Pipeline, Pipeline]:
    detector = make_detector("classical", camera)
    return Pipeline(detector, camera), Pipeline(
        detector, camera, goal_detector=GoalDetector(camera)
    )


@pytest.mark.parametrize("colour", ["yellow", "red", "blue"])
def test_the_pipeline_reports_a_goal_and_the_same_rings_as_without_goals(colour: str) -> None:
    camera = CameraConfig()
    frame = goal_frame([(colour, -0.35, 1.3)], rings=[(0.3, 0.8), (0.45, 1.4)])
    plain, with_goals = pipelines(camera)
    before, after = plain.process(frame), with_goals.process(frame)
    assert before.goals_robot.shape == (0, 3) and "goals" not in before.timings_ms
    assert_goal_at(after.goals_robot, colour, -0.35, 1.3)
    assert after.timings_ms["goals"] >= 0.0
    assert len(after.detections) == len(before.detections) == 2
    assert np.array_equal(after.rings_robot_xy, before.rings_robot_xy)


def test_goals_are_placed_with_the_frames_own_intrinsics() -> None:
    """A camera whose lens differs from the camera config's (a RealSense, the simulator's stream
    send their intrinsics with each frame): the goal is where it stands, not where the config's
    lens would put it."""
    lens = replace(Intrinsics(), fx=Intrinsics().fx * 1.25, fy=Intrinsics().fy * 1.25, cx=360.0)
    frame = goal_frame([("yellow", 0.0, 1.2)], intr=lens)
    _, with_goals = pipelines(CameraConfig())
    assert_goal_at(with_goals.process(frame).goals_robot, "yellow", 0.0, 1.2)
    # The camera config's lens alone puts it elsewhere, or takes it for no base: the test above
    # tells the two apart.
    wrong = GoalDetector(CameraConfig()).detect(frame.color, frame.depth_m)  # type: ignore[arg-type]
    assert not wrong or math.hypot(wrong[0].x, wrong[0].y - 1.2) > PLACED_M


def test_a_frame_without_depth_has_no_goals_and_is_no_error() -> None:
    frame = goal_frame([("yellow", 0.0, 1.2)], rings=[(0.3, 0.8)])
    plain, with_goals = pipelines(CameraConfig())
    flat = replace(frame, depth_m=None)
    result = with_goals.process(flat)
    assert with_goals.process(frame).goals_robot.shape == (1, 3)  # with its depth, the goal
    assert result.goals_robot.shape == (0, 3) and "goals" not in result.timings_ms
    assert np.array_equal(result.rings_robot_xy, plain.process(flat).rings_robot_xy)
