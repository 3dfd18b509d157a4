"""Where a detected ring is in the robot frame, in metres.

Depth comes from the ring's own pixels, never the box centre, which on a ring is the hole (the
original team read the centre pixel and got the floor, or nothing, behind it). The ring's pixels
are those inside the box's inscribed ellipse but outside the ellipse of its hole (a ring's inner
diameter is half its outer), intersected with the colour mask when the mask keeps enough of them,
with a valid depth reading within a ring's size of their median depth (which drops floor and
background seen past the ring's edge).

Each of those pixels is back-projected with K^-1 (undistorted first when the camera has
distortion) at its own depth, and the camera mount takes the points to the robot frame (x right,
y forward, z up; see camera.py). The ring's centre is the middle of the points' extent on the
floor (3rd to 97th percentile in x and in y). Why not the box centre at the median depth: a camera
looking down sees the ring's top and its near side, so the median surface point is 2-3 cm nearer
than the centre (measured on synthetic rings); the extent's middle is off by a few millimetres.

The output, rings_robot_xy sorted nearest first, is what jetson.autonomy.spec.RobotView takes.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass

import cv2
import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import Intrinsics
from jetson.errors import CameraConfigError
from jetson.perception.camera import CameraConfig
from jetson.perception.detection import RING_MINOR_M, Detection


@dataclass(frozen=True)
class LocaliserConfig:
    hole_ratio: float = 0.55  # inner ellipse radius / outer: a ring's hole is half its diameter
    depth_window_m: float = 0.1  # ring pixels lie within a ring's diameter of the median depth
    extent_quantile: float = 0.03
    min_pixels: int = 6  # fewer valid ring pixels than this: no depth, the ring is not placed
    min_mask_pixels: int = 12  # the colour mask is used only when it keeps this many pixels
    near_m: float = 0.17  # D435 minimum range at 640x480 (REFERENCE section 5)
    max_range_m: float = 3.0  # beyond this the depth is too noisy to act on
    # Without depth (plain images) a ring can still be placed by intersecting its ray with the
    # floor; off by default because a ring on a goal or a platform is then placed wrongly.
    floor_fallback: bool = False

    def __post_init__(self) -> None:
        if not 0.0 <= self.hole_ratio < 1.0:
            raise CameraConfigError(f"hole_ratio must be in [0, 1), got {self.hole_ratio}")
        if not 0 < self.near_m < self.max_range_m:
            raise CameraConfigError("need 0 < near_m < max_range_m")

    def to_dict(self) -> dict[str, object]:
        return asdict(self)


@dataclass(frozen=True)
class RingEstimate:
    detection: Detection
    depth_m: float  # median depth of the ring's pixels, along the optical axis
    pixels: int  # ring pixels that gave the estimate (0 for the floor fallback)
    camera_xyz: tuple[float, float, float]
    robot_xy: tuple[float, float]  # x right, y forward, metres
    distance_m: float  # from the robot's centre of turning, on the floor
    method: str  # "depth" or "floor"


def annulus_mask(
    box: Detection, shape: tuple[int, int], hole_ratio: float
) -> tuple[tuple[slice, slice], NDArray[np.bool_]]:
    """The ring's expected pixels inside its box: inside the box's inscribed ellipse, outside
    the hole's. Returns the (clipped) window and the mask within it."""
    h, w = shape
    x0, y0 = max(0, int(np.floor(box.x0))), max(0, int(np.floor(box.y0)))
    x1, y1 = min(w, int(np.ceil(box.x1))), min(h, int(np.ceil(box.y1)))
    win = (slice(y0, max(y0, y1)), slice(x0, max(x0, x1)))
    if x1 <= x0 or y1 <= y0:
        return win, np.zeros((0, 0), dtype=bool)
    cx, cy = box.center
    ax, ay = max(box.width / 2, 0.5), max(box.height / 2, 0.5)
    xs = (np.arange(x0, x1) + 0.5 - cx) / ax
    ys = (np.arange(y0, y1) + 0.5 - cy) / ay
    r2 = xs[None, :] ** 2 + ys[:, None] ** 2
    return win, (r2 <= 1.0) & (r2 >= hole_ratio**2)


def ring_pixels(
    box: Detection,
    depth_m: NDArray[np.float32],
    colour_mask: NDArray[np.uint8] | None,
    config: LocaliserConfig,
) -> tuple[NDArray[np.float64], NDArray[np.float64]] | None:
    """The ring's own pixels (N, 2) as (u, v) and their depths (N,), or None when too few."""
    win, ann = annulus_mask(box, depth_m.shape, config.hole_ratio)
    if ann.size == 0:
        return None
    d = depth_m[win]
    valid = ann & (d >= config.near_m) & np.isfinite(d)
    if colour_mask is not None:
        coloured = valid & (colour_mask[win] > 0)
        if np.count_nonzero(coloured) >= config.min_mask_pixels:
            valid = coloured
    if np.count_nonzero(valid) < config.min_pixels:
        return None
    median = float(np.median(d[valid]))
    valid &= np.abs(d - median) <= config.depth_window_m
    if np.count_nonzero(valid) < config.min_pixels:
        return None
    ys, xs = np.nonzero(valid)
    uv = np.c_[xs + win[1].start + 0.0, ys + win[0].start + 0.0]
    return uv, d[valid].astype(np.float64)


