"""The classical mobile-goal detector: colour masks, blobs, each blob's points in 3D, shape tests.

A Tipping Point mobile goal stands on a large coloured base (at most 13 in across, 3 in high):
yellow for the neutral goals, red or blue for the alliance goals. The detector masks each colour
in HSV and keeps blobs big enough for a goal base at the camera's range. Each blob's pixels with a
depth reading (the depth image, aligned to the colour image) are placed in the robot frame through
the camera model (jetson.autonomy.camera: the one pinhole model and mount), and the blob holds a
goal only where those points are shaped like a base standing on the floor:

- on the floor: its points no higher than a base (and a margin) are the base; the goal's post,
  of the same colour, rises above it and is left out. A blob with too few of them (an
  alliance-coloured bumper or plate on a robot, all above that height) holds none; the base
  parts that are apart in the image once the posts are left out are tested one by one (a goal
  behind another, the nearer one's post across its base);
- one base: across the camera's ray at least part of a base's diameter wide, along it part of a
  base deep (the camera sees its top from above), and nearly all its points within a radius (and
  a margin) of its middle. A piece of a platform of a goal's colour (the twin's platforms are the
  alliance goals' red and blue), bigger than a base or thin, leaves points outside;
- in view: a base running off more of the image's edges than `max_cut_edges` is not tested (no
  telling it from something bigger, such as a piece of a platform of its colour); a yellow one
  may run off two (`max_cut_edges_yellow`: nothing else on the field is yellow, and a neutral
  goal at the robot's front corner runs off the image's bottom and a side). One whose middle is
  out of view is not reported, as the twin's geometric sighting (sim/goal_sight.py) does not
  report it.

The middle is a base radius beyond the base's near face along the ray (the camera never sees its
far side from below; when the image's bottom cuts the near face, a radius before its top's far
edge), across the ray the middle of its points (a radius in from the side the image cuts). It is
where the goal is reported: the report is what the scripted alliance reads
(jetson.autonomy.alliance.AllianceInputs.goals_robot): (N, 3) x, y robot frame (metres, x right,
y forward) and a colour code, COLOUR_CODES (jetson/autonomy/goal_colours.py).

It knows nothing of where the robot is: the scripted decider, which knows the pose, drops the
sightings on a platform's footprint (jetson/autonomy/goal_sightings.py), which the shape tests
can let through when the image's edge cuts a piece of a platform to a base's size.

The daemon runs it in its perception pipeline when `[camera] goals` is on (jetson/perception/
pipeline.py); in the twin's own matches the goals come from geometry instead (sim/goal_sight.py),
while the full stack's daemon runs this detector on the twin's rendered frames
(`python -m sim.goal_survey` measures it there). Not measured on real photos: the HSV windows are
first guesses for saturated field colours, the shape tests' numbers are chosen on the twin's
renders (disc bases, depth without noise), and a real base is a heptagon.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import Intrinsics, project_points
from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES as COLOUR_CODES
from jetson.perception.blobs import colour_blobs, image_intrinsics, robot_points
from jetson.perception.camera import CameraConfig
from jetson.perception.prefilter import HsvWindow

INCH = 0.0254


def colour_windows() -> dict[str, tuple[HsvWindow, ...]]:
    """The HSV windows of the field's colours: yellow goals; red and blue goals and plates."""
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
    windows: dict[str, tuple[HsvWindow, ...]] = field(default_factory=colour_windows)
    reference_width: int = 640  # min_area_px is for this image width and scales with it
    min_area_px: float = 400.0  # a goal base 3 m away covers ~1500 px at 640x480
    open_px: int = 3
    base_radius_m: float = 6.5 * INCH  # the manual: a base at most 13 in across
    base_height_m: float = 3.0 * INCH
    # The shape tests (the module's doc), on the blob's points in the robot frame:
    height_margin_m: float = 0.03  # a base's point is no higher than the base and this
    min_base_points: int = 12  # fewer of them: no base
    min_width: float = 0.45  # across the ray, at least this share of the base's diameter
    min_depth: float = 0.5  # along the ray (its top seen from above), this share of it
    disc_margin_m: float = 0.06  # a base's point lies within its radius and this of its middle
    min_inside: float = 0.9  # the share of the base's points that must
    max_cut_edges: int = 1  # a base running off more of the image's edges is not tested
    # The same for a yellow (neutral) base that runs off the image's bottom and a side (a goal
    # at the robot's front corner): nothing else on the field is yellow, so it is placed from
    # the part in view.
    max_cut_edges_yellow: int = 2

    def __post_init__(self) -> None:
        unknown = set(self.windows) - set(COLOUR_CODES)
        if unknown:
            raise ValueError(f"goal colours must be among {sorted(COLOUR_CODES)}: {unknown}")
        if self.min_area_px <= 0 or self.base_radius_m <= 0 or self.base_height_m <= 0:
            raise ValueError("min_area_px, base_radius_m and base_height_m must be > 0")
        if not (0 < self.min_inside <= 1 and 0 <= self.min_width <= 1 and 0 <= self.min_depth <= 1):
            raise ValueError("min_inside in (0, 1], min_width and min_depth in [0, 1]")


