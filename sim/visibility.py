"""Which rings a robot's camera sees: frustum, range and occlusion, in numpy.

Training fidelity has no ring bodies in PyBullet, so visibility is geometry: a ring is visible when
its centre projects inside the image, lies between the near plane and the range limit, and the
straight line from the camera to it passes through no obstacle. Obstacles are vertical prisms
standing on the floor (robots and platforms as boxes, goal bases and posts as discs), which is what
everything on a Tipping Point field is to a camera 0.3 m up. High fidelity cross-checks the same
question with PyBullet ray tests (sim.world).

Robots are seen by their licence plates (plates_in_view): the twin's model of the Jetson's
robot detector (jetson/perception/robots.py), batched over matches so that PyBullet's twin and
the fast backend ask the same arithmetic.

numpy only.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import project_points, robot_to_camera_rotation
from jetson.autonomy.geometry import heading_vector
from sim.config import CameraConfig

FloatArray = NDArray[np.float64]
_EPS = 1e-9


@dataclass
class Obstacles:
    """Vertical prisms on the floor, field frame. Boxes: centre, heading, half extents
    (across, along the heading), height. Discs: centre, radius, height."""

    box_xy: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    box_heading: FloatArray = field(default_factory=lambda: np.zeros(0))
    box_half: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    box_height: FloatArray = field(default_factory=lambda: np.zeros(0))
    disc_xy: FloatArray = field(default_factory=lambda: np.zeros((0, 2)))
    disc_radius: FloatArray = field(default_factory=lambda: np.zeros(0))
    disc_height: FloatArray = field(default_factory=lambda: np.zeros(0))

    @classmethod
    def build(
        cls,
        boxes: list[tuple[float, float, float, float, float, float]],
        discs: list[tuple[float, float, float, float]],
    ) -> Obstacles:
        """boxes: (x, y, heading_deg, half_across, half_along, height); discs: (x, y, r, h)."""
        b = np.asarray(boxes, dtype=np.float64).reshape(-1, 6)
        d = np.asarray(discs, dtype=np.float64).reshape(-1, 4)
        return cls(b[:, 0:2], b[:, 2], b[:, 3:5], b[:, 5], d[:, 0:2], d[:, 2], d[:, 3])


@dataclass(frozen=True)
class CameraPose:
    """Where a camera is: optical centre in the field frame (x, y, z) and the rotation taking
    field-frame vectors into the optical frame (x right, y down, z forward)."""

    position: FloatArray
    rotation: FloatArray

    def to_camera(self, points_xyz: FloatArray) -> FloatArray:
        return (np.asarray(points_xyz, dtype=np.float64) - self.position) @ self.rotation.T


def camera_pose(robot_xy: tuple[float, float], heading_deg: float, cam: CameraConfig) -> CameraPose:
    """The camera pose of a robot at robot_xy with the given GPS heading."""
    fwd = heading_vector(heading_deg)
    right = np.array([fwd[1], -fwd[0]])
    pos_xy = np.asarray(robot_xy, dtype=np.float64) + cam.forward_m * fwd + cam.right_m * right
    # Field -> robot (x right, y forward, z up), then robot -> optical.
    field_to_robot = np.array([[right[0], right[1], 0.0], [fwd[0], fwd[1], 0.0], [0.0, 0.0, 1.0]])
    rot = robot_to_camera_rotation(cam.tilt_deg) @ field_to_robot
    return CameraPose(np.array([pos_xy[0], pos_xy[1], cam.height_m]), rot)


def in_frustum(
    points_xyz: FloatArray, pose: CameraPose, cam: CameraConfig
) -> tuple[NDArray[np.bool_], FloatArray, FloatArray]:
    """Points inside the image, beyond the near plane and within the range limit.

    Returns the mask, the pixel coordinates (N, 2) and the optical-frame points (N, 3).
    """
    pc = pose.to_camera(points_xyz)
    uv, z = project_points(pc, cam.fx, cam.fy, cam.cx, cam.cy)
    dist = np.linalg.norm(pc, axis=-1)
    with np.errstate(invalid="ignore"):
        mask = (
            (z > cam.near_m)
            & (dist <= cam.max_range_m)
            & (uv[:, 0] >= 0)
            & (uv[:, 0] < cam.width)
            & (uv[:, 1] >= 0)
            & (uv[:, 1] < cam.height)
        )
    return mask, uv, pc


def _slab_interval(aa: FloatArray, da: FloatArray, h: FloatArray) -> tuple[FloatArray, FloatArray]:
    """Parameter interval [lo, hi] where aa + t da lies within |x| <= h along one axis (the
    arrays broadcast against each other; da has the full shape)."""
    parallel = np.abs(da) < _EPS
    ta = (-h - aa) / da
    tb = (h - aa) / da
    inside = np.abs(aa) <= h
    lo = np.where(parallel, np.where(inside, -np.inf, np.inf), np.minimum(ta, tb))
    hi = np.where(parallel, np.where(inside, np.inf, -np.inf), np.maximum(ta, tb))
    return lo, hi


def _blocked(
    t0: FloatArray, t1: FloatArray, z0: float, dz: FloatArray, height: FloatArray, t_max: float
) -> NDArray[np.bool_]:
    """Does the segment z(t) = z0 + t dz, t in (0, t_max), dip below `height` while inside?"""
    lo = np.maximum(t0, 0.0)
    hi = np.minimum(t1, t_max)
    inside = hi > lo
    # z is linear in t: its minimum over [lo, hi] is at one end.
    z_min = np.minimum(z0 + lo * dz, z0 + hi * dz)
    return inside & (z_min < height)


def occluded(
    camera_xyz: FloatArray,
    targets_xyz: FloatArray,
    obstacles: Obstacles,
    t_max: float = 1.0 - 1e-6,
) -> NDArray[np.bool_]:
    """For each target, whether the segment camera -> target crosses any obstacle prism."""
    targets = np.asarray(targets_xyz, dtype=np.float64).reshape(-1, 3)
    n = len(targets)
    if n == 0:
        return np.zeros(0, dtype=bool)
    c = np.asarray(camera_xyz, dtype=np.float64)
    d3 = targets - c  # (N, 3)
    d = d3[:, :2]
    dz = d3[:, 2]
    hit = np.zeros(n, dtype=bool)
    # A sight line parallel to a slab divides by zero; np.where then keeps the parallel answer.
    with np.errstate(divide="ignore", invalid="ignore"):
        if len(obstacles.box_xy):
            hit |= _boxes_blocked(c, d, dz, obstacles, t_max)
        if len(obstacles.disc_xy):
            hit |= _discs_blocked(c, d, dz, obstacles, t_max)
    return hit


def _boxes_blocked(
    c: FloatArray, d: FloatArray, dz: FloatArray, obstacles: Obstacles, t_max: float
) -> NDArray[np.bool_]:
    """Which sight lines from c along d (N, 2), dz (N,) a box crosses below its height: each
    box's slabs in its own axes, x across (right of its heading), y along its heading."""
    h = np.radians(obstacles.box_heading)
    s, co = np.sin(h), np.cos(h)
    rel = c[:2] - obstacles.box_xy  # (M, 2)
    dx, dy = d[:, None, 0], d[:, None, 1]  # (N, 1)
    lo_x, hi_x = _slab_interval(
        rel[:, 0] * co - rel[:, 1] * s, dx * co[None] - dy * s[None], obstacles.box_half[:, 0]
    )
    lo_y, hi_y = _slab_interval(
        rel[:, 0] * s + rel[:, 1] * co, dx * s[None] + dy * co[None], obstacles.box_half[:, 1]
    )
    t0, t1 = np.maximum(lo_x, lo_y), np.minimum(hi_x, hi_y)  # (N, M)
    return _blocked(t0, t1, c[2], dz[:, None], obstacles.box_height[None], t_max).any(axis=1)


