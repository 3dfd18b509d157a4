"""Camera datasets from the simulator: `pete-sim dataset --frames N --out DIR`.

Each frame is an independent scene drawn from its own seed (the run's seed and the frame's
number), so frame k is the same whatever N is and any frame can be regenerated alone:

* a ring layout: the field's starting rings, a random subset removed, some displaced, some pushed
  against a neighbour (touching rings are the hard case for a detector);
* mobile goals nudged, the other robots (both sizes) placed at random or left out of view;
* the observing robot (15 in or 24 in, so both camera mounts) at a random free spot, usually
  facing a ring 0.3-3 m away, otherwise any way;
* with `viewpoint = "spectator"`, the camera is not on the robot but where a person photographs
  the field from: 0.1-1.2 m outside a wall, 0.8-1.9 m up, looking down at a point 1-3 m into
  the field, so far rings are a few pixels wide, as in photos of a field (the
  robot's own camera, 0.3 m up, sees few rings that small);
* what the renderer lets us vary: light direction and ambient/diffuse balance, per-ring colour
  jitter inside the perception HSV window, floor and wall tints; after rendering, Gaussian or
  motion blur and sensor noise on the saved image (depth stays exact: it is ground truth).

Labels come from the render's per-pixel ring ids, so a ring cut by the image's edge or hidden in
part gets the box of its visible pixels; rings with fewer than `min_ring_pixels` visible pixels
are not labelled. Truth positions are the world's ring centres in the observing robot's frame.

The folder is the one jetson.perception.dataset reads and writes (its writer is used here), plus
`frames.jsonl`: per frame, the robot, its field pose and its camera mount. A folder that mixes
both robots has no single mount, so dataset.json then lists `mounts` by robot instead of `mount`.
"""

from __future__ import annotations

import colorsys
import json
import math
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
import pybullet as p

from jetson.autonomy.geometry import field_to_robot
from sim.camera import projection_matrix, render_camera, view_matrix
from sim.config import ROBOTS, CameraConfig, WorldConfig
from sim.errors import ConfigError
from sim.world import sensors
from sim.world.physics import World

# The perception HSV window on OpenCV's scales (H 0-179, S and V 0-255), from the original
# team's GRIP pipeline. Ring colours are drawn inside it with a margin, and V high enough that
# the darkest shading (the ambient term) keeps it in the window.
HSV_WINDOW = {"h": (123.0, 169.0), "s": (39.0, 192.0), "v": (76.0, 255.0)}
_H_DRAW = (128.0, 164.0)
_S_DRAW = (70.0, 180.0)
_AMBIENT = (0.5, 0.7)  # ambient + diffuse = 1: a lit face never saturates and shifts hue
_V_DRAW = (76.0 / _AMBIENT[0] + 8.0, 250.0)
_PARKED = (50.0, 50.0)  # robots left out of a scene wait here, far beyond the far plane
_REFERENCE_AREA = 640 * 480
# Bumped whenever a (seed, frame) pair renders a different scene than before, so that a test set
# rendered by older code is recognised (dataset.json's "scenes_version") and rendered again.
# 2: no ring inside a goal's base.
SCENES_VERSION = 2
VIEWPOINTS = ("robot", "spectator")


@dataclass(frozen=True)
class DatasetConfig:
    frames: int
    seed: int = 0
    width: int = 640
    height: int = 480
    robots: tuple[str, ...] = ("15in", "24in")
    # Rings with fewer visible pixels (at 640x480; scaled with the image area) get no label.
    min_ring_pixels: int = 40
    augment: bool = True  # blur and noise on the saved image
    viewpoint: str = "robot"  # robot: the observing robot's camera | spectator: see the module doc

    def __post_init__(self) -> None:
        if self.frames < 1:
            raise ConfigError(f"frames must be at least 1, got {self.frames}")
        if self.width < 16 or self.height < 16:
            raise ConfigError(f"image must be at least 16x16, got {self.width}x{self.height}")
        if not self.robots:
            raise ConfigError("robots must name at least one robot")
        unknown = sorted(set(self.robots) - set(ROBOTS))
        if unknown:
            raise ConfigError(f"unknown robots {unknown} (known: {sorted(ROBOTS)})")
        if self.min_ring_pixels < 1:
            raise ConfigError(f"min_ring_pixels must be >= 1, got {self.min_ring_pixels}")
        if self.viewpoint not in VIEWPOINTS:
            raise ConfigError(f"viewpoint must be one of {VIEWPOINTS}, got {self.viewpoint!r}")

    @property
    def min_pixels_here(self) -> int:
        scaled = self.min_ring_pixels * self.width * self.height / _REFERENCE_AREA
        return max(6, round(scaled))

    def camera(self, robot: str) -> CameraConfig:
        return ROBOTS[robot].camera.scaled(self.width, self.height)


