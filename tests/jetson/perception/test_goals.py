"""The classical goal detector (jetson/perception/goals.py) on synthetic frames with depth
(jetson/perception/synthetic.py: boxes on a floor, ray-traced): a goal base of each colour is
found at its middle with its colour; what is of a goal's colour but not shaped like a base
standing on the floor (a robot's bumper, a platform's board, a strip of tape, a far wider blob)
is not a goal, nor is a blob without depth. Not real photos: the HSV windows are unmeasured (the
module's doc says so); the twin's renders are sim/goal_survey.py's."""

from __future__ import annotations

import numpy as np
import pytest

from jetson.autonomy.camera import CameraMount, Intrinsics, project_points
from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES
from jetson.perception.camera import CameraConfig
from jetson.perception.goals import GoalDetector, GoalDetectorConfig, goals_robot
from jetson.perception.synthetic import Obstacle, Scene, render

CAMERA = CameraConfig()
BASE_RADIUS_M = 0.1651
BASE_HEIGHT_M = 0.0762
BGR = {"yellow": (20, 210, 235), "red": (40, 30, 200), "blue": (190, 80, 30)}


def base(colour: str, x: float, y: float, radius: float = BASE_RADIUS_M) -> Obstacle:
    """A goal's base as a box of its diameter and height, centred on (x, y), robot frame."""
    return Obstacle(
        (x - radius, y - radius, 0.0), (x + radius, y + radius, BASE_HEIGHT_M), BGR[colour]
    )


def frame(*things: Obstacle, size: tuple[int, int] = (640, 480)) -> tuple[np.ndarray, np.ndarray]:
    rendered = render(
        Scene(obstacles=list(things)), Intrinsics().scaled(*size), CameraMount(), None
    )
    assert rendered.frame.depth_m is not None
    return rendered.frame.color, rendered.frame.depth_m


def detect(bgr: np.ndarray, depth: np.ndarray) -> list[tuple[str, float, float]]:
    return sorted((s.colour, s.x, s.y) for s in GoalDetector(CAMERA).detect(bgr, depth))


@pytest.mark.parametrize("colour", ["yellow", "red", "blue"])
@pytest.mark.parametrize("where", [(0.25, 1.25), (-0.2, 1.2), (0.0, 1.4)])
def test_a_goal_base_is_found_at_its_middle_with_its_colour(
    colour: str, where: tuple[float, float]
) -> None:
    found = GoalDetector(CAMERA).detect(*frame(base(colour, *where)))
    assert [s.colour for s in found] == [colour]
    # The base's middle, not its near face (a base radius, 0.165 m, nearer); the box's corner
    # nearest the camera is a little nearer than a round base's edge would be.
    assert (found[0].x, found[0].y) == pytest.approx(where, abs=0.04)
    report = goals_robot(found)
    assert report.shape == (1, 3) and report[0, 2] == GOAL_COLOUR_CODES[colour]


def test_several_goals_at_the_full_stacks_size() -> None:
    bgr, depth = frame(base("yellow", -0.2, 1.35), base("blue", 0.25, 1.0), size=(240, 180))
    found = detect(bgr, depth)
    assert [c for c, _, _ in found] == ["blue", "yellow"]
    assert found[0][1:] == pytest.approx((0.25, 1.0), abs=0.04)
    assert found[1][1:] == pytest.approx((-0.2, 1.35), abs=0.04)


def test_a_bumper_of_a_goals_colour_is_no_goal() -> None:
    """A robot's alliance-coloured bumper (the twin's: a stripe 8 cm high across the robot's
    front, 11-19 cm up), of a 15 in robot and of a 24 in one, in front of a goal."""
    for width in (0.34, 0.55):
        bumper = Obstacle((-width / 2, 1.2, 0.11), (width / 2, 1.22, 0.19), BGR["red"])
        assert detect(*frame(bumper)) == []
    bumper = Obstacle((0.05, 0.9, 0.11), (0.6, 0.92, 0.19), BGR["blue"])
    assert [c for c, _, _ in detect(*frame(bumper, base("blue", -0.15, 1.3)))] == ["blue"]