def _discs_blocked(
    c: FloatArray, d: FloatArray, dz: FloatArray, obstacles: Obstacles, t_max: float
) -> NDArray[np.bool_]:
    """Which sight lines from c along d (N, 2), dz (N,) a disc crosses below its height."""
    rel = c[:2] - obstacles.disc_xy  # (M, 2)
    qa = np.einsum("ij,ij->i", d, d)[:, None]  # (N, 1)
    qb = 2.0 * (d @ rel.T)  # (N, M)
    qc = np.einsum("ij,ij->i", rel, rel)[None] - obstacles.disc_radius[None] ** 2
    disc = qb * qb - 4 * qa * qc
    ok = (disc >= 0) & (qa > _EPS)
    root = np.sqrt(np.where(ok, disc, 0.0))
    t0 = np.where(ok, (-qb - root) / (2 * qa), np.inf)
    t1 = np.where(ok, (-qb + root) / (2 * qa), -np.inf)
    return _blocked(t0, t1, c[2], dz[:, None], obstacles.disc_height[None], t_max).any(axis=1)


def visible(
    points_xyz: FloatArray,
    pose: CameraPose,
    cam: CameraConfig,
    obstacles: Obstacles,
) -> NDArray[np.bool_]:
    """Frustum, range and occlusion together: the mask of visible points."""
    pts = np.asarray(points_xyz, dtype=np.float64).reshape(-1, 3)
    mask, _, _ = in_frustum(pts, pose, cam)
    idx = np.flatnonzero(mask)
    if len(idx):
        mask[idx[occluded(pose.position, pts[idx], obstacles)]] = False
    return mask