@dataclass
class SimSample:
    """One rendered frame with its labels."""

    name: str
    bgr: np.ndarray  # (H, W, 3) uint8, augmented
    depth_m: np.ndarray  # (H, W) float32, 0 = no return
    boxes_px: np.ndarray  # (N, 4) x0, y0, x1, y1 of each labelled ring's visible pixels
    rings_robot_xy: np.ndarray  # (N, 2) metres, robot frame, same order
    ring_ids: np.ndarray  # (H, W) int16 ring index under each pixel, -1 elsewhere
    ring_index: np.ndarray  # (N,) world ring index of each label
    info: dict[str, Any] = field(default_factory=dict)


def frame_rng(seed: int, k: int) -> np.random.Generator:
    return np.random.default_rng([seed, k])


def _world_config() -> WorldConfig:
    # Two of each size: index 0 and 1 observe (red 15 in, red 24 in), the rest are clutter.
    return WorldConfig(red=("15in", "24in"), blue=("15in", "24in"))


def _observer_index(world: World, robot: str) -> int:
    return next(r.index for r in world.robots if r.alliance == "red" and r.config.name == robot)


def _ring_layout(world: World, rng: np.random.Generator) -> np.ndarray:
    f = world.field
    xy = f.ring_positions.copy()
    xy = xy[rng.random(len(xy)) < rng.uniform(0.3, 1.0)]
    if len(xy) == 0:
        return xy.reshape(0, 2)
    moved = rng.random(len(xy)) < rng.uniform(0.1, 0.6)
    xy[moved] += rng.normal(0.0, 0.3, (int(moved.sum()), 2))
    # Some rings pushed against another: touching rings merge into one blob for a detector.
    touch = np.flatnonzero(rng.random(len(xy)) < 0.15)
    for i in touch:
        j = int(rng.integers(len(xy)))
        if j != i:
            a = rng.uniform(0, 2 * math.pi)
            d = f.ring.outer_diameter * rng.uniform(0.95, 1.1)
            xy[i] = xy[j] + d * np.array([math.cos(a), math.sin(a)])
    lim = f.half - f.ring.radius - 0.01
    return np.clip(xy, -lim, lim)


def _free_spot(
    world: World,
    rng: np.random.Generator,
    radius: float,
    taken: list[tuple[float, float, float]],
    goal_xy: np.ndarray,
) -> tuple[float, float]:
    """A random position for a robot of this radius: inside the walls, off the goals and other
    robots (circles (x, y, r) in `taken`). After many failures, the last try (scenes are rare
    where nothing fits, and overlap only costs realism)."""
    lim = world.field.half - radius - 0.02
    x = y = 0.0
    for _ in range(200):
        x, y = rng.uniform(-lim, lim, 2)
        clear = all(math.hypot(x - tx, y - ty) > radius + tr + 0.05 for tx, ty, tr in taken)
        for g, (gx, gy) in zip(world.goals, goal_xy, strict=True):
            clear = clear and math.hypot(x - gx, y - gy) > radius + g.spec.base_radius + 0.05
        if clear:
            break
    return float(x), float(y)


def _aim(
    rng: np.random.Generator, xy: tuple[float, float], rings: np.ndarray, cam: CameraConfig
) -> float:
    """A heading: mostly towards a ring in the camera's range, sometimes any way at all."""
    if len(rings) and rng.random() < 0.85:
        d = np.hypot(rings[:, 0] - xy[0], rings[:, 1] - xy[1])
        near = np.flatnonzero((d > 0.3) & (d < cam.max_range_m))
        pick = rings[int(rng.choice(near))] if len(near) else rings[int(np.argmin(d))]
        heading = math.degrees(math.atan2(pick[0] - xy[0], pick[1] - xy[1]))
        return float((heading + rng.normal(0.0, 15.0)) % 360.0)
    return float(rng.uniform(0.0, 360.0))


def _ring_colour(rng: np.random.Generator, base_hsv: tuple[float, float, float]) -> list[float]:
    """RGBA in [0, 1] near base_hsv (OpenCV scales), inside the drawing window."""
    h = float(np.clip(base_hsv[0] + rng.normal(0, 2.0), *_H_DRAW))
    s = float(np.clip(base_hsv[1] + rng.normal(0, 8.0), *_S_DRAW))
    v = float(np.clip(base_hsv[2] + rng.normal(0, 8.0), *_V_DRAW))
    r, g, b = colorsys.hsv_to_rgb(h / 180.0, s / 255.0, v / 255.0)
    return [r, g, b, 1.0]


