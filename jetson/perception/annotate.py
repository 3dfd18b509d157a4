"""Pictures of what perception saw: boxes on the image, and the rings seen from above.

Drawn with OpenCV only (the Jetson has no matplotlib).
"""

from __future__ import annotations

import math

import cv2
import numpy as np
from numpy.typing import NDArray

from jetson.perception.camera import CameraConfig
from jetson.perception.detection import Detection
from jetson.perception.localise import RingEstimate

GREEN = (60, 220, 60)
YELLOW = (0, 220, 255)
RING = (200, 80, 160)
GRID = (70, 70, 70)
TEXT = (235, 235, 235)


def draw_detections(
    bgr: NDArray[np.uint8], detections: list[Detection], rings: list[RingEstimate]
) -> NDArray[np.uint8]:
    """A copy of the image with every box, its confidence and, when placed, its distance."""
    out = bgr.copy()
    placed = {id(r.detection): r for r in rings}
    scale = max(0.35, out.shape[1] / 1280)
    for det in detections:
        ring = placed.get(id(det))
        colour = GREEN if ring is not None else YELLOW
        p0 = (round(det.x0), round(det.y0))
        p1 = (round(det.x1) - 1, round(det.y1) - 1)
        cv2.rectangle(out, p0, p1, colour, 1 if out.shape[1] < 500 else 2)
        label = f"{det.score:.2f}"
        if ring is not None:
            label += f" {ring.distance_m:.2f}m"
        (tw, th), _ = cv2.getTextSize(label, cv2.FONT_HERSHEY_SIMPLEX, scale, 1)
        y = max(th + 2, p0[1] - 3)
        cv2.rectangle(out, (p0[0], y - th - 2), (p0[0] + tw + 2, y + 2), (0, 0, 0), cv2.FILLED)
        cv2.putText(out, label, (p0[0] + 1, y), cv2.FONT_HERSHEY_SIMPLEX, scale, colour, 1)
    return out


def top_down(
    rings: list[RingEstimate],
    camera: CameraConfig,
    *,
    size_px: int = 480,
    range_m: float = 3.0,
    truth_xy: NDArray[np.float64] | None = None,
    title: str = "",
) -> NDArray[np.uint8]:
    """The robot frame from above: robot at the bottom centre facing up, 0.5 m grid, the
    camera's field of view, each placed ring with its distance; truth_xy as crosses."""
    img = np.full((size_px, size_px, 3), 25, np.uint8)
    margin = 30
    ppm = (size_px - 2 * margin) / range_m  # pixels per metre
    ox, oy = size_px / 2, size_px - margin  # robot centre

    def px(x: float, y: float) -> tuple[int, int]:
        return round(ox + x * ppm), round(oy - y * ppm)

    half = range_m / 2
    for k in np.arange(-math.floor(half / 0.5) * 0.5, half + 1e-9, 0.5):
        cv2.line(img, px(k, 0), px(k, range_m), GRID, 1)
    for k in np.arange(0, range_m + 1e-9, 0.5):
        cv2.line(img, px(-half, k), px(half, k), GRID, 1)
        cv2.putText(img, f"{k:.1f}", px(-half, k), cv2.FONT_HERSHEY_SIMPLEX, 0.35, TEXT, 1)
    # Field of view: the image's left and right edges projected onto the floor plane.
    intr, mount = camera.intrinsics, camera.mount
    half_fov = math.atan(intr.width / (2 * intr.fx))
    cam = (mount.right_m, mount.forward_m)
    for side in (-1, 1):
        far = (cam[0] + side * math.tan(half_fov) * range_m, cam[1] + range_m)
        cv2.line(img, px(*cam), px(*far), (110, 110, 40), 1)
    robot = 0.381 / 2
    cv2.rectangle(img, px(-robot, robot), px(robot, -robot), (160, 160, 160), 1)
    cv2.arrowedLine(img, px(0, 0), px(0, robot * 1.6), (160, 160, 160), 1, tipLength=0.3)
    if truth_xy is not None:
        for x, y in np.asarray(truth_xy).reshape(-1, 2):
            cv2.drawMarker(img, px(x, y), GREEN, cv2.MARKER_CROSS, 12, 1)
    radius = max(2, round(0.0508 * ppm))  # a ring is 4 in across
    for r in rings:
        x, y = r.robot_xy
        cv2.circle(img, px(x, y), radius, RING, 2)
        cv2.putText(
            img, f"{r.distance_m:.2f}", px(x + 0.07, y), cv2.FONT_HERSHEY_SIMPLEX, 0.35, TEXT, 1
        )
    if title:
        cv2.putText(img, title, (8, 18), cv2.FONT_HERSHEY_SIMPLEX, 0.45, TEXT, 1)
    return img
