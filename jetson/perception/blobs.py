"""Coloured blobs with depth: what the classical goal and robot detectors start from.

Each colour's HSV windows make a mask (opened to drop specks), whose connected blobs big enough
(`min_area_px` at `reference_width`, scaled with the image's width) are kept with their pixels
that have a depth reading (finite, positive). jetson/perception/goals.py and robots.py test the
blobs' shapes in 3D; this finds them, once, for both, and places their pixels in the robot
frame (`robot_points`, at the image's own intrinsics: `image_intrinsics`).
"""

from __future__ import annotations

from collections.abc import Iterator, Mapping
from dataclasses import dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import Intrinsics
from jetson.perception.camera import CameraConfig
from jetson.perception.localise import pixel_rays
from jetson.perception.prefilter import HsvWindow


@dataclass(frozen=True)
class Blob:
    colour: str
    box: tuple[int, int, int, int]  # x0, y0, x1, y1 (exclusive) of the blob in the image
    centroid: tuple[float, float]  # u, v of all its pixels
    uv: NDArray[np.float64]  # (N, 2) its pixels with depth, image coordinates
    depth_m: NDArray[np.float64]  # (N,) their depths

    @property
    def local(self) -> tuple[NDArray[np.int64], NDArray[np.int64]]:
        """The pixels with depth as rows and columns within the blob's box."""
        x0, y0, _, _ = self.box
        return (self.uv[:, 1] - y0).astype(np.int64), (self.uv[:, 0] - x0).astype(np.int64)


def image_intrinsics(
    camera: CameraConfig, intrinsics: Intrinsics | None, width: int, height: int
) -> Intrinsics:
    """The frame's own intrinsics (a RealSense and the simulator's stream send theirs) or the
    camera config's, scaled to the image's size."""
    intr = intrinsics or camera.intrinsics
    return intr if (intr.width, intr.height) == (width, height) else intr.scaled(width, height)


def robot_points(
    camera: CameraConfig, uv: NDArray[np.float64], depth: NDArray[np.float64], intr: Intrinsics
) -> NDArray[np.float64]:
    """Pixels (N, 2) at their depths (N,) -> points (N, 3), robot frame, z up."""
    return camera.mount.camera_to_robot(pixel_rays(uv, intr) * depth[:, None])


def colour_blobs(
    bgr: NDArray[np.uint8],
    depth_m: NDArray[np.float32],
    windows: Mapping[str, tuple[HsvWindow, ...]],
    min_area_px: float,
    open_px: int = 3,
    reference_width: int = 640,
) -> Iterator[Blob]:
    """Every blob of each colour at least min_area_px big (scaled from reference_width) with at
    least one pixel with depth."""
    h, w = bgr.shape[:2]
    if depth_m.shape[:2] != (h, w):
        raise ValueError(f"depth image {depth_m.shape[:2]} is not the colour's {(h, w)}")
    scale = w / reference_width
    hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
    kernel = np.ones((open_px, open_px), np.uint8)
    for colour, wins in windows.items():
        mask = np.zeros((h, w), np.uint8)
        for win in wins:
            lo, hi = win.bounds()
            mask |= cv2.inRange(hsv, lo, hi)
        mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
        n, labels, stats, centroids = cv2.connectedComponentsWithStats(mask)
        for k in range(1, n):
            if stats[k, cv2.CC_STAT_AREA] < min_area_px * scale * scale:
                continue
            x0, y0 = int(stats[k, cv2.CC_STAT_LEFT]), int(stats[k, cv2.CC_STAT_TOP])
            x1 = x0 + int(stats[k, cv2.CC_STAT_WIDTH])
            y1 = y0 + int(stats[k, cv2.CC_STAT_HEIGHT])
            vs, us = np.nonzero(labels[y0:y1, x0:x1] == k)
            d = depth_m[vs + y0, us + x0]
            ok = np.isfinite(d) & (d > 0)
            if not ok.any():
                continue
            uv = np.column_stack([us[ok] + x0, vs[ok] + y0]).astype(np.float64)
            u, v = (float(c) for c in centroids[k])
            yield Blob(colour, (x0, y0, x1, y1), (u, v), uv, d[ok].astype(np.float64))