@pytest.mark.parametrize("span", [(-0.6, 0.6), (0.15, 0.9), (-0.2, 0.25)])
def test_a_platform_board_of_a_goals_colour_is_no_goal(span: tuple[float, float]) -> None:
    """The twin's platforms are the alliance goals' red and blue: a board (2 ft deep, 3 in up)
    seen whole, its end, and a piece no wider than a base: all deeper than one base."""
    board = Obstacle((span[0], 0.8, 0.07), (span[1], 1.41, 0.08), BGR["blue"])
    assert detect(*frame(board)) == []


def test_tape_and_blobs_of_the_wrong_size_are_no_goals() -> None:
    tape = Obstacle((-0.8, 1.4, 0.0), (0.8, 1.45, 0.002), BGR["yellow"])  # a line on the floor
    assert detect(*frame(tape)) == []
    assert detect(*frame(base("yellow", 0.0, 1.3, radius=0.5))) == []
    bgr, depth = frame(base("yellow", 0.0, 1.25))
    assert detect(bgr, np.zeros_like(depth)) == []


def test_a_goal_cut_by_the_images_edge_is_placed_from_its_visible_side() -> None:
    """Its middle just inside the image's right edge, half the base beyond it."""
    intr, mount = CAMERA.intrinsics, CAMERA.mount
    y = 1.0
    xs = np.linspace(0.0, 2.0, 2001)
    pts = mount.robot_to_camera_points(np.column_stack([xs, np.full_like(xs, y), xs * 0 + 0.04]))
    uv, _ = project_points(pts, intr.fx, intr.fy, intr.cx, intr.cy)
    x_edge = float(xs[np.argmax(uv[:, 0] >= intr.width)])  # the floor's x at the right edge
    found = detect(*frame(base("red", x_edge - 0.03, y)))
    assert len(found) == 1 and found[0][1:] == pytest.approx((x_edge - 0.03, y), abs=0.07)


def test_a_near_neutral_base_cut_by_two_edges_is_placed_and_an_alliance_one_is_not() -> None:
    """A base at the robot's front corner runs off the image's bottom and a side. Nothing else
    on the field is yellow, so a neutral one is placed from the part in view
    (max_cut_edges_yellow); an alliance-coloured one is not tested (a platform's piece, cut to
    a base's size, looks the same: max_cut_edges)."""
    intr, mount = CAMERA.intrinsics, CAMERA.mount
    # The floor's point at the image's bottom-right corner; the base's middle a little inside.
    ys = np.linspace(0.2, 1.5, 1301)
    pts = mount.robot_to_camera_points(np.column_stack([ys * 0, ys, ys * 0 + 0.04]))
    uv, _ = project_points(pts, intr.fx, intr.fy, intr.cx, intr.cy)
    y_bottom = float(ys[np.argmax(uv[:, 1] < intr.height)])
    xs = np.linspace(0.0, 1.0, 1001)
    pts = mount.robot_to_camera_points(
        np.column_stack([xs, np.full_like(xs, y_bottom + 0.08), xs * 0 + 0.04])
    )
    uv, _ = project_points(pts, intr.fx, intr.fy, intr.cx, intr.cy)
    x_edge = float(xs[np.argmax(uv[:, 0] >= intr.width)])
    where = (x_edge - 0.05, y_bottom + 0.08)
    detector = GoalDetector(CAMERA)
    for colour in ("yellow", "red"):
        bgr, depth = frame(base(colour, *where))
        shapes = [shape for _, shape in detector.blobs(bgr, depth)]
        assert len(shapes) == 1 and set(shapes[0].edges.split(",")) == {"bottom", "right"}
        if colour == "yellow":
            assert shapes[0].goal
            assert (shapes[0].x, shapes[0].y) == pytest.approx(where, abs=0.07)
        else:
            assert not shapes[0].goal and shapes[0].why == "cut by the image"


def test_bad_inputs_are_refused() -> None:
    with pytest.raises(ValueError, match="purple"):
        GoalDetectorConfig(windows={"purple": ()})
    with pytest.raises(ValueError, match="min_inside"):
        GoalDetectorConfig(min_inside=0.0)
    bgr, depth = frame()
    with pytest.raises(ValueError, match="depth image"):
        GoalDetector(CAMERA).detect(bgr, depth[:10])
