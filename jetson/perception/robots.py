"""The classical robot detector: alliance-coloured licence plates, their points in 3D, a plate's
shape, and the robot behind it.

VEX robots carry licence plates in their alliance's colour (red or blue) on two opposite sides;
the twin's robots carry one, across the front (sim/world/physics.py). The detector
masks both colours in HSV (the goal detector's windows: jetson/perception/goals.py), keeps blobs
big enough for a plate at the camera's range, and places each blob's pixels with a depth reading
in the robot frame through the camera model (jetson.autonomy.camera: the one pinhole model and
mount). A blob holds a plate only where those points are shaped like one:

- off the floor: most of its points between `min_height_m` and `max_height_m` (a goal's base,
  a platform's board and the tape lie lower);
- a strip standing up: across the ray at least `min_width_m` wide (an alliance goal's post is a
  few centimetres), no taller than `max_tall_m` (the post rises half a metre), and thin across
  its own line (`max_thickness_m`: a board or a floor patch is wide both ways).

The robot stands behind the plate: its middle is the plate's middle moved, away from the camera
along the plate's normal, by half the robot's depth, taken as the plate's length over
`plate_share` (a square robot whose plate spans that share of its side). The report is
(N, 3): x, y robot frame (metres, x right, y forward) and the alliance's code
(ROBOT_ALLIANCE_CODES). A robot seen side on (in the twin, or from behind) shows no plate and is
not reported; the camera, which looks down at the floor for rings, sees plates within about 2 m.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import Intrinsics
from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES
from jetson.perception.blobs import colour_blobs, image_intrinsics, robot_points
from jetson.perception.camera import CameraConfig
from jetson.perception.goals import colour_windows
from jetson.perception.prefilter import HsvWindow

# A robot's alliance as its plate's colour: the goal colour codes' red and blue, so one code
# means one colour whatever was seen (jetson.decide reads the robots' codes with them).
ROBOT_ALLIANCE_CODES = {name: GOAL_COLOUR_CODES[name] for name in ("red", "blue")}


def _plate_windows() -> dict[str, tuple[HsvWindow, ...]]:
    windows = colour_windows()
    return {name: windows[name] for name in ROBOT_ALLIANCE_CODES}


@dataclass(frozen=True)
class RobotDetectorConfig:
    windows: dict[str, tuple[HsvWindow, ...]] = field(default_factory=_plate_windows)
    reference_width: int = 640  # min_area_px is for this image width and scales with it
    min_area_px: float = 300.0
    open_px: int = 3
    min_points: int = 12
    min_height_m: float = 0.09  # above a goal's base (3 in) and a lowered board
    max_height_m: float = 0.45
    min_width_m: float = 0.15  # a plate's length, not a goal's post
    min_cut_width_m: float = 0.05  # the same for a plate the image's side cuts
    nominal_plate_m: float = 0.45  # a cut plate's length (a 15" robot's 0.34, a 24"'s 0.55)
    max_tall_m: float = 0.2
    max_thickness_m: float = 0.08
    plate_share: float = 0.9  # of the robot's side its plate spans

    def __post_init__(self) -> None:
        unknown = set(self.windows) - set(ROBOT_ALLIANCE_CODES)
        if unknown:
            raise ValueError(f"plate colours must be among {sorted(ROBOT_ALLIANCE_CODES)}")
        if not 0 < self.plate_share <= 1 or self.min_area_px <= 0:
            raise ValueError("plate_share must be in (0, 1] and min_area_px > 0")


@dataclass(frozen=True)
class RobotSighting:
    alliance: str
    x: float  # the robot's middle, robot frame, metres
    y: float
    plate_x: float  # the plate's middle
    plate_y: float
    plate_m: float  # the plate's length


class RobotDetector:
    """Robots in one colour image with its aligned depth image (metres, 0 where unknown)."""

    def __init__(self, camera: CameraConfig, config: RobotDetectorConfig | None = None) -> None:
        self.camera = camera
        self.config = config or RobotDetectorConfig()

    def detect(
        self,
        bgr: NDArray[np.uint8],
        depth_m: NDArray[np.float32],
        intrinsics: Intrinsics | None = None,
    ) -> list[RobotSighting]:
        cfg = self.config
        w = bgr.shape[1]
        intr = image_intrinsics(self.camera, intrinsics, w, bgr.shape[0])
        out: list[RobotSighting] = []
        for blob in colour_blobs(
            bgr, depth_m, cfg.windows, cfg.min_area_px, cfg.open_px, cfg.reference_width
        ):
            if len(blob.uv) < cfg.min_points:
                continue
            points = robot_points(self.camera, blob.uv, blob.depth_m, intr)
            x0, _, x1, _ = blob.box
            cut = (x0 < 1, x1 > w - 1)  # the blob runs off the image's left, right side
            sighting = self.plate(blob.colour, points, cut)
            if sighting is not None:
                out.append(sighting)
        return out

    def plate(
        self,
        alliance: str,
        points: NDArray[np.float64],
        cut: tuple[bool, bool] = (False, False),
    ) -> RobotSighting | None:
        """The shape tests (the module's doc) on a blob's points (N, 3), robot frame; `cut`:
        whether the image's left and right sides cut the blob (its length there is not the
        plate's: the end in view is, and the plate is taken as `nominal_plate_m` long)."""
        cfg = self.config
        z = points[:, 2]
        up = (z >= cfg.min_height_m) & (z <= cfg.max_height_m)
        if up.sum() < cfg.min_points or up.mean() < 0.8:
            return None
        pts = points[up]
        z_lo, z_hi = (float(q) for q in np.quantile(pts[:, 2], [0.03, 0.97]))
        if z_hi - z_lo > cfg.max_tall_m:
            return None
        xy = pts[:, :2]
        mid = np.median(xy, axis=0)
        # The plate's line: the main direction of its points on the floor.
        _, _, vt = np.linalg.svd(xy - xy.mean(axis=0), full_matrices=False)
        along, normal = vt[0], vt[1]
        cam = self.camera.mount.position[:2]
        ray = mid - cam
        if float(along @ np.array([ray[1], -ray[0]])) < 0:
            along = -along  # along the plate to the image's right, as u grows
        a = (xy - mid) @ along
        t = (xy - mid) @ normal
        a_lo, a_hi = (float(q) for q in np.quantile(a, [0.005, 0.995]))
        t_lo, t_hi = (float(q) for q in np.quantile(t, [0.03, 0.97]))
        length = a_hi - a_lo
        left, right = cut
        if length < (cfg.min_cut_width_m if left or right else cfg.min_width_m):
            return None
        if t_hi - t_lo > cfg.max_thickness_m:
            return None
        middle = (a_lo + a_hi) / 2
        if left or right:
            length = max(length, cfg.nominal_plate_m)
            if right and not left:
                middle = a_lo + length / 2
            elif left and not right:
                middle = a_hi - length / 2
        centre = mid + middle * along
        if float((centre - cam) @ normal) < 0:
            normal = -normal  # away from the camera: the robot is behind its plate
        robot = centre + normal * (length / cfg.plate_share) / 2
        return RobotSighting(
            alliance, float(robot[0]), float(robot[1]), float(centre[0]), float(centre[1]), length
        )

    @staticmethod
    def as_array(sightings: list[RobotSighting]) -> NDArray[np.float64]:
        """(N, 3): x, y robot frame and the alliance's code."""
        rows = [(s.x, s.y, ROBOT_ALLIANCE_CODES[s.alliance]) for s in sightings]
        return np.asarray(rows, dtype=np.float64).reshape(-1, 3)
