"""One camera frame: aligned colour and depth, the colour camera's intrinsics, a timestamp."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import Intrinsics
from jetson.errors import SourceError


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
