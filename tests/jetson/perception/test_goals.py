"""The classical goal detector (jetson/perception/goals.py) on synthetic images: a goal base of
each colour drawn where the camera model projects a floor point, with a depth image, is found at
that point in the robot frame with its colour; blobs too small or of other colours are not goals.
Not real photos: the HSV windows are unmeasured (the module's doc says so)."""

from __future__ import annotations

import cv2
import numpy as np
import pytest

from jetson.autonomy.camera import project_points
from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES
from jetson.perception.camera import CameraConfig
from jetson.perception.goals import GoalDetector, GoalDetectorConfig, goals_robot

CAMERA = CameraConfig()
BASE_RADIUS_M = 0.1651
BGR = {"yellow": (20, 210, 235), "red": (40, 30, 200), "blue": (190, 80, 30)}


def scene(
    goals: list[tuple[str, float, float]], radius_m: float = BASE_RADIUS_M
) -> tuple[np.ndarray, np.ndarray]:
    """A grey floor at 3 m depth with a disc per goal (colour, x, y robot frame) drawn at the
    pixel of its base's middle, the disc's depth that point's."""
    intr, mount = CAMERA.intrinsics, CAMERA.mount
    bgr = np.full((intr.height, intr.width, 3), 110, np.uint8)
    depth = np.full((intr.height, intr.width), 3.0, np.float32)
    for colour, x, y in goals:
        pc = mount.robot_to_camera_points(np.array([[x, y, 0.05]]))
        uv, z = project_points(pc, intr.fx, intr.fy, intr.cx, intr.cy)
        centre = (round(float(uv[0, 0])), round(float(uv[0, 1])))
        r = max(1, round(intr.fx * radius_m / float(z[0])))
        cv2.circle(bgr, centre, r, BGR[colour], -1)
        disc = np.zeros(depth.shape, np.uint8)
        cv2.circle(disc, centre, r, 255, -1)
        depth[disc > 0] = float(z[0])
    return bgr, depth


@pytest.mark.parametrize("colour", ["yellow", "red", "blue"])
def test_a_goal_base_is_found_where_it_stands_with_its_colour(colour: str) -> None:
    bgr, depth = scene([(colour, 0.25, 1.6)])
    found = GoalDetector(CAMERA).detect(bgr, depth)
    assert [s.colour for s in found] == [colour]
    assert (found[0].x, found[0].y) == pytest.approx((0.25, 1.6), abs=0.04)
    report = goals_robot(found)
    assert report.shape == (1, 3) and report[0, 2] == GOAL_COLOUR_CODES[colour]


def test_several_goals_and_nothing_else() -> None:
    bgr, depth = scene([("yellow", -0.5, 1.8), ("blue", 0.5, 1.4)])
    # A purple ring-sized blob and a small yellow speck are not goals.
    cv2.circle(bgr, (320, 430), 25, (160, 40, 150), -1)
    cv2.circle(bgr, (40, 40), 4, BGR["yellow"], -1)
    found = sorted(GoalDetector(CAMERA).detect(bgr, depth), key=lambda s: s.x)
    assert [s.colour for s in found] == ["yellow", "blue"]
    assert (found[0].x, found[0].y) == pytest.approx((-0.5, 1.8), abs=0.05)
    assert (found[1].x, found[1].y) == pytest.approx((0.5, 1.4), abs=0.05)


def test_a_blob_of_the_wrong_physical_size_is_no_goal() -> None:
    """A yellow blob far wider than a goal base at its depth (a wall, a banner) is left out,
    as is one with no depth."""
    bgr, depth = scene([("yellow", 0.0, 1.5)], radius_m=0.6)
    assert GoalDetector(CAMERA).detect(bgr, depth) == []
    bgr, depth = scene([("yellow", 0.0, 1.5)])
    assert GoalDetector(CAMERA).detect(bgr, np.zeros_like(depth)) == []


def test_bad_inputs_are_refused() -> None:
    with pytest.raises(ValueError, match="purple"):
        GoalDetectorConfig(windows={"purple": ()})
    bgr, depth = scene([])
    with pytest.raises(ValueError, match="depth image"):
        GoalDetector(CAMERA).detect(bgr, depth[:10])
