"""One camera frame: aligned colour and depth, the colour camera's intrinsics, a timestamp."""

from __future__ import annotations

import math
from dataclasses import dataclass, replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from jetson.perception.errors import ConfigError, SourceError

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
            raise ConfigError(f"image size must be positive, got {self.width}x{self.height}")
        for name in ("fx", "fy", "cx", "cy"):
            value = getattr(self, name)
            if not math.isfinite(value):
                raise ConfigError(f"intrinsics {name} must be finite, got {value}")
        if self.fx <= 0 or self.fy <= 0:
            raise ConfigError(f"focal lengths must be positive, got fx={self.fx}, fy={self.fy}")
        if len(self.dist) not in (4, 5, 8, 12, 14):
            raise ConfigError(f"dist must have 4, 5, 8, 12 or 14 terms, got {len(self.dist)}")
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
            raise ConfigError(f"unknown intrinsics keys {sorted(unknown)}; known: {sorted(known)}")
        missing = known - {"dist"} - set(data)
        if missing:
            raise ConfigError(f"intrinsics lack {sorted(missing)}")
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
            raise ConfigError(f"intrinsics values must be numbers: {exc}") from exc


@dataclass
class Frame:
    """Aligned colour and depth from one instant.

    color: (H, W, 3) uint8 in OpenCV's BGR order.
    depth_m: (H, W) float32 metres along the optical axis, aligned pixel for pixel with colour;
        0 where the camera has no reading. None when the source has no depth (plain images).
    """

    color: NDArray[np.uint8]
    depth_m: NDArray[np.float32] | None
    intrinsics: Intrinsics
    timestamp_s: float
    index: int = 0

    def __post_init__(self) -> None:
        c = self.color
        if c.dtype != np.uint8 or c.ndim != 3 or c.shape[2] != 3:
            raise SourceError(f"colour must be (H, W, 3) uint8, got {c.shape} {c.dtype}")
        h, w = c.shape[:2]
        if (w, h) != (self.intrinsics.width, self.intrinsics.height):
            raise SourceError(
                f"colour is {w}x{h} but the intrinsics are for "
                f"{self.intrinsics.width}x{self.intrinsics.height}"
            )
        if self.depth_m is not None:
            d = self.depth_m
            if d.shape != (h, w):
                raise SourceError(f"depth {d.shape} does not match colour {(h, w)}")
            if d.dtype != np.float32:
                self.depth_m = d.astype(np.float32)

    @property
    def size(self) -> tuple[int, int]:
        """(width, height)."""
        return self.intrinsics.width, self.intrinsics.height


DEPTH_UNIT_M = 0.001
"""Depth on disk and on the wire is uint16 millimetres, as the D435 reports it (scale 0.001)."""


def depth_to_mm(depth_m: NDArray[np.float32]) -> NDArray[np.uint16]:
    """Metres to uint16 millimetres; invalid (<= 0, NaN) and beyond 65.535 m become 0."""
    d = np.nan_to_num(np.asarray(depth_m, dtype=np.float64), nan=0.0, posinf=0.0, neginf=0.0)
    mm = np.rint(d / DEPTH_UNIT_M)
    mm[(mm <= 0) | (mm > 65535)] = 0
    return mm.astype(np.uint16)


def depth_from_mm(depth_mm: NDArray[np.uint16]) -> NDArray[np.float32]:
    return (np.asarray(depth_mm).astype(np.float32)) * np.float32(DEPTH_UNIT_M)
