"""What a robot's sensors give: the GPS reading, the camera's pose and the rings it sees.

Functions over the world's state (sim.world.state.WorldState). Training fidelity answers
visibility with the prism geometry of sim.visibility; high fidelity with PyBullet ray tests
against the ring bodies.

The GPS (`gps`) reads the pose with Gaussian noise and never fails. `gps_with_occlusion` adds the
real sensor's weak spot, as an option (GpsOcclusion; off unless a caller passes one, so existing
configs and benchmarks read exactly what they read before): the VEX GPS is a camera that reads the
field code strip on the perimeter wall, and robots, goals and the platforms between it and the
wall hide the strip. With too little of the strip in sight there is no reading; with part of it,
a noisier one.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import pybullet as p

from jetson.autonomy.geometry import field_to_robot, wrap_heading
from sim.visibility import (
    CameraPose,
    Obstacles,
    in_frustum,
    occluded,
    plates_in_view,
    visible,
    visible_among_rings,
)
from sim.visibility import (
    camera_pose as _camera_pose,
)
from sim.world.state import POST_RADIUS, RING_FLOOR, GpsReading, WorldState


def interpolate_pose(
    a: Any, x0: Any, y0: Any, h0: Any, x1: Any, y1: Any, h1: Any
) -> tuple[Any, Any, Any]:
    """The pose `a` of the way from (x0, y0, h0) to (x1, y1, h1), the heading (degrees) turning
    the shorter way; floats or arrays alike. The GPS's latency: sensors.gps for one robot,
    sim.fast.world for every robot of a batch."""
    dh = (h1 - h0 + 180.0) % 360.0 - 180.0
    return x0 + a * (x1 - x0), y0 + a * (y1 - y0), h0 + a * dh


def gps(world: WorldState, index: int, rng: np.random.Generator | None = None) -> GpsReading:
    """The GPS reading of robot `index`: its pose `latency_s` ago, plus noise when rng."""
    r = world.robots[index]
    gcfg = r.config.gps
    t = world.time_s - gcfg.latency_s
    hist = r.history
    x, y, h = hist[-1][1], hist[-1][2], hist[-1][3]
    if t < hist[-1][0]:
        x, y, h = hist[0][1], hist[0][2], hist[0][3]
        for (t0, x0, y0, h0), (t1, x1, y1, h1) in zip(list(hist)[:-1], list(hist)[1:], strict=True):
            if t0 <= t <= t1:
                a = (t - t0) / (t1 - t0) if t1 > t0 else 1.0
                x, y, h = interpolate_pose(a, x0, y0, h0, x1, y1, h1)
                break
    if rng is not None:
        x += rng.normal(0.0, gcfg.noise_xy_m)
        y += rng.normal(0.0, gcfg.noise_xy_m)
        h += rng.normal(0.0, gcfg.noise_heading_deg)
    return GpsReading(x, y, float(wrap_heading(h)), gcfg.noise_xy_m, world.time_s)


@dataclass(frozen=True)
class GpsOcclusion:
    """The VEX GPS losing sight of the field code strip.

    Facts (VEX's and PROS's documentation of the V5 GPS sensor): a monochrome camera reads the
    code strip printed along the inside of the field perimeter; it cannot read closer than about
    13.5 in (0.34 m) to the wall it looks at, reads reliably from 20 in, and stays accurate up to
    about 12 ft (3.66 m); VEX quotes about +-13 mm of position error with the strip in view.
    Chosen here (no source gives them; change them per robot): the sensor looks to the robot's
    right (`facing_deg` 90, clear of a goal held in a back clamp) across a 60-degree field of
    view, at 0.20 m above the floor, and the strip's useful band is 0.05-0.25 m up the wall. The
    view is sampled by `rays` lines of sight to the strip's middle; a line is lost when it is too
    close or too far, or when a robot (not this one), a goal or a platform crosses it below its
    height. A goal blocks as a disc of `goal_body_radius_m` up to its top (its branches and the
    rings on them, not only its post; chosen), a platform as a box of the field file's height,
    or `platform_height_m` (a tilted see-saw's raised side and what stands on it, which the
    flat box misses; the twin's see-saw state does not reach this model yet).
    Less than `min_visible` of the lines clear: no reading (a dropout). Otherwise the reading's
    noise, and the error the sensor reports, grow as the strip in view shrinks:
    noise_xy_m / sqrt(fraction in view).
    """

    noise_xy_m: float = 0.013
    noise_heading_deg: float = 0.5
    facing_deg: float = 90.0  # where the camera looks, clockwise from the robot's heading
    fov_deg: float = 60.0
    height_m: float = 0.20
    strip_bottom_m: float = 0.05
    strip_top_m: float = 0.25
    min_range_m: float = 0.34
    max_range_m: float = 3.66
    rays: int = 9
    min_visible: float = 0.35
    goal_body_radius_m: float = 0.09
    platform_height_m: float | None = None

    def __post_init__(self) -> None:
        numbers = (
            self.noise_xy_m, self.noise_heading_deg, self.facing_deg, self.fov_deg,
            self.height_m, self.strip_bottom_m, self.strip_top_m, self.min_range_m,
            self.max_range_m, self.min_visible,
        )  # fmt: skip
        if not all(math.isfinite(v) for v in numbers):
            raise ValueError(f"GpsOcclusion numbers must be finite: {self}")
        if self.noise_xy_m < 0 or self.noise_heading_deg < 0:
            raise ValueError("GpsOcclusion noise must not be negative")
        if not 0 < self.fov_deg < 180 or self.rays < 1:
            raise ValueError("GpsOcclusion needs a field of view in (0, 180) and at least one ray")
        if not 0 <= self.strip_bottom_m < self.strip_top_m or self.height_m <= 0:
            raise ValueError("GpsOcclusion: strip_bottom_m < strip_top_m, height_m > 0")
        if not 0 <= self.min_range_m < self.max_range_m:
            raise ValueError("GpsOcclusion: min_range_m < max_range_m")
        if not 0 < self.min_visible <= 1:
            raise ValueError("GpsOcclusion min_visible must be in (0, 1]")
        if not (math.isfinite(self.goal_body_radius_m) and self.goal_body_radius_m >= 0):
            raise ValueError("GpsOcclusion goal_body_radius_m must not be negative")
        ph = self.platform_height_m
        if ph is not None and not (math.isfinite(ph) and ph >= 0):
            raise ValueError("GpsOcclusion platform_height_m must not be negative")


def gps_sensor_xy(world: WorldState, index: int) -> tuple[float, float]:
    """Where robot `index`'s GPS sensor is (its offset from the centre of turning)."""
    r = world.robots[index]
    gcfg = r.config.gps
    h = math.radians(r.heading)
    fx, fy = math.sin(h), math.cos(h)  # forward
    rx, ry = math.cos(h), -math.sin(h)  # right
    return (
        r.x + gcfg.offset_forward_m * fx + gcfg.offset_right_m * rx,
        r.y + gcfg.offset_forward_m * fy + gcfg.offset_right_m * ry,
    )


def _gps_obstacles(world: WorldState, index: int, model: GpsOcclusion) -> Obstacles:
    """What can hide the strip from robot `index`'s GPS: the other robots, the goals (their
    bodies, not only their posts) and the platforms."""
    boxes = []
    for r in world.robots:
        if r.index != index:
            rc = r.config
            boxes.append((r.x, r.y, r.heading, rc.width_m / 2, rc.length_m / 2, rc.height_m))
    for pl in world.field.platforms:
        height = pl.height if model.platform_height_m is None else model.platform_height_m
        boxes.append((pl.center[0], pl.center[1], 0.0, pl.size[0] / 2, pl.size[1] / 2, height))
    discs = []
    for g in world.goals:
        discs.append((g.x, g.y, g.spec.base_radius, g.spec.base_height))
        discs.append((g.x, g.y, max(POST_RADIUS, model.goal_body_radius_m), g.spec.height))
    return Obstacles.build(boxes, discs)


def gps_strip_in_view(world: WorldState, index: int, model: GpsOcclusion) -> float:
    """The fraction (0..1) of robot `index`'s GPS lines of sight that reach the strip."""
    r = world.robots[index]
    sx, sy = gps_sensor_xy(world, index)
    half = world.field.size / 2
    n = model.rays
    offsets = np.linspace(-0.5, 0.5, n) * model.fov_deg if n > 1 else np.zeros(1)
    ang = np.radians(r.heading + model.facing_deg + offsets)
    dx, dy = np.sin(ang), np.cos(ang)
    # Distance along each ray to the perimeter's inside face (the square |x|, |y| <= half).
    with np.errstate(divide="ignore"):
        tx = np.where(np.abs(dx) > 1e-12, (np.sign(dx) * half - sx) / dx, np.inf)
        ty = np.where(np.abs(dy) > 1e-12, (np.sign(dy) * half - sy) / dy, np.inf)
    t = np.minimum(tx, ty)
    in_range = (t >= model.min_range_m) & (t <= model.max_range_m)
    z = 0.5 * (model.strip_bottom_m + model.strip_top_m)
    targets = np.column_stack([sx + t * dx, sy + t * dy, np.full(n, z)])
    obs = _gps_obstacles(world, index, model)
    finite = np.isfinite(t)
    clear = np.zeros(n, dtype=bool)
    if np.any(finite & in_range):
        keep = np.flatnonzero(finite & in_range)
        clear[keep] = ~occluded(np.array([sx, sy, model.height_m]), targets[keep], obs)
    return float(np.count_nonzero(clear)) / n


def gps_with_occlusion(
    world: WorldState,
    index: int,
    rng: np.random.Generator | None,
    model: GpsOcclusion | None,
) -> GpsReading | None:
    """The GPS reading of robot `index` as `gps` gives it, or with `model` as the real sensor
    gives it: None while too little of the strip is in view, else the pose `latency_s` ago with
    the model's noise, grown as the strip in view shrinks (its error_m says how much)."""
    if model is None:
        return gps(world, index, rng)
    frac = gps_strip_in_view(world, index, model)
    if frac < model.min_visible:
        return None
    exact = gps(world, index, None)
    scale = 1.0 / math.sqrt(frac)
    x, y, h = exact.x, exact.y, exact.heading_deg
    if rng is not None:
        x += rng.normal(0.0, model.noise_xy_m * scale)
        y += rng.normal(0.0, model.noise_xy_m * scale)
        h += rng.normal(0.0, model.noise_heading_deg * scale)
    return GpsReading(x, y, float(wrap_heading(h)), model.noise_xy_m * scale, exact.time_s)


def camera_pose(world: WorldState, index: int) -> CameraPose:
    """Where robot `index`'s camera is and how it looks."""
    r = world.robots[index]
    return _camera_pose((r.x, r.y), r.heading, r.config.camera)


def obstacles(
    world: WorldState, exclude_robot: int | None = None, with_rings: bool = False
) -> Obstacles:
    """Every robot (but `exclude_robot`) and goal as prisms, and the floor rings when asked."""
    boxes = []
    for r in world.robots:
        if r.index != exclude_robot:
            rc = r.config
            boxes.append((r.x, r.y, r.heading, rc.width_m / 2, rc.length_m / 2, rc.height_m))
    discs = []
    for g in world.goals:
        discs.append((g.x, g.y, g.spec.base_radius, g.spec.base_height))
        discs.append((g.x, g.y, POST_RADIUS, g.spec.height))
    obs = Obstacles.build(boxes, discs)
    if with_rings:
        floor = np.flatnonzero(world.ring_state == RING_FLOOR)
        rad = np.full(len(floor), world.field.ring.radius)
        hz = world.ring_z[floor] + world.field.ring.thickness / 2
        obs.disc_xy = np.concatenate([obs.disc_xy, world.ring_xy[floor]])
        obs.disc_radius = np.concatenate([obs.disc_radius, rad])
        obs.disc_height = np.concatenate([obs.disc_height, hz])
    return obs


def robots_in_view(world: WorldState) -> np.ndarray:
    """(R, R): whether robot i's camera sees robot j's licence plate now
    (sim.visibility.plates_in_view, the robot detector's reach, the other robots and the goals
    hiding plates: the fast backend asks the same of every match at once)."""
    rs = world.robots
    pose = np.array([[r.x, r.y, r.heading, r.w] for r in rs], dtype=np.float64).reshape(-1, 4)
    sizes = np.array([(r.config.width_m, r.config.length_m, r.config.height_m) for r in rs])
    cams = [r.config.camera for r in rs]
    gs = world.goals
    goals = np.array([(g.x, g.y) for g in gs], dtype=np.float64).reshape(1, -1, 2)
    discs = np.array(
        [(g.spec.base_radius, g.spec.base_height) for g in gs]
        + [(POST_RADIUS, g.spec.height) for g in gs],
        dtype=np.float64,
    ).reshape(-1, 2)  # the bases, then the posts (as obstacles() has them)
    return plates_in_view(
        pose[None, :, 0], pose[None, :, 1], pose[None, :, 2], pose[None, :, 3], cams, sizes,
        goals, discs,
    )[0]  # fmt: skip


def visible_rings(world: WorldState, index: int) -> np.ndarray:
    """Indices of the rings on the floor that robot `index`'s camera sees."""
    r = world.robots[index]
    cam = r.config.camera
    if cam.max_turn_rate_rad_s is not None and abs(r.w) > cam.max_turn_rate_rad_s:
        return np.zeros(0, dtype=np.int64)
    floor = np.flatnonzero(world.ring_state == RING_FLOOR)
    if len(floor) == 0:
        return floor
    pts = np.column_stack([world.ring_xy[floor], world.ring_z[floor]])
    pose = camera_pose(world, index)
    if world.training:
        obs = obstacles(world, index)
        if world.config.occlude_with_rings:
            ring = world.field.ring
            mask = visible_among_rings(pts, pose, cam, obs, ring.radius, ring.thickness)
        else:
            mask = visible(pts, pose, cam, obs)
        return floor[mask]
    mask, _, _ = in_frustum(pts, pose, cam)
    keep = np.flatnonzero(mask)
    if len(keep):
        mask[keep] = _rays_clear(world, pose, floor[keep], index)
    return floor[mask]


def _rays_clear(world: WorldState, pose: CameraPose, rings: np.ndarray, index: int) -> np.ndarray:
    """High fidelity: a ray from the camera hits the ring itself (or nothing) first."""
    start = [tuple(pose.position)] * len(rings)
    ends = [(world.ring_xy[i, 0], world.ring_xy[i, 1], world.ring_z[i]) for i in rings]
    hits = p.rayTestBatch(start, ends, physicsClientId=world.client)
    own = world.robots[index].body
    out = np.zeros(len(rings), dtype=bool)
    for k, (i, hit) in enumerate(zip(rings, hits, strict=True)):
        body = hit[0]
        out[k] = body in (-1, own, world.ring_bodies[i])
    return out


def rings_in_robot_frame(world: WorldState, index: int, rings: np.ndarray) -> np.ndarray:
    """The positions of `rings` (indices) in robot `index`'s frame, (N, 2)."""
    r = world.robots[index]
    return field_to_robot(world.ring_xy[rings], (r.x, r.y), r.heading)
