"""The one pinhole camera model: intrinsics, where the camera sits on the robot, projection.

Robot frame (geometry.py): origin at the robot's centre of turning, metres, +x to the robot's
right, +y forward, +z up. Camera (optical) frame, as OpenCV and librealsense use it: +x right in
the image, +y down, +z forward along the optical axis. Everything that converts between the two
or projects to pixels is here: perception localises detections with it, the ring memory asks it
which remembered rings are in the picture (MemoryCamera), and the simulator renders and tests
visibility with the same functions.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from jetson.errors import CameraConfigError, ObservationError

FloatArray = NDArray[np.float64]

# The original team's checkerboard calibration of their D435 colour camera at 640x480
# (REFERENCE section 1). Their distortion vector is left out of the default: it was fitted to
# 53 images with k2 = 1.0 and k3 = -3.65, large terms that cancel inside the image but diverge
# just outside it; a fresh `pete-jetson calibrate` gives the real one.
DEFAULT_WIDTH = 640
DEFAULT_HEIGHT = 480
DEFAULT_FX = 608.38952271
DEFAULT_FY = 610.59807426
DEFAULT_CX = 332.60130193
DEFAULT_CY = 236.58507294


@dataclass(frozen=True)
class Intrinsics:
    """Pinhole model of the colour camera (OpenCV's convention: +x right, +y down, +z forward).

    dist is OpenCV's (k1, k2, p1, p2, k3); all zeros means an ideal pinhole.
    """

    width: int = DEFAULT_WIDTH
    height: int = DEFAULT_HEIGHT
    fx: float = DEFAULT_FX
    fy: float = DEFAULT_FY
    cx: float = DEFAULT_CX
    cy: float = DEFAULT_CY
    dist: tuple[float, ...] = (0.0, 0.0, 0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        if self.width < 1 or self.height < 1:
            raise CameraConfigError(f"image size must be positive, got {self.width}x{self.height}")
        for name in ("fx", "fy", "cx", "cy"):
            value = getattr(self, name)
            if not math.isfinite(value):
                raise CameraConfigError(f"intrinsics {name} must be finite, got {value}")
        if self.fx <= 0 or self.fy <= 0:
            raise CameraConfigError(
                f"focal lengths must be positive, got fx={self.fx}, fy={self.fy}"
            )
        if len(self.dist) not in (4, 5, 8, 12, 14):
            raise CameraConfigError(f"dist must have 4, 5, 8, 12 or 14 terms, got {len(self.dist)}")
        object.__setattr__(self, "dist", tuple(float(d) for d in self.dist))

    @property
    def matrix(self) -> NDArray[np.float64]:
        """K, the 3x3 camera matrix."""
        return np.array([[self.fx, 0.0, self.cx], [0.0, self.fy, self.cy], [0.0, 0.0, 1.0]])

    @property
    def distorted(self) -> bool:
        return any(d != 0.0 for d in self.dist)

    def scaled(self, width: int, height: int) -> Intrinsics:
        """The same camera at another resolution (a resize of the whole image)."""
        sx, sy = width / self.width, height / self.height
        return replace(
            self,
            width=width,
            height=height,
            fx=self.fx * sx,
            fy=self.fy * sy,
            cx=self.cx * sx,
            cy=self.cy * sy,
        )

    def to_dict(self) -> dict[str, Any]:
        return {
            "width": self.width,
            "height": self.height,
            "fx": self.fx,
            "fy": self.fy,
            "cx": self.cx,
            "cy": self.cy,
            "dist": list(self.dist),
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Intrinsics:
        known = {"width", "height", "fx", "fy", "cx", "cy", "dist"}
        unknown = set(data) - known
        if unknown:
            raise CameraConfigError(
                f"unknown intrinsics keys {sorted(unknown)}; known: {sorted(known)}"
            )
        missing = known - {"dist"} - set(data)
        if missing:
            raise CameraConfigError(f"intrinsics lack {sorted(missing)}")
        try:
            return cls(
                width=int(data["width"]),
                height=int(data["height"]),
                fx=float(data["fx"]),
                fy=float(data["fy"]),
                cx=float(data["cx"]),
                cy=float(data["cy"]),
                dist=tuple(float(d) for d in data.get("dist", (0.0,) * 5)),
            )
        except (TypeError, ValueError) as exc:
            raise CameraConfigError(f"intrinsics values must be numbers: {exc}") from exc


def robot_to_camera_rotation(tilt_deg: float) -> FloatArray:
    """Rotation taking robot-frame 3D vectors (x right, y forward, z up) to the optical frame.

    tilt_deg is the camera's pitch: negative looks down (the original mounted it at -30 deg).
    """
    t = math.radians(tilt_deg)
    # Untilted: optical x = robot x (right), optical y = -robot z (down), optical z = robot y.
    base = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
    # Tilting down by |t| rotates the optical axis towards -z about the robot's x axis.
    c, s = math.cos(t), math.sin(t)
    pitch = np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])
    return pitch @ base


def project_points(
    points_cam: ArrayLike, fx: float, fy: float, cx: float, cy: float
) -> tuple[FloatArray, FloatArray]:
    """Pinhole projection of optical-frame points (N, 3): pixels (N, 2) and depth (N,)."""
    p = np.asarray(points_cam, dtype=np.float64)
    z = p[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        u = fx * p[..., 0] / z + cx
        v = fy * p[..., 1] / z + cy
    return np.stack([u, v], axis=-1), z


@dataclass(frozen=True)
class CameraMount:
    """Where the camera sits on the robot. Defaults match sim.config.CameraConfig: 0.2 m ahead
    of the centre of turning and tilted 30 degrees down (the original team's mount); the height
    is unverified."""

    forward_m: float = 0.20
    right_m: float = 0.0
    height_m: float = 0.30
    tilt_deg: float = -30.0  # pitch about the robot's x axis; negative looks down

    def __post_init__(self) -> None:
        for name in ("forward_m", "right_m", "height_m", "tilt_deg"):
            if not math.isfinite(getattr(self, name)):
                raise CameraConfigError(f"mount {name} must be finite")
        if not -89.0 <= self.tilt_deg <= 89.0:
            raise CameraConfigError(f"mount tilt_deg must be within +-89, got {self.tilt_deg}")

    @property
    def position(self) -> NDArray[np.float64]:
        """The optical centre in the robot frame."""
        return np.array([self.right_m, self.forward_m, self.height_m])

    @property
    def robot_to_camera(self) -> NDArray[np.float64]:
        """Rotation taking robot-frame vectors to optical-frame vectors."""
        return robot_to_camera_rotation(self.tilt_deg)

    def camera_to_robot(self, points_cam: ArrayLike) -> NDArray[np.float64]:
        """Optical-frame points (..., 3) to robot-frame points (..., 3)."""
        p = np.asarray(points_cam, dtype=np.float64)
        return p @ self.robot_to_camera + self.position

    def robot_to_camera_points(self, points_robot: ArrayLike) -> NDArray[np.float64]:
        """Robot-frame points (..., 3) to optical-frame points (..., 3)."""
        p = np.asarray(points_robot, dtype=np.float64) - self.position
        return p @ self.robot_to_camera.T

    def to_dict(self) -> dict[str, float]:
        return {
            "forward_m": self.forward_m,
            "right_m": self.right_m,
            "height_m": self.height_m,
            "tilt_deg": self.tilt_deg,
        }

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> CameraMount:
        known = {"forward_m", "right_m", "height_m", "tilt_deg"}
        unknown = set(data) - known
        if unknown:
            raise CameraConfigError(f"unknown mount keys {sorted(unknown)}; known: {sorted(known)}")
        try:
            return cls(**{k: float(v) for k, v in data.items()})
        except (TypeError, ValueError) as exc:
            raise CameraConfigError(f"mount values must be numbers: {exc}") from exc


@dataclass(frozen=True)
class MemoryCamera:
    """The camera as the ring memory needs it (spec.memory_view "camera"): where it sits on the
    robot (x right, y forward, z up from the centre of turning at floor level; tilt negative
    looking down) and its pinhole intrinsics, to tell which remembered rings are in its picture.
    The simulator builds one from the robot's camera, the Jetson from its camera config."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    forward_m: float
    right_m: float
    height_m: float
    tilt_deg: float
    near_m: float = 0.17  # nearer than this along the optical axis the depth camera sees nothing
    ring_z_m: float = 0.0127  # a ring's centre above the floor (lying flat, 1 inch tube)

    def __post_init__(self) -> None:
        values = [getattr(self, f.name) for f in fields(self)]
        if not all(math.isfinite(v) for v in values):
            raise ObservationError(f"memory camera values must be finite: {self}")
        if not (self.fx > 0 and self.fy > 0 and self.width > 0 and self.height > 0):
            raise ObservationError("memory camera: fx, fy, width and height must be positive")

    @classmethod
    def from_model(cls, intrinsics: Intrinsics, mount: CameraMount, **extra: float) -> MemoryCamera:
        """The ring memory's view of a camera given by the model (a camera config file)."""
        k, m = intrinsics, mount
        return cls(
            fx=k.fx, fy=k.fy, cx=k.cx, cy=k.cy, width=k.width, height=k.height,
            forward_m=m.forward_m, right_m=m.right_m, height_m=m.height_m, tilt_deg=m.tilt_deg,
            **extra,
        )  # fmt: skip

    def locate(
        self, robot_xy: NDArray[np.float64]
    ) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
        """For floor rings at robot-frame (x, y): inside the picture, and distance from the lens."""
        pts = np.asarray(robot_xy, dtype=np.float64).reshape(-1, 2)
        rel = np.column_stack(
            [
                pts[:, 0] - self.right_m,
                pts[:, 1] - self.forward_m,
                np.full(len(pts), self.ring_z_m - self.height_m),
            ]
        )
        optical = rel @ robot_to_camera_rotation(self.tilt_deg).T
        uv, z = project_points(optical, self.fx, self.fy, self.cx, self.cy)
        with np.errstate(invalid="ignore"):
            inside = (z > self.near_m) & (uv[:, 0] >= 0) & (uv[:, 0] < self.width)
            inside &= (uv[:, 1] >= 0) & (uv[:, 1] < self.height)
        return inside, np.linalg.norm(rel, axis=1)
