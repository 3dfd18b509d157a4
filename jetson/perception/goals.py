"""The classical mobile-goal detector: colour masks, blobs, depth, the camera model.

A Tipping Point mobile goal stands on a large coloured base (a 13 in disc): yellow for the neutral
goals, red or blue for the alliance goals. The detector masks each colour in HSV, keeps blobs big
enough for a goal base at the camera's range, takes each blob's median depth (the depth image,
aligned to the colour image) and puts the blob's centre pixel at that depth through the camera
model (jetson.autonomy.camera: the one pinhole model and mount), giving the goal's place on the
floor in the robot frame. The report is what the scripted alliance reads
(jetson.autonomy.alliance.AllianceInputs.goals_robot): (N, 3) x, y robot frame (metres, x right,
y forward) and a colour code, COLOUR_CODES.

The daemon runs it in its perception pipeline when `[camera] goals` is on (jetson/perception/
pipeline.py); in the twin's own matches the goals come from geometry instead (sim/goal_sight.py),
while the full stack's daemon runs this detector on the twin's rendered frames. Not measured on
real photos: the HSV windows are first guesses for saturated field colours, checked on synthetic
images (tests/jetson/perception/test_goals.py) and the twin's renders; anything of a goal's colour
and size is a goal to it (a platform's edge, a bumper: jetson/perception/README.md, "Goals").
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import Intrinsics
from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES as COLOUR_CODES
from jetson.perception.camera import CameraConfig
from jetson.perception.localise import pixel_rays
from jetson.perception.prefilter import HsvWindow


def _default_windows() -> dict[str, tuple[HsvWindow, ...]]:
    # OpenCV hue runs 0-180: red wraps around 0, so it has two windows.
    return {
        "yellow": (HsvWindow((18.0, 35.0), (110.0, 255.0), (90.0, 255.0)),),
        "red": (
            HsvWindow((0.0, 8.0), (120.0, 255.0), (70.0, 255.0)),
            HsvWindow((172.0, 180.0), (120.0, 255.0), (70.0, 255.0)),
        ),
        "blue": (HsvWindow((100.0, 125.0), (120.0, 255.0), (50.0, 255.0)),),
    }


@dataclass(frozen=True)
class GoalDetectorConfig:
    windows: dict[str, tuple[HsvWindow, ...]] = field(default_factory=_default_windows)
    reference_width: int = 640  # min_area_px is for this image width and scales with it
    min_area_px: float = 400.0  # a goal base 3 m away covers ~1500 px at 640x480
    base_width_m_range: tuple[float, float] = (0.15, 0.6)  # the blob's physical width, with depth
    open_px: int = 3

    def __post_init__(self) -> None:
        unknown = set(self.windows) - set(COLOUR_CODES)
        if unknown:
            raise ValueError(f"goal colours must be among {sorted(COLOUR_CODES)}: {unknown}")
        lo, hi = self.base_width_m_range
        if self.min_area_px <= 0 or not 0 < lo < hi:
            raise ValueError("min_area_px > 0 and 0 < base width low < high")


@dataclass(frozen=True)
class GoalSighting:
    colour: str
    u: float  # the blob's centre pixel
    v: float
    depth_m: float
    x: float  # robot frame, metres
    y: float


class GoalDetector:
    """Goals in one colour image with its aligned depth image (metres, 0 where unknown)."""

    def __init__(self, camera: CameraConfig, config: GoalDetectorConfig | None = None) -> None:
        self.camera = camera
        self.config = config or GoalDetectorConfig()

    def detect(
        self,
        bgr: NDArray[np.uint8],
        depth_m: NDArray[np.float32],
        intrinsics: Intrinsics | None = None,
    ) -> list[GoalSighting]:
        """`intrinsics`: the frame's own (a RealSense and the simulator's stream send theirs);
        the camera config's by default. Either is scaled to the image's size."""
        cfg = self.config
        h, w = bgr.shape[:2]
        if depth_m.shape[:2] != (h, w):
            raise ValueError(f"depth image {depth_m.shape[:2]} is not the colour's {(h, w)}")
        intr = intrinsics or self.camera.intrinsics
        if (intr.width, intr.height) != (w, h):
            intr = intr.scaled(w, h)
        scale = w / cfg.reference_width
        hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
        kernel = np.ones((cfg.open_px, cfg.open_px), np.uint8)
        out: list[GoalSighting] = []
        for colour, windows in cfg.windows.items():
            mask = np.zeros((h, w), np.uint8)
            for win in windows:
                lo, hi = win.bounds()
                mask |= cv2.inRange(hsv, lo, hi)
            mask = cv2.morphologyEx(mask, cv2.MORPH_OPEN, kernel)
            n, labels, stats, centroids = cv2.connectedComponentsWithStats(mask)
            for k in range(1, n):
                if stats[k, cv2.CC_STAT_AREA] < cfg.min_area_px * scale * scale:
                    continue
                pix = labels == k
                d = depth_m[pix]
                d = d[np.isfinite(d) & (d > 0)]
                if not len(d):
                    continue
                z = float(np.median(d))
                width_m = stats[k, cv2.CC_STAT_WIDTH] * z / intr.fx
                lo_w, hi_w = cfg.base_width_m_range
                if not lo_w <= width_m <= hi_w:
                    continue
                u, v = (float(c) for c in centroids[k])
                point = self.camera.mount.camera_to_robot(pixel_rays(np.array([[u, v]]), intr) * z)
                out.append(GoalSighting(colour, u, v, z, float(point[0, 0]), float(point[0, 1])))
        return out


def goals_robot(sightings: list[GoalSighting]) -> NDArray[np.float64]:
    """Sightings as the strategy reads them: (N, 3) x, y robot frame and colour code."""
    return np.array(
        [(s.x, s.y, COLOUR_CODES[s.colour]) for s in sightings], dtype=np.float64
    ).reshape(-1, 3)
