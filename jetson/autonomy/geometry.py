"""The one coordinate-frame module: every conversion between frames lives here.

Field frame (the VEX GPS frame)
    Origin at the centre of the field, metres. Seen from above, +x points to the right and +y away
    from the viewer. Heading is in degrees, measured CLOCKWISE from +y (heading 0 faces +y, heading
    90 faces +x), normalised to [0, 360), exactly as the V5 GPS reports it ("0 being north on the
    field, [0, 360) going clockwise", PROS gps API). A robot with heading h moves along
    (sin h, cos h).

Robot frame
    Origin at the robot's centre of turning, metres; +y forward (the robot's heading), +x to the
    robot's right. It is the field frame as a robot at the origin with heading 0 sees it, so the
    same handedness and the same "clockwise is positive" rule hold in both. (The original team's
    Unity sim used the same axes: local x right, local z forward.)

AllianceName frame
    The field frame as an alliance sees it: red's equals the field frame, blue's is rotated by
    180 degrees about the centre, so both alliances share one observation space. The Tipping Point
    field is point-symmetric, so a blue robot in the alliance frame sees what a red robot in the
    same place sees in the field frame.

PyBullet world
    x and y equal the field frame's, z up. PyBullet's yaw is counter-clockwise from +x, so
    yaw_rad = radians(90 - heading). Angular rates: the protocol's Command.angular is rad/s,
    positive clockwise (heading increasing); PyBullet's angular velocity about +z is its negative.

Camera frame (optical, as OpenCV and librealsense use)
    +x right in the image, +y down, +z forward along the optical axis.

Only numpy here: the robot's decision code (jetson.autonomy) and the simulator share it. The
pinhole camera model (robot frame <-> optical frame <-> pixels) is jetson/autonomy/camera.py.
"""

from __future__ import annotations

import math
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

INCH = 0.0254
"""Metres per inch: the VEX manuals are in inches, everything here is in metres."""

AllianceName = Literal["red", "blue"]
"""An alliance as the decision code names it (the wire's is protocol.messages.AllianceName)."""
ALLIANCES: tuple[AllianceName, AllianceName] = ("red", "blue")

FloatArray = NDArray[np.float64]


def inches(value: float) -> float:
    return value * INCH


def wrap_heading(heading_deg: ArrayLike) -> NDArray[np.float64] | float:
    """Heading folded into [0, 360)."""
    if isinstance(heading_deg, float | int):
        # The scalar path is taken every control step; numpy's overhead would dominate it.
        h = float(heading_deg) % 360.0
        return 0.0 if h >= 360.0 else h
    wrapped = np.mod(np.asarray(heading_deg, dtype=np.float64), 360.0)
    # np.mod(-1e-18, 360) is 360.0 in floating point; fold it back so the range is half-open.
    wrapped = np.where(wrapped >= 360.0, 0.0, wrapped)
    return float(wrapped) if wrapped.ndim == 0 else wrapped


def angle_diff_deg(a: float, b: float) -> float:
    """Signed smallest difference a - b in degrees, in [-180, 180)."""
    return (a - b + 180.0) % 360.0 - 180.0


def heading_vector(heading_deg: ArrayLike) -> FloatArray:
    """Unit vector(s) of a heading in the field frame, shape (..., 2)."""
    if isinstance(heading_deg, float | int):
        return np.array(heading_sin_cos(heading_deg))
    h = np.radians(np.asarray(heading_deg, dtype=np.float64))
    return np.stack([np.sin(h), np.cos(h)], axis=-1)


def heading_sin_cos(heading_deg: float) -> tuple[float, float]:
    """(sin, cos) of one heading: heading_vector's two values as floats, computed by numpy as
    heading_vector computes them (math.sin may differ from numpy's in the last bit)."""
    h = np.radians(np.asarray(heading_deg, dtype=np.float64))
    return float(np.sin(h)), float(np.cos(h))


def heading_of(vector_xy: ArrayLike) -> NDArray[np.float64] | float:
    """Heading in degrees [0, 360) of field-frame direction vector(s) (..., 2)."""
    v = np.asarray(vector_xy, dtype=np.float64)
    return wrap_heading(np.degrees(np.arctan2(v[..., 0], v[..., 1])))


def field_to_robot(
    points_xy: ArrayLike, robot_xy: ArrayLike, robot_heading_deg: float
) -> FloatArray:
    """Field-frame points (N, 2) into the frame of a robot at robot_xy with the given heading."""
    p = np.asarray(points_xy, dtype=np.float64) - np.asarray(robot_xy, dtype=np.float64)
    out = np.empty_like(p)
    if p.size == 0:  # most control steps see no ring at all
        return out
    h = math.radians(robot_heading_deg)
    s, c = math.sin(h), math.cos(h)
    # Forward unit (s, c), right unit (c, -s): project onto them.
    px, py = p[..., 0], p[..., 1]
    out[..., 0] = px * c - py * s
    out[..., 1] = px * s + py * c
    return out


