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


def test_the_twins_sight_model_agrees_with_the_detector(world: World) -> None:
    """sim.visibility.plates_in_view, what the twin's observation (seen_opponents) and the fast
    backend call seeing a robot, against the detector on the renders of the same scenes: near
    and far, facing, aslant, side on and turned away, ahead and aside."""
    from sim.world.sensors import robots_in_view

    agree, scenes, seen = 0, 0, 0
    for d in (0.9, 1.3, 1.7, 2.1, 2.5, 2.9, 3.3):
        for rel in (180.0, 140.0, 235.0, 100.0, 0.0):
            for lat in (0.0, 0.6):
                got, _ = look(world, d, rel, lat)
                model = bool(robots_in_view(world)[0, 1])
                agree += model == bool(got)
                seen += model
                scenes += 1
    assert seen >= 10 and scenes - seen >= 10  # both answers were asked
    assert agree / scenes >= 0.9, f"{agree} of {scenes}"


def test_the_sight_model_projects_as_the_camera_does() -> None:
    """plates_in_view's picture test is the camera model's (sim.visibility.in_frustum) on the
    same points along a plate's lower edge, over random poses of a plate facing the lens."""
    from sim.config import CameraConfig, RobotConfig
    from sim.visibility import (
        PLATE_EDGE_M,
        PLATE_IN_PICTURE,
        PLATE_SAMPLES,
        PLATE_SHARE,
        ROBOT_SIGHT_M,
        camera_pose,
        in_frustum,
        plates_in_view,
    )

    rng = np.random.default_rng(2)
    cam, rc = CameraConfig(), RobotConfig()
    sizes = np.array([(rc.width_m, rc.length_m, rc.height_m)] * 2)
    answers = []
    for _ in range(300):
        x1, y1 = rng.uniform(-1.2, 1.2), rng.uniform(0.3, 2.8)
        h0 = rng.uniform(-20.0, 20.0)
        xs, ys = np.array([[0.0, x1]]), np.array([[0.0, y1]])
        got = plates_in_view(xs, ys, np.array([[h0, 180.0]]), np.zeros((1, 2)), [cam, cam], sizes)
        # Robot 1 faces -y: its plate's middle is half its length below its centre, the plate
        # runs along -x (its right), its lower edge PLATE_EDGE_M below the middle.
        along = np.linspace(-0.5, 0.5, PLATE_SAMPLES) * PLATE_SHARE * rc.width_m
        z = rc.height_m / 2 - PLATE_EDGE_M
        edge = np.array([[x1 - a, y1 - rc.length_m / 2, z] for a in along])
        mask, _, _ = in_frustum(edge, camera_pose((0.0, 0.0), h0, cam), cam)
        lens = np.array(camera_pose((0.0, 0.0), h0, cam).position)
        mid = edge[PLATE_SAMPLES // 2]
        want = mask.sum() >= PLATE_IN_PICTURE and np.linalg.norm(mid - lens) <= ROBOT_SIGHT_M
        facing = (lens[1] - mid[1]) / np.hypot(*(lens[:2] - mid[:2]))
        want &= PLATE_SHARE * rc.width_m * -facing >= 0.15
        answers.append((bool(got[0, 0, 1]), bool(want)))
        assert not got[0, 0, 0] and not got[0, 1, 1]  # never itself
    assert all(a == b for a, b in answers)
    assert 30 < sum(a for a, _ in answers) < 270  # both answers were asked


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


def test_a_robot_in_between_hides_the_plate_from_the_model_and_the_detector() -> None:
    """The sight model's occlusion (sim.visibility._plates_hidden): red's 15" standing between
    red's 24" camera and blue's 24" hides blue's plate; moved aside, both see it again."""
    from sim.world.sensors import robots_in_view

    w = World(replace(world_preset("tipping_point_2v2", preloads=False), fidelity="training"))
    try:
        w.reset(np.random.default_rng(0))
        w.set_floor_rings(np.zeros((0, 2)))
        for g, (x, y) in zip(w.goals, SPOTS * 2, strict=False):
            w.place_goal(g.index, x, y)
        cam = w.robots[0].config.camera.scaled(240, 180)
        detector = RobotDetector(JetsonCamera(cam.intrinsics, cam.mount))
        w.place_robot(0, -1.0, 0.0, 90.0)  # red 24", looking along +x
        w.place_robot(2, 0.5, 0.0, 270.0)  # blue 24", its plate toward red's camera
        w.place_robot(3, 0.5, 1.5, 0.0)  # blue 15", out of the way
        answers = []
        for partner_y in (0.0, 1.2):  # red 15" in between (its plate away from us), then aside
            w.place_robot(1, -0.2, partner_y, 90.0)
            f = render_camera(w, 0, cam)
            got = detector.detect(np.ascontiguousarray(f.rgb[:, :, ::-1]), f.depth, cam.intrinsics)
            answers.append((bool(robots_in_view(w)[0, 2]), [s.alliance for s in got]))
        assert answers == [(False, []), (True, ["blue"])]
    finally:
        w.close()
