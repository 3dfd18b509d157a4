"""Synthetic ring scenes with exact ground truth, rendered in numpy (no simulator needed).

A camera on the robot's mount looks at a floor of grey tiles with tape lines, painted clutter,
box-shaped obstacles and a far wall; rings are tori (4 in outer, 2 in inner diameter) lying on the
floor or tipped over, in random purples inside the pre-filter's HSV window. Each ring is found by
sphere tracing its signed distance function, so the colour, the depth along the optical axis and
the per-ring pixel masks are exact; depth then gets D435-like noise, dropouts at edges, and mm
quantisation.

Tests use it for frames with known boxes and positions; `pete-jetson detector synth` writes it as
a dataset folder (jetson/perception/dataset.py) so training and the benchmark can use it until the
simulator's own renders (`pete-sim dataset`) replace it.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field

import cv2
import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import CameraMount, Intrinsics
from jetson.perception.detection import RING_MAJOR_M, RING_MINOR_M, RING_OUTER_M
from jetson.perception.frame import Frame, depth_from_mm, depth_to_mm

FloatArray = NDArray[np.float64]

# Clutter colours (BGR) chosen outside the ring window: goal red, blue and yellow, robot metal,
# tile seams, and a magenta-ish red (H 173) that sits just outside the window's hue.
_CLUTTER_BGR = [
    (45, 40, 200),
    (190, 80, 30),
    (30, 190, 225),
    (150, 150, 150),
    (60, 60, 60),
    (230, 230, 230),
    (80, 40, 200),
    (40, 140, 40),
]


@dataclass(frozen=True)
class Ring:
    """A ring in the robot frame: centre (x right, y forward, z up), axis tilt from vertical
    (0 = lying flat) about a horizontal direction at `tilt_azimuth_rad`, and its colour (BGR)."""

    x: float
    y: float
    z: float = RING_MINOR_M
    tilt_rad: float = 0.0
    tilt_azimuth_rad: float = 0.0
    bgr: tuple[int, int, int] = (200, 80, 160)

    def rotation(self) -> FloatArray:
        """Ring-local (axis = local z) to robot frame."""
        a, t = self.tilt_azimuth_rad, self.tilt_rad
        ca, sa, ct, st = math.cos(a), math.sin(a), math.cos(t), math.sin(t)
        rz = np.array([[ca, -sa, 0.0], [sa, ca, 0.0], [0.0, 0.0, 1.0]])
        rx = np.array([[1.0, 0.0, 0.0], [0.0, ct, -st], [0.0, st, ct]])
        return rz @ rx @ rz.T


@dataclass(frozen=True)
class Obstacle:
    """An axis-aligned box standing on the floor, robot frame, with a colour (BGR)."""

    lo: tuple[float, float, float]
    hi: tuple[float, float, float]
    bgr: tuple[int, int, int]


@dataclass(frozen=True)
class Lighting:
    direction: tuple[float, float, float] = (0.3, -0.4, 1.0)  # towards the light, robot frame
    ambient: float = 0.45
    gain: float = 1.0


@dataclass
class Scene:
    rings: list[Ring] = field(default_factory=list)
    obstacles: list[Obstacle] = field(default_factory=list)
    floor_bgr: tuple[int, int, int] = (130, 128, 128)
    wall_y_m: float = 5.0
    wall_bgr: tuple[int, int, int] = (210, 200, 190)
    tape_x_m: tuple[float, ...] = ()
    paint: list[tuple[float, float, float, tuple[int, int, int]]] = field(default_factory=list)
    lighting: Lighting = field(default_factory=Lighting)
    mottle: float = 0.0  # relative amplitude of low-frequency brightness variation on the floor
    mottle_phase: tuple[float, float, float] = (0.0, 0.0, 0.0)


@dataclass
class Rendered:
    """A rendered frame and its ground truth.

    boxes (N, 4): visible extent of each labelled ring in pixels (x0, y0, x1, y1, x1/y1
    exclusive); rings_robot_xy (N, 2): their centres in the robot frame (x right, y forward);
    ring_ids (N,): their indices into the scene's ring list. Rings too occluded or too small to
    label are left out of all three; the visible extent of each of those is in ignore_boxes
    (M, 4), which training counts as neither ring nor background.
    """

    frame: Frame
    boxes: FloatArray
    rings_robot_xy: FloatArray
    ring_ids: NDArray[np.int64]
    id_buffer: NDArray[np.int32]  # per pixel: index of the ring seen there, or -1
    ignore_boxes: FloatArray = field(default_factory=lambda: np.zeros((0, 4)))


def _rays(intr: Intrinsics, mount: CameraMount) -> tuple[FloatArray, FloatArray]:
    """Robot-frame ray directions (H, W, 3), scaled so the parameter t is optical-axis depth."""
    u = np.arange(intr.width, dtype=np.float64)
    v = np.arange(intr.height, dtype=np.float64)
    uu, vv = np.meshgrid(u, v)
    cam = np.stack([(uu - intr.cx) / intr.fx, (vv - intr.cy) / intr.fy, np.ones_like(uu)], axis=-1)
    return cam @ mount.robot_to_camera, mount.position


def _shade(base_bgr: FloatArray, normals: FloatArray, light: Lighting) -> FloatArray:
    ld = np.asarray(light.direction, dtype=np.float64)
    ld = ld / np.linalg.norm(ld)
    lambert = np.clip(normals @ ld, 0.0, 1.0)
    k = light.gain * (light.ambient + (1.0 - light.ambient) * lambert)
    return base_bgr * k[..., None]


def _trace_ring(
    ring: Ring,
    intr: Intrinsics,
    mount: CameraMount,
    rays: FloatArray,
    origin: FloatArray,
) -> tuple[tuple[slice, slice], NDArray[np.bool_], FloatArray, FloatArray] | None:
    """Sphere-trace one ring inside its projected bounding window.

    Returns the window, the hit mask, depth and robot-frame normals in it, or None when the
    ring is behind the camera or outside the image.
    """
    centre = np.array([ring.x, ring.y, ring.z])
    c_cam = mount.robot_to_camera_points(centre)
    bound = RING_MAJOR_M + RING_MINOR_M
    if c_cam[2] <= bound + 0.02:
        return None
    u = intr.fx * c_cam[0] / c_cam[2] + intr.cx
    v = intr.fy * c_cam[1] / c_cam[2] + intr.cy
    z_near = c_cam[2] - bound
    half_u = intr.fx * bound / z_near * 1.15 + 2
    half_v = intr.fy * bound / z_near * 1.15 + 2
    u0, u1 = max(0, int(u - half_u)), min(intr.width, math.ceil(u + half_u) + 1)
    v0, v1 = max(0, int(v - half_v)), min(intr.height, math.ceil(v + half_v) + 1)
    if u0 >= u1 or v0 >= v1:
        return None
    win = (slice(v0, v1), slice(u0, u1))
    d = rays[win]
    dn = np.linalg.norm(d, axis=-1)
    rot = ring.rotation()
    # Local coordinates: (p - c) @ rot, since rot's columns are the local axes in robot frame.
    o_local = (origin - centre) @ rot
    d_local = d @ rot
    # Start where the ray enters the bounding sphere.
    b = np.einsum("...i,...i->...", d_local, o_local)
    a = dn * dn
    cterm = o_local @ o_local - (bound * 1.01) ** 2
    disc = b * b - a * cterm
    inside = disc > 0
    t = np.where(inside, (-b - np.sqrt(np.where(inside, disc, 0.0))) / a, np.inf)
    t_exit = np.where(inside, (-b + np.sqrt(np.where(inside, disc, 0.0))) / a, -np.inf)
    t = np.maximum(t, 1e-3)
    active = inside.copy()
    hit = np.zeros_like(inside)
    for _ in range(48):
        if not active.any():
            break
        p = o_local + t[..., None] * d_local
        rho = np.hypot(p[..., 0], p[..., 1])
        dist = np.hypot(rho - RING_MAJOR_M, p[..., 2]) - RING_MINOR_M
        newly = active & (dist < 2e-5)
        hit |= newly
        active &= ~newly
        t = np.where(active, t + dist / dn, t)
        active &= t < t_exit
    if not hit.any():
        return None
    t = np.where(hit, t, 0.0)
    p = o_local + t[..., None] * d_local
    rho = np.maximum(np.hypot(p[..., 0], p[..., 1]), 1e-9)
    qx = rho - RING_MAJOR_M
    n_local = np.stack([p[..., 0] / rho * qx, p[..., 1] / rho * qx, p[..., 2]], axis=-1)
    n_local /= np.maximum(np.linalg.norm(n_local, axis=-1, keepdims=True), 1e-12)
    normals = n_local @ rot.T
    return win, hit, t, normals


def _trace_boxes(
    obstacles: list[Obstacle], rays: FloatArray, origin: FloatArray
) -> tuple[FloatArray, NDArray[np.int64], FloatArray]:
    """Nearest obstacle hit per pixel: depth (inf where none), index, normal."""
    h, w = rays.shape[:2]
    best = np.full((h, w), np.inf)
    idx = np.full((h, w), -1, dtype=np.int64)
    normal = np.zeros((h, w, 3))
    with np.errstate(divide="ignore", invalid="ignore"):
        inv = 1.0 / rays
    for i, ob in enumerate(obstacles):
        lo = (np.asarray(ob.lo) - origin) * inv
        hi = (np.asarray(ob.hi) - origin) * inv
        tmin = np.minimum(lo, hi)
        tmax = np.maximum(lo, hi)
        tmin = np.nan_to_num(tmin, nan=-np.inf)
        tmax = np.nan_to_num(tmax, nan=np.inf)
        t_in = tmin.max(axis=-1)
        t_out = tmax.min(axis=-1)
        ok = (t_in <= t_out) & (t_in > 0) & (t_in < best)
        if not ok.any():
            continue
        axis = tmin.argmax(axis=-1)
        n = np.zeros((h, w, 3))
        sign = -np.sign(np.take_along_axis(rays, axis[..., None], axis=-1))[..., 0]
        np.put_along_axis(n, axis[..., None], sign[..., None], axis=-1)
        best = np.where(ok, t_in, best)
        idx = np.where(ok, i, idx)
        normal = np.where(ok[..., None], n, normal)
    return best, idx, normal


def render(
    scene: Scene,
    intr: Intrinsics,
    mount: CameraMount,
    rng: np.random.Generator | None = None,
    *,
    depth_noise: bool = True,
    min_visible_px: int = 40,
    min_visible_fraction: float = 0.35,
    timestamp_s: float = 0.0,
    index: int = 0,
) -> Rendered:
    """Render `scene` from the camera; `rng` adds sensor noise (None: noise-free).

    A ring is labelled when at least min_visible_px pixels (at 640x480; scaled with the image
    area) and min_visible_fraction of its own unoccluded pixels are visible: a sliver at the
    image's edge or behind another ring is no ring to act on, for a detector or a person.
    """
    rays, origin = _rays(intr, mount)
    h, w = intr.height, intr.width
    dz = rays[..., 2]
    with np.errstate(divide="ignore", invalid="ignore"):
        t_floor = np.where(dz < -1e-9, -origin[2] / dz, np.inf)
        dy = rays[..., 1]
        t_wall = np.where(dy > 1e-9, (scene.wall_y_m - origin[1]) / dy, np.inf)
    depth = np.minimum(t_floor, t_wall)
    on_floor = t_floor <= t_wall
    hit = origin + np.where(np.isfinite(depth), depth, 0.0)[..., None] * rays

    # Floor: tiles with dark seams every 2 ft, tape lines, painted clutter.
    colour = np.empty((h, w, 3))
    colour[:] = np.asarray(scene.floor_bgr, dtype=np.float64)
    fx_, fy_ = hit[..., 0], hit[..., 1]
    tile = 0.6096
    seam = (np.abs((fx_ / tile) - np.round(fx_ / tile)) * tile < 0.004) | (
        np.abs((fy_ / tile) - np.round(fy_ / tile)) * tile < 0.004
    )
    colour[seam & on_floor] *= 0.8
    if scene.mottle > 0:
        a, b, c = scene.mottle_phase
        wave = np.sin(7.0 * fx_ + a) * np.sin(5.0 * fy_ + b) + 0.5 * np.sin(23.0 * (fx_ + fy_) + c)
        colour *= (1.0 + scene.mottle * wave / 1.5)[..., None]
    for tx in scene.tape_x_m:
        colour[(np.abs(fx_ - tx) < 0.025) & on_floor] = (235, 235, 235)
    for px, py, pr, bgr in scene.paint:
        colour[(np.hypot(fx_ - px, fy_ - py) < pr) & on_floor] = bgr
    colour[~on_floor] = scene.wall_bgr
    normals = np.zeros((h, w, 3))
    normals[..., 2] = np.where(on_floor, 1.0, 0.0)
    normals[..., 1] = np.where(on_floor, 0.0, -1.0)

    t_box, box_idx, box_n = _trace_boxes(scene.obstacles, rays, origin)
    use_box = t_box < depth
    if use_box.any():
        depth = np.where(use_box, t_box, depth)
        for i, ob in enumerate(scene.obstacles):
            colour[use_box & (box_idx == i)] = ob.bgr
        normals = np.where(use_box[..., None], box_n, normals)

    ids = np.full((h, w), -1, dtype=np.int32)
    own_px = np.zeros(len(scene.rings), dtype=np.int64)
    for i, ring in enumerate(scene.rings):
        traced = _trace_ring(ring, intr, mount, rays, origin)
        if traced is None:
            continue
        win, ring_hit, t, n = traced
        own_px[i] = int(ring_hit.sum())
        closer = ring_hit & (t < depth[win])
        depth[win] = np.where(closer, t, depth[win])
        ids[win] = np.where(closer, i, ids[win])
        colour[win] = np.where(closer[..., None], np.asarray(ring.bgr, np.float64), colour[win])
        normals[win] = np.where(closer[..., None], n, normals[win])

    img = _shade(colour, normals, scene.lighting)
    if rng is not None:
        img += rng.normal(0.0, rng.uniform(1.0, 5.0), img.shape)
    bgr = np.clip(img, 0, 255).astype(np.uint8)
    if rng is not None and rng.random() < 0.3:
        sigma = rng.uniform(0.4, 1.2)
        bgr = cv2.GaussianBlur(bgr, (0, 0), sigma)

    depth_m = np.where(np.isfinite(depth) & (depth < 10.0), depth, 0.0)
    if rng is not None and depth_noise:
        depth_m = _depth_noise(depth_m, rng)
    depth_m = depth_from_mm(depth_to_mm(depth_m))

    boxes, xy, keep, ignore = [], [], [], []
    min_px = min_visible_px * (w * h) / (640 * 480)
    for i, ring in enumerate(scene.rings):
        vis = ids == i
        n_vis = int(vis.sum())
        if n_vis == 0:
            continue
        ys, xs = np.nonzero(vis)
        box = [xs.min(), ys.min(), xs.max() + 1, ys.max() + 1]
        if n_vis < min_px or n_vis < min_visible_fraction * max(own_px[i], 1):
            ignore.append(box)
            continue
        boxes.append(box)
        xy.append([ring.x, ring.y])
        keep.append(i)
    frame = Frame(bgr, depth_m.astype(np.float32), intr, timestamp_s, index)
    return Rendered(
        frame=frame,
        boxes=np.asarray(boxes, dtype=np.float64).reshape(-1, 4),
        rings_robot_xy=np.asarray(xy, dtype=np.float64).reshape(-1, 2),
        ring_ids=np.asarray(keep, dtype=np.int64),
        id_buffer=ids,
        ignore_boxes=np.asarray(ignore, dtype=np.float64).reshape(-1, 4),
    )


def _depth_noise(depth_m: FloatArray, rng: np.random.Generator) -> FloatArray:
    """D435-like: error growing with the square of distance (~0.5 % at 2 m), no reading at
    sharp depth edges and at a few random pixels."""
    noisy = depth_m + rng.normal(0.0, 1.0, depth_m.shape) * 0.0025 * depth_m**2
    gy, gx = np.gradient(depth_m)
    edge = np.hypot(gx, gy) > 0.05
    drop = (edge & (rng.random(depth_m.shape) < 0.6)) | (rng.random(depth_m.shape) < 0.01)
    return np.where(drop | (depth_m <= 0), 0.0, noisy)


def ring_purple(rng: np.random.Generator) -> tuple[int, int, int]:
    """A random ring colour (BGR) whose lit face falls inside the HSV window."""
    hue = rng.uniform(128, 162)  # OpenCV scale
    sat = rng.uniform(80, 185)
    val = rng.uniform(170, 250)
    hsv = np.array([[[hue, sat, val]]], dtype=np.uint8)
    b, g, r = cv2.cvtColor(hsv, cv2.COLOR_HSV2BGR)[0, 0]
    return int(b), int(g), int(r)


def random_scene(
    rng: np.random.Generator,
    intr: Intrinsics,
    mount: CameraMount,
    *,
    max_rings: int = 8,
    max_range_m: float = 3.0,
    decoys: bool = False,
) -> Scene:
    """A random floor scene: 0..max_rings rings (some in clusters, some tipped), clutter.

    decoys adds, now and then, ring-coloured things that are not rings (flat discs, boxes), so a
    CNN trained on the scenes learns the shape and not just the colour.
    """
    half_fov = math.atan(intr.width / (2 * intr.fx))
    rings: list[Ring] = []

    def free(x: float, y: float) -> bool:
        return all(math.hypot(x - r.x, y - r.y) > RING_OUTER_M * 1.02 for r in rings)

    def place(x: float, y: float) -> None:
        if not free(x, y):
            return
        tipped = rng.random() < 0.12
        tilt = rng.uniform(0.3, 1.5) if tipped else rng.uniform(0.0, 0.08)
        z = RING_MAJOR_M * math.sin(tilt) + RING_MINOR_M * math.cos(tilt)
        rings.append(Ring(x, y, z, tilt, rng.uniform(0, 2 * math.pi), ring_purple(rng)))

    n = int(rng.integers(0, max_rings + 1))
    while len(rings) < n:
        y = rng.uniform(0.35, max_range_m)
        lateral = (y - mount.forward_m) * math.tan(half_fov) * 1.1
        x = rng.uniform(-lateral, lateral)
        if rng.random() < 0.3:  # a row of touching rings, as they lie after a match starts
            ang = rng.uniform(0, 2 * math.pi)
            for k in range(int(rng.integers(2, 5))):
                step = RING_OUTER_M * 1.05 * k
                place(x + step * math.cos(ang), y + step * math.sin(ang))
        else:
            place(x, y)
        if len(rings) >= n:
            break
    rings = rings[: max(n, 0)]

    obstacles = []
    for _ in range(int(rng.integers(0, 3))):
        y = rng.uniform(0.8, 4.0)
        x = rng.uniform(-1.5, 1.5)
        sx, sy, sz = rng.uniform(0.1, 0.45), rng.uniform(0.1, 0.45), rng.uniform(0.05, 0.5)
        bgr = _CLUTTER_BGR[int(rng.integers(len(_CLUTTER_BGR)))]
        obstacles.append(Obstacle((x - sx / 2, y - sy / 2, 0.0), (x + sx / 2, y + sy / 2, sz), bgr))

    paint = []
    for _ in range(int(rng.integers(0, 5))):
        bgr = _CLUTTER_BGR[int(rng.integers(len(_CLUTTER_BGR)))]
        paint.append((rng.uniform(-1.5, 1.5), rng.uniform(0.4, 4.0), rng.uniform(0.03, 0.2), bgr))
    if decoys and rng.random() < 0.35:
        for _ in range(int(rng.integers(1, 3))):
            purple = ring_purple(rng)
            if rng.random() < 0.5:
                y, r = rng.uniform(0.4, 2.5), rng.uniform(0.02, 0.12)
                paint.append((rng.uniform(-1.0, 1.0), y, r, purple))
            else:
                x, y = rng.uniform(-1.2, 1.2), rng.uniform(0.8, 3.0)
                s = rng.uniform(0.05, 0.3)
                obstacles.append(Obstacle((x - s, y - s, 0.0), (x + s, y + s, 2 * s), purple))
    grey = rng.uniform(90, 170)
    floor = (
        int(grey + rng.uniform(-4, 4)),
        int(grey + rng.uniform(-4, 4)),
        int(grey + rng.uniform(-4, 4)),
    )
    tape = tuple(float(x) for x in rng.uniform(-1.5, 1.5, int(rng.integers(0, 3))))
    light = Lighting(
        direction=(rng.uniform(-1, 1), rng.uniform(-1, 1), rng.uniform(0.5, 2.0)),
        ambient=rng.uniform(0.4, 0.75),  # indoor light is mostly diffuse
        gain=rng.uniform(0.8, 1.15),
    )
    wall = tuple(int(c) for c in rng.uniform(60, 230, 3))
    return Scene(
        rings=rings,
        obstacles=obstacles,
        floor_bgr=floor,
        wall_y_m=float(rng.uniform(3.5, 7.0)),
        wall_bgr=(wall[0], wall[1], wall[2]),
        tape_x_m=tape,
        paint=paint,
        lighting=light,
        mottle=float(rng.uniform(0.0, 0.12)),
        mottle_phase=(
            float(rng.uniform(0, 6.3)),
            float(rng.uniform(0, 6.3)),
            float(rng.uniform(0, 6.3)),
        ),
    )


def random_frame(
    rng: np.random.Generator,
    intr: Intrinsics | None = None,
    mount: CameraMount | None = None,
    *,
    max_rings: int = 8,
    index: int = 0,
    decoys: bool = False,
) -> Rendered:
    """One random scene rendered with sensor noise."""
    intr = intr or Intrinsics()
    mount = mount or CameraMount()
    scene = random_scene(rng, intr, mount, max_rings=max_rings, decoys=decoys)
    return render(scene, intr, mount, rng, index=index, timestamp_s=index / 30.0)