def _tint(rng: np.random.Generator, rgb: tuple[int, int, int], spread: float) -> list[float]:
    """A brightness change of up to +-spread and a faint colour cast: the tint must never make
    grey tiles saturated enough to pass the ring colour window."""
    scale = rng.uniform(1 - spread, 1 + spread)
    cast = rng.uniform(-0.05, 0.05, 3)
    c = np.clip(np.asarray(rgb) / 255.0 * scale * (1 + cast), 0, 1)
    return [float(c[0]), float(c[1]), float(c[2]), 1.0]


def _light(rng: np.random.Generator) -> dict[str, Any]:
    elevation = rng.uniform(math.radians(25), math.radians(90))
    azimuth = rng.uniform(0, 2 * math.pi)
    ambient = float(rng.uniform(*_AMBIENT))
    return {
        "lightDirection": [
            math.cos(elevation) * math.cos(azimuth),
            math.cos(elevation) * math.sin(azimuth),
            math.sin(elevation),
        ],
        "lightColor": [1.0, 1.0, 1.0],
        "lightAmbientCoeff": ambient,
        "lightDiffuseCoeff": 1.0 - ambient,
        # Specular highlights would whiten rings out of the HSV window.
        "lightSpecularCoeff": 0.0,
        "shadow": 0,
    }


def _appearance(world: World, rng: np.random.Generator) -> dict[str, Any]:
    """Randomise ring colours, floor and wall tints on the world's visual shapes."""
    cid = world.client
    f = world.field
    base = (
        rng.uniform(_H_DRAW[0] + 4, _H_DRAW[1] - 4),
        rng.uniform(_S_DRAW[0] + 15, _S_DRAW[1] - 10),
        rng.uniform(_V_DRAW[0] + 10, _V_DRAW[1]),
    )
    for body in world.ensure_ring_visuals():
        p.changeVisualShape(body, -1, rgbaColor=_ring_colour(rng, base), physicsClientId=cid)
    floor = _tint(rng, f.tile_rgb, 0.3)
    p.changeVisualShape(world.floor, -1, rgbaColor=floor, physicsClientId=cid)
    for wall in world.walls:
        p.changeVisualShape(wall, -1, rgbaColor=_tint(rng, f.wall_rgb, 0.2), physicsClientId=cid)
    return {
        "ring_hsv": [round(float(c), 1) for c in base],
        "floor_rgb": [round(c, 4) for c in floor[:3]],
    }


def _render_rgb(world: World, cam: CameraConfig, index: int, light: dict[str, Any]) -> np.ndarray:
    """The colour image under a given light. render_camera fixes its light, so colour is rendered
    here with the same view and projection (pixels line up with its depth and ring ids)."""
    _, _, rgba, _, _ = p.getCameraImage(
        cam.width,
        cam.height,
        view_matrix(sensors.camera_pose(world, index)),
        projection_matrix(cam),
        renderer=p.ER_TINY_RENDERER,
        flags=p.ER_NO_SEGMENTATION_MASK,
        physicsClientId=world.client,
        **light,
    )
    return np.asarray(rgba, dtype=np.uint8).reshape(cam.height, cam.width, 4)[:, :, :3].copy()


def ring_boxes(ring_ids: np.ndarray, min_pixels: int) -> tuple[np.ndarray, np.ndarray]:
    """Boxes (x0, y0, x1, y1; x1, y1 one past the last pixel) of every ring id with at least
    min_pixels pixels, and those ids, in id order."""
    ids, counts = np.unique(ring_ids[ring_ids >= 0], return_counts=True)
    keep = ids[counts >= min_pixels]
    boxes = []
    for i in keep:
        ys, xs = np.nonzero(ring_ids == i)
        boxes.append([xs.min(), ys.min(), xs.max() + 1, ys.max() + 1])
    return np.asarray(boxes, dtype=np.float64).reshape(-1, 4), keep.astype(np.int64)