def visible_among_rings(
    points_xyz: FloatArray,
    pose: CameraPose,
    cam: CameraConfig,
    obstacles: Obstacles,
    ring_radius: float,
    ring_thickness: float,
) -> NDArray[np.bool_]:
    """visible(), where every point is also a ring lying flat that can hide the others."""
    pts = np.asarray(points_xyz, dtype=np.float64).reshape(-1, 3)
    mask = visible(pts, pose, cam, obstacles)
    tops = pts[:, 2] + ring_thickness / 2
    for k in np.flatnonzero(mask):
        others = np.arange(len(pts)) != k
        rings = Obstacles(
            disc_xy=pts[others, :2],
            disc_radius=np.full(int(others.sum()), ring_radius),
            disc_height=tops[others],
        )
        mask[k] = not occluded(pose.position, pts[k : k + 1], rings)[0]
    return mask


def brute_force_visible(
    points_xyz: FloatArray,
    pose: CameraPose,
    cam: CameraConfig,
    obstacles: Obstacles,
    samples: int = 4000,
) -> NDArray[np.bool_]:
    """A slow, obviously-correct reference: test points along each sight line one by one."""
    out = []
    k = cam.fx, cam.fy, cam.cx, cam.cy
    for p in np.asarray(points_xyz, dtype=np.float64).reshape(-1, 3):
        pc = pose.rotation @ (p - pose.position)
        if pc[2] <= cam.near_m or math.dist(p, pose.position) > cam.max_range_m:
            out.append(False)
            continue
        u = k[0] * pc[0] / pc[2] + k[2]
        v = k[1] * pc[1] / pc[2] + k[3]
        if not (0 <= u < cam.width and 0 <= v < cam.height):
            out.append(False)
            continue
        seen = True
        for t in np.linspace(0.0, 1.0, samples, endpoint=False)[1:]:
            q = pose.position + t * (p - pose.position)
            if _point_in_obstacles(q, obstacles):
                seen = False
                break
        out.append(seen)
    return np.array(out, dtype=bool)


def _point_in_obstacles(q: FloatArray, obs: Obstacles) -> bool:
    for (x, y), hd, (hx, hy), hz in zip(
        obs.box_xy, obs.box_heading, obs.box_half, obs.box_height, strict=True
    ):
        if q[2] >= hz:
            continue
        h = math.radians(hd)
        rx, ry = q[0] - x, q[1] - y
        lx = rx * math.cos(h) - ry * math.sin(h)
        ly = rx * math.sin(h) + ry * math.cos(h)
        if abs(lx) <= hx and abs(ly) <= hy:
            return True
    for (x, y), r, hz in zip(obs.disc_xy, obs.disc_radius, obs.disc_height, strict=True):
        if q[2] < hz and (q[0] - x) ** 2 + (q[1] - y) ** 2 <= r * r:
            return True
    return False


# The robot detector's reach (jetson/perception/robots.py; tests/sim/test_robot_sight.py): a
# plate across a robot's front, PLATE_SHARE of its width and 8 cm tall, at half its height (the
# twin's robots: sim/world/physics.py), is found when it faces the camera showing at least
# PLATE_MIN_M of its length across the ray (the detector's min_width_m), within ROBOT_SIGHT_M of
# the lens, and at least PLATE_IN_PICTURE of PLATE_SAMPLES points along its lower edge are in
# the picture (the detector places a plate the image cuts from the end it sees; the camera looks
# down for rings, so far plates leave the picture's top edge bottom first).
PLATE_SHARE = 0.9
PLATE_MIN_M = 0.15
PLATE_EDGE_M = 0.03  # the sampled line: this far below the plate's middle (its half height 4 cm)
PLATE_SAMPLES = 9
PLATE_IN_PICTURE = 2
ROBOT_SIGHT_M = 2.0


