"""The classical ring detector: colour mask, contours, shape tests.

A ring is a purple blob of roughly elliptical outline whose pixels fill a good part of its box,
usually with a hole. Blobs are tested for area, aspect, fill ratio, solidity and how saturated
their purple is; with depth, also for a ring's physical width (box width times depth over fx).

Rings that touch merge into one blob. With the camera model (intrinsics and mount) the detector
knows how big one ring lying on the floor looks at the blob's place (its depth from the depth
image, or from the floor plane without depth); a blob too wide or too tall for one ring is split
into (blob area / one ring's area) rings by k-means over its pixels, seeded at its holes when it
has one hole per ring. Without the camera model only holes split blobs.
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import Intrinsics
from jetson.errors import CameraConfigError
from jetson.perception.camera import CameraConfig
from jetson.perception.detection import RING_MINOR_M, RING_OUTER_M, Detection
from jetson.perception.prefilter import HsvWindow

RING_FILL = 0.7  # a flat ring's pixels over (expected width x expected height), measured
MAX_SPLIT = 12


@dataclass(frozen=True)
class ClassicalConfig:
    window: HsvWindow = field(default_factory=HsvWindow)
    reference_width: int = 640  # pixel sizes below are for this image width and scale with it
    min_area_px: float = 150.0  # blob pixels: a ring 3 m away covers ~200 at 640x480
    max_area_fraction: float = 0.25  # of the image: bigger is a wall or a lit room, not a ring
    min_side_px: float = 4.0
    aspect_range: tuple[float, float] = (0.2, 5.0)  # box width / height
    fill_range: tuple[float, float] = (0.4, 0.97)  # blob pixels / box area
    min_solidity: float = 0.65  # blob area / convex hull area
    # Median saturation of the blob's pixels: real rings sit well inside the window (5 % of
    # the labelled BLRSAI rings are below 71), washed-out purple-grey surfaces near its edge.
    min_median_saturation: float = 60.0
    min_hole_fraction: float = 0.01  # a hole smaller than this fraction of its blob is noise
    width_m_range: tuple[float, float] = (0.035, 0.17)  # physical box width, when depth exists
    close_px: int = 3  # closing kernel that heals shading cracks

    def __post_init__(self) -> None:
        if self.min_area_px <= 0 or self.reference_width <= 0:
            raise CameraConfigError("min_area_px and reference_width must be positive")
        for name in ("aspect_range", "fill_range", "width_m_range"):
            lo, hi = getattr(self, name)
            if not 0 < lo < hi:
                raise CameraConfigError(f"{name} must be 0 < low < high, got {(lo, hi)}")

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)


@dataclass
class _Blob:
    box: tuple[int, int, int, int]  # x, y, w, h
    area: float
    solidity: float
    holes: list[NDArray[np.int32]]
    contour: NDArray[np.int32]


class ClassicalDetector:
    """`camera`: the camera model for the ring-size prior (see the module's doc); leave it out
    for photos from unknown cameras."""

    name = "classical"

    def __init__(
        self, config: ClassicalConfig | None = None, camera: CameraConfig | None = None
    ) -> None:
        self.config = config or ClassicalConfig()
        self.camera = camera

    def detect(
        self,
        bgr: NDArray[np.uint8],
        depth_m: NDArray[np.float32] | None = None,
        colour_mask: NDArray[np.uint8] | None = None,
    ) -> list[Detection]:
        cfg = self.config
        h, w = bgr.shape[:2]
        scale = w / cfg.reference_width
        hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
        if colour_mask is None:
            lo, hi = cfg.window.bounds()
            colour_mask = cv2.inRange(hsv, lo, hi)
        mask = colour_mask
        # Opening drops sensor-noise speckles before closing could join them into blobs.
        mask = _open(mask, 2)
        k = max(1, round(cfg.close_px * scale))
        if k > 1:
            mask = _close(mask, k)
        contours, hierarchy = cv2.findContours(mask, cv2.RETR_CCOMP, cv2.CHAIN_APPROX_SIMPLE)
        if hierarchy is None:
            return []
        min_area = cfg.min_area_px * scale * scale
        intr = self.camera.intrinsics.scaled(w, h) if self.camera is not None else None
        out: list[Detection] = []
        for blob in _blobs(contours, hierarchy[0], cfg.min_hole_fraction):
            if blob.area < min_area or blob.area > cfg.max_area_fraction * w * h:
                continue
            if _median_saturation(blob, hsv, mask) < cfg.min_median_saturation:
                continue
            z = _blob_depth(blob, mask, depth_m) if depth_m is not None else None
            expected = self._expected_size(blob, z, intr)
            for det in _split(blob, mask, expected, cfg.min_solidity):
                if self._plausible(det, mask, z, intr, min_area, scale):
                    out.append(det)
        out.sort(key=lambda d: d.score, reverse=True)
        return out

    def _expected_size(
        self, blob: _Blob, z: float | None, intr: Intrinsics | None
    ) -> tuple[float, float] | None:
        """(width, height) in pixels of one ring lying flat where the blob is, or None."""
        if self.camera is None or intr is None:
            return None
        x, y, bw, bh = blob.box
        mount = self.camera.mount
        u, v = x + bw / 2, y + bh / 2
        ray_cam = np.array([(u - intr.cx) / intr.fx, (v - intr.cy) / intr.fy, 1.0])
        ray = ray_cam @ mount.robot_to_camera
        unit = ray / np.linalg.norm(ray)
        if z is None:
            # No depth: assume the ring lies on the floor and intersect the ray with it.
            if ray[2] >= -1e-6:
                return None
            z = (RING_MINOR_M - mount.height_m) / ray[2]
        if z <= 0.05:
            return None
        elev = math.asin(min(1.0, max(0.0, -unit[2])))
        w_px = intr.fx * RING_OUTER_M / z
        h_px = intr.fy * (RING_OUTER_M * math.sin(elev) + 2 * RING_MINOR_M * math.cos(elev)) / z
        return w_px, h_px

    def _plausible(
        self,
        det: Detection,
        mask: NDArray[np.uint8],
        z: float | None,
        intr: Intrinsics | None,
        min_area: float,
        scale: float,
    ) -> bool:
        cfg = self.config
        bw, bh = det.width, det.height
        if min(bw, bh) < cfg.min_side_px * scale:
            return False
        x0, y0, x1, y1 = (round(v) for v in (det.x0, det.y0, det.x1, det.y1))
        h, w = mask.shape
        # A ring cut by the image's edge has any aspect, fill and width; its area still counts.
        at_edge = x0 <= 0 or y0 <= 0 or x1 >= w or y1 >= h
        filled = float(np.count_nonzero(mask[y0:y1, x0:x1]))
        if filled < min_area:
            return False
        if at_edge:
            return True
        if not cfg.aspect_range[0] <= bw / bh <= cfg.aspect_range[1]:
            return False
        if not cfg.fill_range[0] <= filled / (bw * bh) <= cfg.fill_range[1]:
            return False
        if z is not None and intr is not None:
            width_m = bw * z / intr.fx
            lo, hi = cfg.width_m_range
            # A ring hidden in part behind another is narrower than it is, never wider.
            if width_m > hi or width_m < lo * 0.5:
                return False
        return True


def _blobs(
    contours: tuple[NDArray[np.int32], ...], hierarchy: NDArray[np.int32], min_hole: float
) -> list[_Blob]:
    """Outer contours with their holes (RETR_CCOMP: next, prev, first child, parent)."""
    out = []
    for i, c in enumerate(contours):
        if hierarchy[i][3] != -1:
            continue
        outer_area = cv2.contourArea(c)
        if outer_area <= 0:
            continue
        holes = []
        hole_area = 0.0
        child = hierarchy[i][2]
        while child != -1:
            a = cv2.contourArea(contours[child])
            if a >= min_hole * outer_area:
                holes.append(contours[child])
                hole_area += a
            child = hierarchy[child][0]
        hull = cv2.contourArea(cv2.convexHull(c))
        solidity = outer_area / hull if hull > 0 else 0.0
        out.append(_Blob(cv2.boundingRect(c), outer_area - hole_area, solidity, holes, c))
    return out


def _split(
    blob: _Blob,
    mask: NDArray[np.uint8],
    expected: tuple[float, float] | None,
    min_solidity: float,
) -> list[Detection]:
    """One blob into one box per ring it holds.

    The count comes from the blob's area over one ring's expected area when the camera model
    gives that, and from its holes otherwise; pixels are then clustered (k-means seeded at the
    holes when there are as many holes as rings), each cluster giving a box.
    """
    x, y, bw, bh = blob.box
    hole_bonus = 0.25 if blob.holes else 0.0
    score = float(np.clip(0.45 + hole_bonus + 0.3 * blob.solidity, 0.0, 1.0))
    n = len(blob.holes)
    if expected is not None:
        ring_area = RING_FILL * expected[0] * expected[1]
        by_area = round(blob.area / ring_area) if ring_area > 0 else 1
        # Only trust the area when the blob is also too wide or too tall for one ring.
        too_big = bw > 1.4 * expected[0] or bh > 1.4 * expected[1]
        n = max(n, min(by_area, MAX_SPLIT)) if too_big else n
    if n < 2:
        if blob.solidity < min_solidity:
            return []
        return [Detection(x, y, x + bw, y + bh, score)]
    local = np.zeros((bh, bw), np.uint8)
    cv2.drawContours(local, [blob.contour - np.array([x, y])], -1, 255, cv2.FILLED)
    local &= mask[y : y + bh, x : x + bw]
    ys, xs = np.nonzero(local)
    if xs.size < n:
        return [Detection(x, y, x + bw, y + bh, score)]
    px = np.stack([xs, ys], axis=1).astype(np.float32) + np.float32(0.5)
    # The centres are found on at most ~600 of the blob's pixels (a regular subsample keeps
    # the shape), which keeps a big cluster of rings within a millisecond; every pixel is then
    # given to its nearest centre.
    sample = px[:: max(1, len(px) // 600)]
    if len(blob.holes) == n:
        centres = np.array([_centre(hc) - (x, y) for hc in blob.holes], dtype=np.float32)
    else:
        centres = _kmeans(sample, n)
    for _ in range(4):  # a few Lloyd steps from the seeds
        owner = np.argmin(((sample[:, None, :] - centres[None, :, :]) ** 2).sum(-1), axis=1)
        centres = np.array(
            [
                sample[owner == k].mean(axis=0) if np.any(owner == k) else centres[k]
                for k in range(n)
            ],
            dtype=np.float32,
        )
    owner = np.argmin(((px[:, None, :] - centres[None, :, :]) ** 2).sum(-1), axis=1)
    dets = []
    for k in range(n):
        sel = px[owner == k]
        if len(sel) == 0:
            continue
        x0, y0 = np.floor(sel.min(axis=0))
        x1, y1 = np.ceil(sel.max(axis=0))
        dets.append(Detection(float(x0 + x), float(y0 + y), float(x1 + x), float(y1 + y), score))
    return dets


def _centre(contour: NDArray[np.int32]) -> NDArray[np.float64]:
    bx, by, bw, bh = cv2.boundingRect(contour)
    return np.array([bx + bw / 2, by + bh / 2])


def _kmeans(px: NDArray[np.float32], n: int) -> NDArray[np.float32]:
    criteria = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 20, 0.5)
    # A fixed seed keeps detections deterministic frame to frame.
    cv2.setRNGSeed(12345)
    _, _, centres = cv2.kmeans(px, n, None, criteria, 2, cv2.KMEANS_PP_CENTERS)
    return centres.astype(np.float32)


def _blob_depth(blob: _Blob, mask: NDArray[np.uint8], depth_m: NDArray[np.float32]) -> float | None:
    x, y, bw, bh = blob.box
    d = depth_m[y : y + bh, x : x + bw][mask[y : y + bh, x : x + bw] > 0]
    d = d[d > 0]
    return float(np.median(d)) if d.size >= 5 else None


def _median_saturation(blob: _Blob, hsv: NDArray[np.uint8], mask: NDArray[np.uint8]) -> float:
    x, y, bw, bh = blob.box
    s = hsv[y : y + bh, x : x + bw, 1][mask[y : y + bh, x : x + bw] > 0]
    return float(np.median(s)) if s.size else 0.0


# Even-sized kernels are centred between pixels, so OpenCV's morphologyEx (one anchor for both
# passes) shifts the result by a pixel; the second pass uses the mirrored anchor to cancel that.
def _open(mask: NDArray[np.uint8], k: int) -> NDArray[np.uint8]:
    kernel = np.ones((k, k), np.uint8)
    a, b = k // 2, k - 1 - k // 2
    return cv2.dilate(cv2.erode(mask, kernel, anchor=(a, a)), kernel, anchor=(b, b))


def _close(mask: NDArray[np.uint8], k: int) -> NDArray[np.uint8]:
    kernel = np.ones((k, k), np.uint8)
    a, b = k // 2, k - 1 - k // 2
    return cv2.erode(cv2.dilate(mask, kernel, anchor=(a, a)), kernel, anchor=(b, b))
