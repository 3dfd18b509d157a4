"""What a robot's sensors give: the GPS reading, the camera's pose and the rings it sees.

Functions over the world's state (sim.world.state.WorldState). Training fidelity answers
visibility with the prism geometry of sim.visibility; high fidelity with PyBullet ray tests
against the ring bodies.
"""

from __future__ import annotations

import numpy as np
import pybullet as p

from jetson.autonomy.geometry import field_to_robot, wrap_heading
from sim.visibility import (
    CameraPose,
    Obstacles,
    in_frustum,
    visible,
    visible_among_rings,
)
from sim.visibility import (
    camera_pose as _camera_pose,
)
from sim.world.state import POST_RADIUS, RING_FLOOR, GpsReading, WorldState


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
                dh = (h1 - h0 + 180.0) % 360.0 - 180.0
                x, y, h = x0 + a * (x1 - x0), y0 + a * (y1 - y0), h0 + a * dh
                break
    if rng is not None:
        x += rng.normal(0.0, gcfg.noise_xy_m)
        y += rng.normal(0.0, gcfg.noise_xy_m)
        h += rng.normal(0.0, gcfg.noise_heading_deg)
    return GpsReading(x, y, float(wrap_heading(h)), gcfg.noise_xy_m, world.time_s)


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