def ring_depth(
    box: Detection,
    depth_m: NDArray[np.float32],
    colour_mask: NDArray[np.uint8] | None,
    config: LocaliserConfig,
) -> float | None:
    """Median depth of the ring's own pixels (see the module's doc), or None."""
    found = ring_pixels(box, depth_m, colour_mask, config)
    return None if found is None else float(np.median(found[1]))


def pixel_rays(points_uv: NDArray[np.float64], intr: Intrinsics) -> NDArray[np.float64]:
    """K^-1 [u, v, 1] for pixels (N, 2): optical-frame directions with z = 1."""
    uv = np.asarray(points_uv, dtype=np.float64).reshape(-1, 2)
    if intr.distorted:
        norm = cv2.undistortPoints(
            uv.reshape(-1, 1, 2), intr.matrix, np.asarray(intr.dist, dtype=np.float64)
        ).reshape(-1, 2)
    else:
        k_inv = np.linalg.inv(intr.matrix)
        norm = (np.c_[uv, np.ones(len(uv))] @ k_inv.T)[:, :2]
    return np.c_[norm, np.ones(len(norm))]


def back_project(u: float, v: float, depth_m: float, intr: Intrinsics) -> NDArray[np.float64]:
    """The optical-frame point at pixel (u, v) and depth (along the optical axis)."""
    return pixel_rays(np.array([[u, v]]), intr)[0] * depth_m


class Localiser:
    def __init__(self, camera: CameraConfig, config: LocaliserConfig | None = None) -> None:
        self.camera = camera
        self.config = config or LocaliserConfig()

    def localise(
        self,
        detections: list[Detection],
        depth_m: NDArray[np.float32] | None,
        colour_mask: NDArray[np.uint8] | None = None,
        intrinsics: Intrinsics | None = None,
    ) -> list[RingEstimate]:
        """Estimates for the detections that can be placed, nearest first.

        intrinsics: the frame's own (a RealSense or the simulator sends them); the camera
        config's by default. Either is scaled to the depth image when their sizes differ.
        """
        intr = intrinsics or self.camera.intrinsics
        if depth_m is not None and depth_m.shape != (intr.height, intr.width):
            intr = intr.scaled(depth_m.shape[1], depth_m.shape[0])
        cfg = self.config
        out = []
        for det in detections:
            est = self._one(det, depth_m, colour_mask, intr)
            if est is not None and est.distance_m <= cfg.max_range_m:
                out.append(est)
        out.sort(key=lambda e: e.distance_m)
        return out

    def _one(
        self,
        det: Detection,
        depth_m: NDArray[np.float32] | None,
        colour_mask: NDArray[np.uint8] | None,
        intr: Intrinsics,
    ) -> RingEstimate | None:
        mount = self.camera.mount
        cfg = self.config
        found = ring_pixels(det, depth_m, colour_mask, cfg) if depth_m is not None else None
        if found is not None:
            uv, d = found
            points = mount.camera_to_robot(pixel_rays(uv, intr) * d[:, None])
            q = cfg.extent_quantile
            lo = np.quantile(points[:, :2], q, axis=0)
            hi = np.quantile(points[:, :2], 1.0 - q, axis=0)
            x, y = (lo + hi) / 2.0
            z_ring = float(np.median(points[:, 2]))
            cam = mount.robot_to_camera_points(np.array([x, y, z_ring]))
            depth, n, method = float(np.median(d)), len(d), "depth"
        elif cfg.floor_fallback:
            u, v = det.center
            ray = pixel_rays(np.array([[u, v]]), intr)[0]
            ray_robot = ray @ mount.robot_to_camera
            if ray_robot[2] >= -1e-9:
                return None
            # The ring's centre is a tube radius above the floor.
            depth = (RING_MINOR_M - mount.height_m) / ray_robot[2]
            cam = ray * depth
            x, y = mount.camera_to_robot(cam)[:2]
            n, method = 0, "floor"
        else:
            return None
        return RingEstimate(
            detection=det,
            depth_m=float(depth),
            pixels=n,
            camera_xyz=(float(cam[0]), float(cam[1]), float(cam[2])),
            robot_xy=(float(x), float(y)),
            distance_m=float(np.hypot(x, y)),
            method=method,
        )


def rings_robot_xy(estimates: list[RingEstimate]) -> NDArray[np.float64]:
    """(N, 2) positions for jetson.autonomy.spec.RobotView.rings_robot_xy, nearest first."""
    return np.asarray([e.robot_xy for e in estimates], dtype=np.float64).reshape(-1, 2)
