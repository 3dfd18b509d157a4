"""The camera config file: the camera model (jetson/autonomy/camera.py) of one robot, on disk.

The file (JSON, written by `pete-jetson calibrate`):

    {"format": "pete-camera", "version": 1,
     "intrinsics": {"width": 640, "height": 480, "fx": ..., "fy": ..., "cx": ..., "cy": ...,
                    "dist": [k1, k2, p1, p2, k3]},
     "mount": {"forward_m": 0.2, "right_m": 0.0, "height_m": 0.3, "tilt_deg": -30.0},
     "calibration": {...}}            # optional: how the intrinsics were measured
"""

from __future__ import annotations

import json
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

from jetson.autonomy.camera import CameraMount, Intrinsics
from jetson.errors import CameraConfigError

CAMERA_FORMAT = "pete-camera"
CAMERA_VERSION = 1


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
            raise CameraConfigError(f"not a camera config (format is {data.get('format')!r})")
        if data.get("version") != CAMERA_VERSION:
            raise CameraConfigError(
                f"camera config version {data.get('version')!r} is not supported"
            )
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
            raise CameraConfigError(f"camera config {path} does not exist") from exc
        except (OSError, json.JSONDecodeError) as exc:
            raise CameraConfigError(f"camera config {path} cannot be read: {exc}") from exc
        if not isinstance(data, dict):
            raise CameraConfigError(f"camera config {path} must hold a JSON object")
        return cls.from_dict(data)
