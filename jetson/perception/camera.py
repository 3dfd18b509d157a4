"""The camera as mounted on the robot, and the camera config file that records it.

Robot frame (the simulator's, sim/geometry.py): origin at the robot's centre of turning, metres,
+x to the robot's right, +y forward, +z up. Camera (optical) frame: +x right in the image, +y down,
+z forward along the optical axis. This module is the one place on the Jetson that converts
between them; tests check it against sim.geometry so the two cannot drift apart.

The camera config file (JSON, written by `pete-jetson calibrate`):

    {"format": "pete-camera", "version": 1,
     "intrinsics": {"width": 640, "height": 480, "fx": ..., "fy": ..., "cx": ..., "cy": ...,
                    "dist": [k1, k2, p1, p2, k3]},
     "mount": {"forward_m": 0.2, "right_m": 0.0, "height_m": 0.3, "tilt_deg": -30.0},
     "calibration": {...}}            # optional: how the intrinsics were measured
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from jetson.perception.errors import ConfigError
from jetson.perception.frame import Intrinsics

CAMERA_FORMAT = "pete-camera"
CAMERA_VERSION = 1


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
                raise ConfigError(f"mount {name} must be finite")
        if not -89.0 <= self.tilt_deg <= 89.0:
            raise ConfigError(f"mount tilt_deg must be within +-89, got {self.tilt_deg}")

    @property
    def position(self) -> NDArray[np.float64]:
        """The optical centre in the robot frame."""
        return np.array([self.right_m, self.forward_m, self.height_m])

    @property
    def robot_to_camera(self) -> NDArray[np.float64]:
        """Rotation taking robot-frame vectors to optical-frame vectors."""
        t = math.radians(self.tilt_deg)
        # Level camera: optical x = robot x, optical y = -robot z, optical z = robot y.
        level = np.array([[1.0, 0.0, 0.0], [0.0, 0.0, -1.0], [0.0, 1.0, 0.0]])
        c, s = math.cos(t), math.sin(t)
        pitch = np.array([[1.0, 0.0, 0.0], [0.0, c, s], [0.0, -s, c]])
        return pitch @ level

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
            raise ConfigError(f"unknown mount keys {sorted(unknown)}; known: {sorted(known)}")
        try:
            return cls(**{k: float(v) for k, v in data.items()})
        except (TypeError, ValueError) as exc:
            raise ConfigError(f"mount values must be numbers: {exc}") from exc


@dataclass(frozen=True)
class CameraConfig:
    intrinsics: Intrinsics = field(default_factory=Intrinsics)
    mount: CameraMount = field(default_factory=CameraMount)
    calibration: dict[str, Any] | None = None

    def to_dict(self) -> dict[str, Any]:
        out: dict[str, Any] = {
            "format": CAMERA_FORMAT,
            "version": CAMERA_VERSION,
            "intrinsics": self.intrinsics.to_dict(),
            "mount": self.mount.to_dict(),
        }
        if self.calibration is not None:
            out["calibration"] = self.calibration
        return out

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> CameraConfig:
        if data.get("format") != CAMERA_FORMAT:
            raise ConfigError(f"not a camera config (format is {data.get('format')!r})")
        if data.get("version") != CAMERA_VERSION:
            raise ConfigError(f"camera config version {data.get('version')!r} is not supported")
        return cls(
            intrinsics=Intrinsics.from_dict(data.get("intrinsics", {})),
            mount=CameraMount.from_dict(data.get("mount", {})),
            calibration=data.get("calibration"),
        )

    def save(self, path: Path) -> None:
        path.parent.mkdir(parents=True, exist_ok=True)
        path.write_text(json.dumps(self.to_dict(), indent=2) + "\n")

    @classmethod
    def load(cls, path: Path) -> CameraConfig:
        try:
            data = json.loads(Path(path).read_text())
        except FileNotFoundError as exc:
            raise ConfigError(f"camera config {path} does not exist") from exc
        except (OSError, json.JSONDecodeError) as exc:
            raise ConfigError(f"camera config {path} cannot be read: {exc}") from exc
        if not isinstance(data, dict):
            raise ConfigError(f"camera config {path} must hold a JSON object")
        return cls.from_dict(data)