def plates_in_view(
    x: FloatArray,
    y: FloatArray,
    heading_deg: FloatArray,
    turn_rad_s: FloatArray,
    cams: list[CameraConfig],
    sizes: FloatArray,
    goals_xy: FloatArray | None = None,
    goal_discs: FloatArray | None = None,
) -> NDArray[np.bool_]:
    """(B, R, R): whether robot i's camera sees robot j's licence plate in match b (never its
    own), from the robots' poses and turn rates (B, R), their cameras (R) and their sizes (R, 3:
    width, length, height, metres). A camera turning faster than its max_turn_rate_rad_s sees
    nothing (its picture is blurred), as for rings. A sampled point of the plate counts only
    where no other robot's body (a box) and no goal hides it: `goals_xy` (B, G, 2) and
    `goal_discs` (2G, 2: radius and height, the G bases then the G posts), the prisms of
    `occluded`; without goals only the robots hide plates."""
    n_robots = len(cams)
    rad = np.radians(heading_deg)
    fwd = np.stack([np.sin(rad), np.cos(rad)], -1)  # (B, R, 2)
    right = np.stack([fwd[..., 1], -fwd[..., 0]], -1)
    width, half_len, height = sizes[:, 0], sizes[:, 1] / 2, sizes[:, 2]
    plate = np.stack([x, y], -1) + fwd * half_len[None, :, None]  # robot j's plate middle

    def per_camera(values: list[float]) -> FloatArray:
        return np.asarray(values, dtype=np.float64)[None, :, None]  # robot i's, against j

    fwd_m = np.array([c.forward_m for c in cams])[None, :, None]
    right_m = np.array([c.right_m for c in cams])[None, :, None]
    lens = np.stack([x, y], -1) + fwd * fwd_m + right * right_m  # (B, R, 2): robot i's lens
    d = plate[:, None, :, :] - lens[:, :, None, :]  # (B, i, j, 2)
    # Points along robot j's plate (its right vector), (B, i, j, K, 2) from robot i's lens.
    along = np.linspace(-0.5, 0.5, PLATE_SAMPLES)[:, None] * PLATE_SHARE * width[:, None, None]
    pts = d[..., None, :] + along[None, None] * right[:, None, :, None, :]
    dz = (height / 2 - PLATE_EDGE_M)[None, None, :, None] - per_camera([c.height_m for c in cams])[
        ..., None
    ]
    f = np.einsum("bijkl,bil->bijk", pts, fwd)
    r = np.einsum("bijkl,bil->bijk", pts, right)
    tilt = np.radians([c.tilt_deg for c in cams])
    c, s = per_camera(list(np.cos(tilt)))[..., None], per_camera(list(np.sin(tilt)))[..., None]
    zc = c * f + s * dz  # the optical frame (jetson.autonomy.camera.robot_to_camera_rotation)
    yc = s * f - c * dz

    def cam_value(name: str) -> FloatArray:
        return per_camera([getattr(k, name) for k in cams])[..., None]

    with np.errstate(divide="ignore", invalid="ignore"):
        u = cam_value("fx") * r / zc + cam_value("cx")
        v = cam_value("fy") * yc / zc + cam_value("cy")
    in_picture = (
        (zc > cam_value("near_m"))
        & (u >= 0) & (u < cam_value("width"))
        & (v >= 0) & (v < cam_value("height"))
    )  # fmt: skip
    near = np.sqrt((d**2).sum(-1) + dz[..., 0] ** 2) <= ROBOT_SIGHT_M
    enough = in_picture.sum(-1) >= PLATE_IN_PICTURE
    # The plate faces the lens and shows enough of its length across the ray.
    flat = np.maximum(np.hypot(d[..., 0], d[..., 1]), _EPS)
    facing = -np.einsum("bijk,bjk->bij", d, fwd) / flat  # cos(plate normal, toward the lens)
    shows = PLATE_SHARE * width[None, None, :] * facing >= PLATE_MIN_M
    limit = [math.inf if k.max_turn_rate_rad_s is None else k.max_turn_rate_rad_s for k in cams]
    steady = np.abs(turn_rad_s) <= np.asarray(limit)[None, :]
    own = np.eye(n_robots, dtype=bool)[None]
    seen = enough & near & shows & steady[:, :, None] & ~own
    who = np.nonzero(seen)  # the few pairs left: the occlusion test runs on them only
    if len(who[0]):
        b, i, j = who
        lens3 = np.concatenate([lens[b, i], np.array([k.height_m for k in cams])[i, None]], -1)
        edge_xy = pts[who] + lens[b, i][:, None, :]  # (n, K, 2), field frame
        edge_z = np.broadcast_to(
            (height / 2 - PLATE_EDGE_M)[j][:, None, None], (*edge_xy.shape[:2], 1)
        )
        edge = np.concatenate([edge_xy, edge_z], -1)
        hidden = _plates_hidden(lens3, edge, who, x, y, heading_deg, sizes, goals_xy, goal_discs)
        seen[who] = (in_picture[who] & ~hidden).sum(-1) >= PLATE_IN_PICTURE
    return seen


