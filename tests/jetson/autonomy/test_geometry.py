"""The one coordinate-frame module: GPS headings, robot frames, alliance rotation, camera."""

from __future__ import annotations

import math

import numpy as np
import pytest
from hypothesis import given
from hypothesis import strategies as st

from jetson.autonomy import camera
from jetson.autonomy import geometry as g

coord = st.floats(-2.0, 2.0, allow_nan=False)
heading = st.floats(0.0, 359.999, allow_nan=False)


def test_heading_zero_faces_plus_y_and_ninety_faces_plus_x() -> None:
    assert np.allclose(g.heading_vector(0.0), [0.0, 1.0])
    assert np.allclose(g.heading_vector(90.0), [1.0, 0.0])
    assert np.allclose(g.heading_vector(180.0), [0.0, -1.0])
    assert g.heading_of([1.0, 0.0]) == pytest.approx(90.0)
    assert g.heading_of([-1.0, 0.0]) == pytest.approx(270.0)


def test_wrap_heading_is_half_open() -> None:
    assert g.wrap_heading(360.0) == 0.0
    assert g.wrap_heading(-90.0) == pytest.approx(270.0)
    assert 0.0 <= g.wrap_heading(-1e-18) < 360.0
    assert g.angle_diff_deg(10.0, 350.0) == pytest.approx(20.0)


def test_robot_frame_axes() -> None:
    # A robot facing +x (heading 90): a point ahead is +y in its frame, one to its right
    # (field -y) is +x.
    ahead = g.field_to_robot([[1.0, 0.0]], [0.0, 0.0], 90.0)
    right = g.field_to_robot([[0.0, -1.0]], [0.0, 0.0], 90.0)
    assert np.allclose(ahead, [[0.0, 1.0]])
    assert np.allclose(right, [[1.0, 0.0]])


@given(coord, coord, heading, coord, coord)
def test_robot_frame_round_trip(px: float, py: float, h: float, rx: float, ry: float) -> None:
    local = g.field_to_robot([[px, py]], [rx, ry], h)
    back = g.robot_to_field(local, [rx, ry], h)
    assert np.allclose(back, [[px, py]], atol=1e-9)
    assert np.linalg.norm(local) == pytest.approx(math.hypot(px - rx, py - ry), abs=1e-9)


@given(coord, coord, heading)
def test_alliance_rotation_is_an_involution(x: float, y: float, h: float) -> None:
    p1, h1 = g.to_alliance_frame([x, y], h, "blue")
    p2, h2 = g.to_alliance_frame(p1, h1, "blue")
    assert np.allclose(p2, [x, y])
    assert g.angle_diff_deg(h2, h) == pytest.approx(0.0, abs=1e-9)
    same, hs = g.to_alliance_frame([x, y], h, "red")
    assert np.allclose(same, [x, y]) and hs == h


def test_bad_alliance_is_named() -> None:
    with pytest.raises(ValueError, match="green"):
        g.to_alliance_frame([0, 0], 0.0, "green")  # type: ignore[arg-type]


@given(heading)
def test_yaw_conversions_round_trip(h: float) -> None:
    yaw = g.heading_to_yaw(h)
    assert g.angle_diff_deg(g.yaw_to_heading(yaw), h) == pytest.approx(0.0, abs=1e-9)
    assert g.quaternion_yaw(g.yaw_quaternion(yaw)) == pytest.approx(
        math.atan2(math.sin(yaw), math.cos(yaw)), abs=1e-9
    )


def test_clockwise_command_is_negative_yaw_rate() -> None:
    assert g.clockwise_rate_to_yaw_rate(1.5) == -1.5


def test_camera_rotation_tilted_down_looks_forward_and_down() -> None:
    rot = camera.robot_to_camera_rotation(-30.0)
    optical_z = rot[2]  # the optical axis in robot coordinates
    assert np.allclose(optical_z, [0.0, math.cos(math.radians(30)), -0.5])
    assert np.allclose(rot @ rot.T, np.eye(3))
    # A point straight ahead on the optical axis projects to the principal point.
    uv, z = camera.project_points([[0.0, 0.0, 2.0]], 600.0, 600.0, 320.0, 240.0)
    assert np.allclose(uv, [[320.0, 240.0]]) and z[0] == 2.0


def test_points_in_box_uses_robot_frame() -> None:
    pts = np.array([[0.0, 0.3], [0.3, 0.0], [0.0, -0.3]])
    inside = g.points_in_box(pts, [0.0, 0.0], 90.0, (-0.1, 0.1), (0.2, 0.4))
    assert inside.tolist() == [False, True, False]