def robot_to_field(
    points_xy: ArrayLike, robot_xy: ArrayLike, robot_heading_deg: float
) -> FloatArray:
    """Robot-frame points (N, 2) back into the field frame (the inverse of field_to_robot)."""
    p = np.asarray(points_xy, dtype=np.float64)
    h = math.radians(robot_heading_deg)
    s, c = math.sin(h), math.cos(h)
    out = np.empty_like(p)
    out[..., 0] = p[..., 0] * c + p[..., 1] * s
    out[..., 1] = -p[..., 0] * s + p[..., 1] * c
    return out + np.asarray(robot_xy, dtype=np.float64)


def to_alliance_frame(
    xy: ArrayLike, heading_deg: float | None, alliance: AllianceName
) -> tuple[FloatArray, float | None]:
    """A field-frame position (and heading) as the given alliance sees it.

    Blue sees the field rotated by 180 degrees; applying it twice gives back the field frame, so
    the same function converts back.
    """
    p = np.asarray(xy, dtype=np.float64)
    if alliance == "red":
        return p.copy(), heading_deg
    if alliance == "blue":
        h = None if heading_deg is None else float(wrap_heading(heading_deg + 180.0))
        return -p, h
    raise ValueError(f"alliance must be 'red' or 'blue', got {alliance!r}")


def pose_to_alliance_frame(
    x: float, y: float, heading_deg: float, alliance: AllianceName
) -> tuple[float, float, float]:
    """to_alliance_frame of one pose, as floats: the same values without the arrays (the
    observation converts the robot's own pose every control step)."""
    if alliance == "red":
        return float(x), float(y), heading_deg
    if alliance == "blue":
        return -float(x), -float(y), float(wrap_heading(heading_deg + 180.0))
    raise ValueError(f"alliance must be 'red' or 'blue', got {alliance!r}")


def other_alliance(alliance: AllianceName) -> AllianceName:
    if alliance == "red":
        return "blue"
    if alliance == "blue":
        return "red"
    raise ValueError(f"alliance must be 'red' or 'blue', got {alliance!r}")


def heading_to_yaw(heading_deg: float) -> float:
    """PyBullet yaw (radians, counter-clockwise from +x) of a GPS heading."""
    return math.radians(90.0 - heading_deg)


def yaw_to_heading(yaw_rad: float) -> float:
    return float(wrap_heading(90.0 - math.degrees(yaw_rad)))


def yaw_quaternion(yaw_rad: float) -> tuple[float, float, float, float]:
    """PyBullet quaternion (x, y, z, w) of a pure rotation about +z."""
    return (0.0, 0.0, math.sin(yaw_rad / 2.0), math.cos(yaw_rad / 2.0))


def quaternion_yaw(q: tuple[float, float, float, float] | ArrayLike) -> float:
    """Yaw about +z of a PyBullet quaternion (x, y, z, w), ignoring any tilt."""
    x, y, z, w = (float(v) for v in q)  # type: ignore[union-attr]
    return math.atan2(2.0 * (w * z + x * y), 1.0 - 2.0 * (y * y + z * z))


def clockwise_rate_to_yaw_rate(angular_cw_rad_s: float) -> float:
    """Command.angular (positive clockwise) to PyBullet's angular velocity about +z."""
    return -angular_cw_rad_s


def box_corners(
    center_xy: ArrayLike, heading_deg: float, width: float, length: float
) -> FloatArray:
    """Field-frame corners (4, 2) of a robot-shaped box: `width` across, `length` along heading."""
    hw, hl = width / 2.0, length / 2.0
    local = np.array([[-hw, -hl], [hw, -hl], [hw, hl], [-hw, hl]])
    return robot_to_field(local, center_xy, heading_deg)


def points_in_box(
    points_xy: ArrayLike,
    center_xy: ArrayLike,
    heading_deg: float,
    x_range: tuple[float, float],
    y_range: tuple[float, float],
) -> NDArray[np.bool_]:
    """Which field points lie in a rectangle given in a robot frame (x right, y forward)."""
    local = field_to_robot(points_xy, center_xy, heading_deg)
    return (
        (local[..., 0] >= x_range[0])
        & (local[..., 0] <= x_range[1])
        & (local[..., 1] >= y_range[0])
        & (local[..., 1] <= y_range[1])
    )


def push_out_of_box(
    local_xy: ArrayLike, half_x: float, half_y: float
) -> tuple[FloatArray, NDArray[np.bool_]]:
    """Points in a robot frame moved out of the box |x| < half_x, |y| < half_y across its nearer
    side (the least movement that clears it), and which of them moved; points outside stay.
    What a bumper does to a ring it drives over: the training simulator's push_rings and the
    ring memory's memory_push."""
    out = np.array(local_xy, dtype=np.float64).reshape(-1, 2)
    inside = (np.abs(out[:, 0]) < half_x) & (np.abs(out[:, 1]) < half_y)
    loc = out[inside]
    sideways = half_x - np.abs(loc[:, 0]) <= half_y - np.abs(loc[:, 1])
    sign = np.where(loc >= 0.0, 1.0, -1.0)
    loc[sideways, 0] = sign[sideways, 0] * half_x
    loc[~sideways, 1] = sign[~sideways, 1] * half_y
    out[inside] = loc
    return out, inside