def _plates_hidden(
    lens: FloatArray,
    edge: FloatArray,
    who: tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]],
    x: FloatArray,
    y: FloatArray,
    heading_deg: FloatArray,
    sizes: FloatArray,
    goals_xy: FloatArray | None,
    goal_discs: FloatArray | None,
) -> NDArray[np.bool_]:
    """(n, K): which of the sampled plate points `edge` (n, K, 3, field frame) the other robots'
    bodies or the goals hide from the lens `lens` (n, 3) of camera i, for the pairs `who`
    (match b, camera robot i, plate robot j): the prisms of sim.visibility.occluded."""
    b, i, j = who
    n, k = edge.shape[:2]
    d3 = edge - lens[:, None, :]  # (n, K, 3)
    d, dz = d3[..., :2], d3[..., 2]
    hit = np.zeros((n, k), dtype=bool)
    t_max = 1.0 - 1e-6
    with np.errstate(divide="ignore", invalid="ignore"):
        # The robots' bodies, but the camera's own and the plate's (the plate is on its face).
        index = np.arange(sizes.shape[0])[None]
        others = (index != i[:, None]) & (index != j[:, None])
        h = np.radians(heading_deg[b])  # (n, R)
        s, co = np.sin(h)[:, None], np.cos(h)[:, None]  # (n, 1, R)
        rel = lens[:, None, :2] - np.stack([x[b], y[b]], -1)  # (n, R, 2)
        rx = (rel[..., 0] * co[:, 0] - rel[..., 1] * s[:, 0])[:, None]  # (n, 1, R)
        ry = (rel[..., 0] * s[:, 0] + rel[..., 1] * co[:, 0])[:, None]
        dx, dy = d[..., 0][..., None], d[..., 1][..., None]  # (n, K, 1)
        lo_x, hi_x = _slab_interval(rx, dx * co - dy * s, sizes[:, 0] / 2)
        lo_y, hi_y = _slab_interval(ry, dx * s + dy * co, sizes[:, 1] / 2)
        t0, t1 = np.maximum(lo_x, lo_y), np.minimum(hi_x, hi_y)
        z0 = lens[:, 2][:, None, None]
        boxes = _blocked(t0, t1, z0, dz[..., None], sizes[:, 2], t_max)  # (n, K, R)
        hit |= (boxes & others[:, None, :]).any(-1)
        if goals_xy is not None and goal_discs is not None and goal_discs.size:
            centres = np.concatenate([goals_xy[b], goals_xy[b]], axis=1)  # bases, then posts
            relg = lens[:, None, :2] - centres  # (n, M, 2)
            qa = (d * d).sum(-1)[..., None]  # (n, K, 1)
            qb = 2.0 * np.einsum("nkc,nmc->nkm", d, relg)
            qc = (relg * relg).sum(-1)[:, None, :] - goal_discs[:, 0] ** 2
            disc = qb * qb - 4 * qa * qc
            ok = (disc >= 0) & (qa > _EPS)
            root = np.sqrt(np.where(ok, disc, 0.0))
            g0 = np.where(ok, (-qb - root) / (2 * qa), np.inf)
            g1 = np.where(ok, (-qb + root) / (2 * qa), -np.inf)
            hit |= _blocked(g0, g1, z0, dz[..., None], goal_discs[:, 1], t_max).any(-1)
    return hit