@dataclass(frozen=True)
class GoalSighting:
    colour: str
    u: float  # the base's pixels' middle
    v: float
    depth_m: float  # their median depth
    x: float  # the base's middle, robot frame, metres
    y: float


@dataclass(frozen=True)
class BlobShape:
    """What the shape tests made of one blob (GoalDetector.blobs): `goal` is the verdict and
    `why` the first test it failed ("" for a goal)."""

    goal: bool
    why: str
    x: float = float("nan")  # the base's middle, robot frame
    y: float = float("nan")
    width_m: float = 0.0  # the base's points across the ray
    depth_m: float = 0.0  # and along it
    inside: float = 0.0  # the share of the base's points within a radius of the middle
    edges: str = ""  # the image's edges the base's pixels run off: "left", "top,right"...


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
        return [s for s, shape in self.blobs(bgr, depth_m, intrinsics) if shape.goal]

    def blobs(
        self,
        bgr: NDArray[np.uint8],
        depth_m: NDArray[np.float32],
        intrinsics: Intrinsics | None = None,
    ) -> list[tuple[GoalSighting, BlobShape]]:
        """Every blob big enough for a base, with what the shape tests made of it (the goals
        and the rest: what sim.goal_survey counts)."""
        cfg = self.config
        h, w = bgr.shape[:2]
        intr = image_intrinsics(self.camera, intrinsics, w, h)
        out: list[tuple[GoalSighting, BlobShape]] = []
        for blob in colour_blobs(
            bgr, depth_m, cfg.windows, cfg.min_area_px, cfg.open_px, cfg.reference_width
        ):
            colour, uv, z = blob.colour, blob.uv, blob.depth_m
            x0, y0, x1, y1 = blob.box
            vs, us = blob.local
            height = robot_points(self.camera, uv, z, intr)[:, 2]
            low = height <= cfg.base_height_m + cfg.height_margin_m
            if low.sum() < cfg.min_base_points:
                u, v = blob.centroid
                nan = float("nan")
                sighting = GoalSighting(colour, u, v, float(np.median(z)), nan, nan)
                out.append((sighting, BlobShape(False, "above the floor")))
                continue
            # The blob's parts no higher than a base, apart in the image once the posts are
            # left out: two goals one behind the other (the nearer one's post across the
            # farther one's base) are two bases.
            part = np.zeros((y1 - y0, x1 - x0), np.uint8)
            part[vs[low], us[low]] = 255
            m, parts = cv2.connectedComponents(part)
            of = parts[vs[low], us[low]]
            for j in range(1, m):
                mine = of == j
                if mine.sum() < cfg.min_base_points:
                    continue
                puv, pz = uv[low][mine], z[low][mine]
                shape = self.shape(puv, pz, intr, colour)
                u, v = (float(c) for c in puv.mean(axis=0))
                sighting = GoalSighting(colour, u, v, float(np.median(pz)), shape.x, shape.y)
                out.append((sighting, shape))
        return out

    def shape(
        self,
        uv: NDArray[np.float64],
        depth: NDArray[np.float64],
        intr: Intrinsics,
        colour: str = "red",
    ) -> BlobShape:
        """The shape tests (the module's doc) on a blob's pixels (N, 2) and their depths (N,),
        in an image of `intr`'s size."""
        cfg = self.config
        r = cfg.base_radius_m
        mount = self.camera.mount
        points = robot_points(self.camera, uv, depth, intr)
        low = points[:, 2] <= cfg.base_height_m + cfg.height_margin_m
        if low.sum() < cfg.min_base_points:
            return BlobShape(False, "above the floor")
        base, pix = points[low], uv[low]
        # The image's edges the base's pixels run off.
        cut = {
            "left": pix[:, 0].min() < 1,
            "right": pix[:, 0].max() > intr.width - 2,
            "top": pix[:, 1].min() < 1,
            "bottom": pix[:, 1].max() > intr.height - 2,
        }
        edges = ",".join(k for k, v in cut.items() if v)
        # A yellow base may run off the bottom and one side (a goal at the robot's front corner).
        corner = cut["bottom"] and not cut["top"] and not (cut["left"] and cut["right"])
        limit = cfg.max_cut_edges_yellow if colour == "yellow" and corner else cfg.max_cut_edges
        if sum(cut.values()) > limit:
            return BlobShape(False, "cut by the image", edges=edges)
        # The ray from the camera to the blob, on the floor: along it (s) and across it (a, to
        # the right, as the image's u grows).
        cam = mount.position[:2]
        rel = base[:, :2] - cam
        ray = np.median(rel, axis=0)
        ray = ray / max(float(np.hypot(*ray)), 1e-9)
        across = np.array([ray[1], -ray[0]])
        s, a = rel @ ray, rel @ across
        a_lo, a_hi = (float(q) for q in np.quantile(a, [0.03, 0.97]))
        width = a_hi - a_lo
        if cut["left"]:
            mid_a = a_hi - r
        elif cut["right"]:
            mid_a = a_lo + r
        else:
            mid_a = (a_lo + a_hi) / 2
            if width < cfg.min_width * 2 * r:
                return BlobShape(False, "too narrow", width_m=width, edges=edges)
        middle = np.abs(a - mid_a) <= r / 2
        s_mid = s[middle] if middle.sum() >= 3 else s
        s_lo, s_hi = (float(q) for q in np.quantile(s_mid, [0.02, 0.98]))
        deep = s_hi - s_lo
        if deep < cfg.min_depth * 2 * r and not (cut["top"] or cut["bottom"]):
            return BlobShape(False, "too shallow", width_m=width, depth_m=deep, edges=edges)
        # The near face is the base's edge, unless it is below the image: then its top's far edge.
        along = s_hi - r if cut["bottom"] else s_lo + r
        centre = cam + along * ray + mid_a * across
        x, y = float(centre[0]), float(centre[1])
        inside = float(np.mean(np.hypot(*(base[:, :2] - centre).T) <= r + cfg.disc_margin_m))

        def placed(why: str) -> BlobShape:
            return BlobShape(not why, why, x, y, width, deep, inside, edges)

        if inside < cfg.min_inside:
            return placed("not one base")
        # As the twin's sighting (sim/goal_sight.py): a goal whose middle is out of view is not
        # reported (a sliver at the image's edge could be anything of its colour); the middle
        # may be placed a third of a radius off.
        mid = mount.robot_to_camera_points(np.array([[x, y, cfg.base_height_m / 2]]))
        (pu, pv), pz = (q[0] for q in project_points(mid, intr.fx, intr.fy, intr.cx, intr.cy))
        margin = intr.fx * r / 3 / max(float(pz), 1e-3)
        if not (
            pz > 0 and -margin <= pu < intr.width + margin and -margin <= pv < intr.height + margin
        ):
            return placed("middle out of view")
        return placed("")


def goals_robot(sightings: list[GoalSighting]) -> NDArray[np.float64]:
    """Sightings as the strategy reads them: (N, 3) x, y robot frame and colour code."""
    return np.array(
        [(s.x, s.y, COLOUR_CODES[s.colour]) for s in sightings], dtype=np.float64
    ).reshape(-1, 3)
