"""Localisation: back-projection, the camera mount, depth from the ring's own pixels."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

from jetson.autonomy.camera import CameraMount, Intrinsics
from jetson.errors import CameraConfigError
from jetson.perception.camera import CameraConfig
from jetson.perception.detection import Detection
from jetson.perception.localise import (
    Localiser,
    LocaliserConfig,
    annulus_mask,
    back_project,
    ring_depth,
    rings_robot_xy,
)
from jetson.perception.prefilter import HsvWindow
from jetson.perception.synthetic import RING_MINOR_M, Ring, Scene, render

K = Intrinsics(640, 480, 600.0, 600.0, 320.0, 240.0)


def test_back_projection_matches_hand_computed_points() -> None:
    # The principal point at 2 m is straight ahead.
    assert back_project(320.0, 240.0, 2.0, K) == pytest.approx([0.0, 0.0, 2.0])
    # 60 px right of it at 2 m: x = 60 / 600 * 2 = 0.2 m; 120 px above at 3 m: y = -0.6 m.
    assert back_project(380.0, 240.0, 2.0, K) == pytest.approx([0.2, 0.0, 2.0])
    assert back_project(320.0, 120.0, 3.0, K) == pytest.approx([0.0, -0.6, 3.0])
    # Unequal focal lengths and an off-centre principal point.
    k2 = Intrinsics(640, 480, 500.0, 400.0, 300.0, 200.0)
    assert back_project(400.0, 260.0, 1.5, k2) == pytest.approx([0.3, 0.225, 1.5])


def test_back_projection_undoes_distortion() -> None:
    import cv2

    k = Intrinsics(640, 480, 600.0, 600.0, 320.0, 240.0, (-0.2, 0.05, 0.001, -0.001, 0.0))
    point = np.array([[0.4, -0.25, 2.0]])
    uv, _ = cv2.projectPoints(point, np.zeros(3), np.zeros(3), k.matrix, np.array(k.dist))
    u, v = uv.ravel()
    assert back_project(u, v, 2.0, k) == pytest.approx(point[0], abs=1e-4)


def test_mount_level_camera_by_hand() -> None:
    # Level camera 0.3 m up, 0.2 m ahead: a point 1 m down the optical axis is 1.2 m ahead of
    # the robot at the camera's height; optical +x is robot +x (right), optical +y is down.
    m = CameraMount(forward_m=0.2, right_m=0.0, height_m=0.3, tilt_deg=0.0)
    assert m.camera_to_robot([0.0, 0.0, 1.0]) == pytest.approx([0.0, 1.2, 0.3])
    assert m.camera_to_robot([0.5, 0.1, 1.0]) == pytest.approx([0.5, 1.2, 0.2])


def test_mount_tilted_down_30_degrees_by_hand() -> None:
    m = CameraMount(forward_m=0.2, height_m=0.3, tilt_deg=-30.0)
    # Along the optical axis the ray drops 30 degrees: d metres out is d cos 30 ahead and
    # d sin 30 down. At d = 0.6 m it meets the floor: 0.6 * sin 30 = 0.3.
    p = m.camera_to_robot([0.0, 0.0, 0.6])
    assert p == pytest.approx([0.0, 0.2 + 0.6 * math.cos(math.radians(30)), 0.0])
    # And the inverse takes it back.
    assert m.robot_to_camera_points(p) == pytest.approx([0.0, 0.0, 0.6])


def test_annulus_leaves_out_the_hole_and_the_corners() -> None:
    box = Detection(10, 20, 50, 60, 1.0)
    _, ann = annulus_mask(box, (100, 100), 0.5)
    assert ann.shape == (40, 40)
    assert not ann[20, 20]  # the centre: the hole
    assert not ann[0, 0]  # a box corner: outside the ring
    assert ann[20, 2]  # on the ring, left of the hole
    assert ann[2, 20]


def test_depth_of_a_ring_whose_centre_is_a_hole_ignores_the_hole() -> None:
    # A ring at 1.5 m; through its hole the camera sees a wall 4 m away, and the pixels right
    # at the centre have no reading at all. The centre pixel would say 4 m (or nothing).
    depth = np.full((200, 200), 4.0, np.float32)
    yy, xx = np.mgrid[0:200, 0:200]
    r = np.hypot(xx - 99.5, yy - 99.5)
    ring = (r <= 40) & (r >= 20)
    depth[ring] = 1.5 + 0.01 * np.sin(xx[ring])  # a little surface relief
    depth[r < 5] = 0.0
    box = Detection(59.5, 59.5, 139.5, 139.5, 0.9)
    assert depth[100, 100] == 0.0
    z = ring_depth(box, depth, None, LocaliserConfig())
    assert z == pytest.approx(1.5, abs=0.01)


def test_localise_a_rendered_ring_on_the_floor() -> None:
    cam = CameraConfig()
    intr = cam.intrinsics.scaled(320, 240)
    truth = (0.15, 1.1)
    scene = Scene(rings=[Ring(truth[0], truth[1], RING_MINOR_M)])
    r = render(scene, intr, cam.mount, None)
    assert len(r.boxes) == 1
    mask = HsvWindow().mask(r.frame.color)
    est = Localiser(cam).localise([Detection(*r.boxes[0], 1.0)], r.frame.depth_m, mask, intr)
    assert len(est) == 1
    assert est[0].method == "depth"
    assert np.hypot(*(np.array(est[0].robot_xy) - truth)) < 0.03
    assert est[0].distance_m == pytest.approx(np.hypot(*truth), abs=0.03)


def test_localised_rings_are_sorted_nearest_first_and_feed_the_observation() -> None:
    cam = CameraConfig()
    intr = cam.intrinsics.scaled(320, 240)
    truths = [(0.3, 1.6), (-0.2, 0.7), (0.0, 1.1)]
    scene = Scene(rings=[Ring(x, y) for x, y in truths])
    r = render(scene, intr, cam.mount, np.random.default_rng(3))
    dets = [Detection(*b, 1.0) for b in r.boxes]
    est = Localiser(cam).localise(dets, r.frame.depth_m, HsvWindow().mask(r.frame.color), intr)
    xy = rings_robot_xy(est)
    assert xy.shape == (3, 2)
    d = np.hypot(xy[:, 0], xy[:, 1])
    assert np.all(np.diff(d) > 0)
    expected = sorted(truths, key=lambda p: np.hypot(*p))
    assert xy == pytest.approx(np.array(expected), abs=0.04)
    from jetson.autonomy import observation

    spec = observation.ObservationSpec(n_stack=0)
    view = observation.RobotView(0.0, 0.0, 0.0, "red", 0.0, rings_robot_xy=xy)
    frame = observation.build_frame(spec, view)
    first = frame[spec.ring_offset : spec.ring_offset + 3]
    assert first == pytest.approx([*(xy[0] / spec.length_unit_m), 1.0], abs=1e-6)


def test_rings_without_depth_are_not_placed_unless_the_floor_fallback_is_on() -> None:
    cam = CameraConfig()
    intr = cam.intrinsics.scaled(320, 240)
    scene = Scene(rings=[Ring(0.0, 1.0)])
    r = render(scene, intr, cam.mount, None)
    det = Detection(*r.boxes[0], 1.0)
    assert Localiser(cam).localise([det], None, None, intr) == []
    est = Localiser(cam, LocaliserConfig(floor_fallback=True)).localise([det], None, None, intr)
    assert est[0].method == "floor"
    assert np.hypot(*(np.array(est[0].robot_xy) - (0.0, 1.0))) < 0.08


def test_rings_beyond_the_range_limit_are_dropped() -> None:
    cam = CameraConfig()
    intr = cam.intrinsics.scaled(320, 240)
    r = render(Scene(rings=[Ring(0.0, 1.5)]), intr, cam.mount, None)
    det = Detection(*r.boxes[0], 1.0)
    assert (
        Localiser(cam, LocaliserConfig(max_range_m=1.0)).localise(
            [det], r.frame.depth_m, None, intr
        )
        == []
    )


def test_bad_localiser_config_is_named() -> None:
    with pytest.raises(CameraConfigError, match="hole_ratio"):
        LocaliserConfig(hole_ratio=1.5)
    with pytest.raises(CameraConfigError, match="tilt"):
        CameraMount(tilt_deg=120.0)


def test_camera_config_round_trip_and_errors(tmp_path: Path) -> None:
    cfg = CameraConfig(K, CameraMount(0.1, 0.02, 0.25, -20.0), {"rms_px": 0.3})
    path = tmp_path / "camera.json"
    cfg.save(path)
    assert CameraConfig.load(path) == cfg
    with pytest.raises(CameraConfigError, match="does not exist"):
        CameraConfig.load(tmp_path / "nope.json")
    path.write_text('{"format": "pete-camera", "version": 1, "intrinsics": {"fx": 1}}')
    with pytest.raises(CameraConfigError, match="lack"):
        CameraConfig.load(path)