def _degrade(bgr: np.ndarray, rng: np.random.Generator) -> tuple[np.ndarray, dict[str, float]]:
    """Blur and sensor noise on the saved image, as a real camera adds them."""
    import cv2  # the jetson extra: only the dataset writer needs OpenCV

    out = bgr
    info: dict[str, float] = {}
    if rng.random() < 0.5:
        sigma = float(rng.uniform(0.4, 1.2))
        out = cv2.GaussianBlur(out, (0, 0), sigma)
        info["blur_sigma"] = round(sigma, 3)
    if rng.random() < 0.2:
        length = int(rng.integers(3, 8))
        kernel = np.zeros((length, length), np.float32)
        kernel[length // 2, :] = 1.0 / length
        angle = float(rng.uniform(0, 180))
        rot = cv2.getRotationMatrix2D(((length - 1) / 2, (length - 1) / 2), angle, 1.0)
        kernel = cv2.warpAffine(kernel, rot, (length, length))
        kernel /= max(float(kernel.sum()), 1e-6)
        out = cv2.filter2D(out, -1, kernel)
        info["motion_px"] = length
    sigma_n = float(rng.uniform(0.0, 6.0))
    noisy = out.astype(np.float32) + rng.normal(0.0, sigma_n, out.shape).astype(np.float32)
    info["noise_sigma"] = round(sigma_n, 3)
    return np.clip(np.rint(noisy), 0, 255).astype(np.uint8), info


def render_sample(world: World, cfg: DatasetConfig, k: int) -> SimSample:
    """Frame k of the dataset `cfg` describes, rendered in `world` (from _world_config)."""
    rng = frame_rng(cfg.seed, k)
    world.reset(rng)
    f = world.field
    robot = cfg.robots[int(rng.integers(len(cfg.robots)))]
    obs = _observer_index(world, robot)
    cam = cfg.camera(robot)
    rings = _ring_layout(world, rng)

    goal_xy = np.array([[g.x, g.y] for g in world.goals])
    lim = f.half - 0.2
    nudge = rng.random(len(goal_xy)) < 0.5
    goal_xy[nudge] += rng.normal(0.0, 0.3, (int(nudge.sum()), 2))
    goal_xy = np.clip(goal_xy, -lim, lim)

    me = world.robots[obs]
    x, y = _free_spot(world, rng, me.config.radius_m, [], goal_xy)
    heading = _aim(rng, (x, y), rings, cam)
    placed: list[tuple[int, float, float, float]] = [(obs, x, y, heading)]
    taken = [(x, y, me.config.radius_m)]
    for r in world.robots:
        if r.index == obs:
            continue
        if rng.random() < 0.45:
            ox, oy = _free_spot(world, rng, r.config.radius_m, taken, goal_xy)
            taken.append((ox, oy, r.config.radius_m))
            placed.append((r.index, ox, oy, float(rng.uniform(0, 360))))
        else:
            placed.append((r.index, _PARKED[0] + 2 * r.index, _PARKED[1], 0.0))

    # A ring under a robot would have been pushed aside or taken in; one inside a goal's base
    # cannot be at all (rendered, it is a ring cut in half by the base).
    if len(rings):
        clear = np.ones(len(rings), dtype=bool)
        solid = taken + [
            (gx, gy, g.spec.base_radius) for g, (gx, gy) in zip(world.goals, goal_xy, strict=True)
        ]
        for tx, ty, tr in solid:
            clear &= np.hypot(rings[:, 0] - tx, rings[:, 1] - ty) > tr + f.ring.radius
        rings = rings[clear]
    if cfg.viewpoint == "spectator":
        # Drawn after the scene, so a spectator frame k shows the scene robot frame k shows.
        cam, (x, y, heading) = _spectator(world, rng, cam)
        me.config = replace(me.config, camera=cam)
        placed[0] = (obs, x, y, heading)
    world.set_floor_rings(rings)
    for g, (gx, gy) in zip(world.goals, goal_xy, strict=True):
        world.place_goal(g.index, gx, gy)
    for index, px, py, ph in placed:
        world.place_robot(index, px, py, ph)

    look = _appearance(world, rng)
    light = _light(rng)
    frame = render_camera(world, obs, cam)
    rgb = _render_rgb(world, cam, obs, light)
    boxes, ids = ring_boxes(frame.ring_ids, cfg.min_pixels_here)
    xy = field_to_robot(world.ring_xy[ids], (me.x, me.y), me.heading).reshape(-1, 2)
    bgr = np.ascontiguousarray(rgb[:, :, ::-1])
    degrade: dict[str, float] = {}
    if cfg.augment:
        bgr, degrade = _degrade(bgr, rng)
    info = {
        "robot": robot,
        "viewpoint": cfg.viewpoint,
        "pose": [round(me.x, 5), round(me.y, 5), round(me.heading, 4)],
        "mount": mount_of(cam),
        "light": {
            "direction": [round(v, 4) for v in light["lightDirection"]],
            "ambient": round(light["lightAmbientCoeff"], 4),
        },
        **look,
        **degrade,
    }
    return SimSample(
        f"sim_{cfg.seed}_{k:06d}", bgr, frame.depth, boxes, xy, frame.ring_ids, ids, info
    )


def _spectator(
    world: World, rng: np.random.Generator, cam: CameraConfig
) -> tuple[CameraConfig, tuple[float, float, float]]:
    """A photographer's camera (the observing robot carries it, out of the field and out of
    the picture) and the robot's pose: outside a random wall, aimed at a point of the field."""
    half = world.field.half
    side = int(rng.integers(4))
    along = float(rng.uniform(-half, half))
    out = half + float(rng.uniform(0.1, 1.2))
    # Where the photographer stands and the heading that looks square into the field (0 deg
    # is +y, 90 deg is +x): one row per wall.
    x, y, inward = [
        (out, along, 270.0),
        (-out, along, 90.0),
        (along, out, 180.0),
        (along, -out, 0.0),
    ][side]
    # Aimed 1-3 m into the field, up to 35 deg off square to its wall, and looking down at
    # that point give or take: photos of a field show mostly field.
    heading = (inward + float(rng.uniform(-35.0, 35.0))) % 360.0
    reach = float(rng.uniform(1.0, 3.0)) + (out - half)
    height = float(rng.uniform(0.8, 1.9))
    down = math.degrees(math.atan2(height, reach))
    spec = replace(
        cam,
        forward_m=0.35,  # ahead of the robot's body, which stays out of the picture
        right_m=0.0,
        height_m=height,
        tilt_deg=float(np.clip(-down + rng.normal(0.0, 6.0), -75.0, -10.0)),
        max_range_m=cam.far_m,
    )
    return spec, (x, y, heading)


def mount_of(cam: CameraConfig) -> dict[str, float]:
    """The camera mount in jetson.perception.camera.CameraMount's terms."""
    return {
        "forward_m": cam.forward_m,
        "right_m": cam.right_m,
        "height_m": cam.height_m,
        "tilt_deg": cam.tilt_deg,
    }


def intrinsics_of(cam: CameraConfig) -> dict[str, Any]:
    """The intrinsics in jetson.perception.frame.Intrinsics' terms (the render is a pinhole)."""
    return {
        "width": cam.width,
        "height": cam.height,
        "fx": cam.fx,
        "fy": cam.fy,
        "cx": cam.cx,
        "cy": cam.cy,
        "dist": [0.0] * 5,
    }


def iter_samples(cfg: DatasetConfig) -> Iterator[SimSample]:
    world = World(_world_config())
    try:
        for k in range(cfg.frames):
            yield render_sample(world, cfg, k)
    finally:
        world.close()


def dataset_meta(cfg: DatasetConfig) -> dict[str, Any]:
    cams = {name: cfg.camera(name) for name in dict.fromkeys(cfg.robots)}
    first = next(iter(cams.values()))
    meta: dict[str, Any] = {
        "source": "pete-sim dataset",
        "seed": cfg.seed,
        "frames": cfg.frames,
        "robots": list(cams),
        # Every robot's camera has the same optics; only the mount differs.
        "intrinsics": intrinsics_of(first),
        "min_ring_pixels": cfg.min_pixels_here,
        "scenes_version": SCENES_VERSION,
        "hsv_window": HSV_WINDOW,
        "viewpoint": cfg.viewpoint,
    }
    # Spectator frames each have their own mount (frames.jsonl), so no folder-wide one.
    if cfg.viewpoint == "robot":
        mounts = {name: mount_of(c) for name, c in cams.items()}
        if len({json.dumps(m, sort_keys=True) for m in mounts.values()}) == 1:
            meta["mount"] = next(iter(mounts.values()))
        else:
            meta["mounts"] = mounts
    return meta


def write_dataset(cfg: DatasetConfig, out: Path, progress: bool = False) -> int:
    """Render cfg.frames frames into the dataset folder `out`; returns the number of labels."""
    from jetson.perception.dataset import write_meta, write_sample

    out = Path(out)
    if (out / "images").is_dir() and any((out / "images").iterdir()):
        raise FileExistsError(f"{out} already holds a dataset; choose an empty folder")
    write_meta(out, dataset_meta(cfg))
    samples: Iterator[SimSample] = iter_samples(cfg)
    if progress:
        from tqdm import tqdm

        samples = tqdm(samples, total=cfg.frames, unit="frame", desc="pete-sim dataset")
    labels = 0
    with (out / "frames.jsonl").open("w") as log:
        for s in samples:
            write_sample(out, s.name, s.bgr, s.boxes_px, s.depth_m, s.rings_robot_xy)
            log.write(json.dumps({"name": s.name, **s.info}) + "\n")
            log.flush()
            labels += len(s.boxes_px)
    return labels
