"""The robot's RealSense as PyBullet renders it: RGB, metric depth and segmentation.

    frame = render_camera(world, robot_index)             # the robot's configured camera
    frame = render_camera(world, 0, cam.scaled(320, 240))  # another resolution, same optics
    rgb, depth = render_view(world, robot_index)          # the same, without the ground truth

The projection is built from the pinhole intrinsics (fx, fy, cx, cy), so a ring's pixel in the
render is where sim.visibility's projection puts it; depth is z along the optical axis in metres
(what a RealSense depth frame holds), 0 where nothing is within the far plane. Ring colours come
from the field file and stay inside the perception HSV window under this lighting (ambient 0.6 +
diffuse 0.4, no specular, so shading only scales brightness).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import pybullet as p

from jetson.autonomy.geometry import field_to_robot
from sim.config import CameraConfig
from sim.visibility import CameraPose
from sim.world import sensors
from sim.world.physics import World

LABEL_BACKGROUND = 0
LABEL_RING = 1
LABEL_GOAL = 2
LABEL_ROBOT = 3
LABELS = {"background": LABEL_BACKGROUND, "ring": LABEL_RING, "goal": LABEL_GOAL, "robot": 3}

_LIGHT = {
    "lightDirection": [0.3, -0.4, 1.0],
    "lightColor": [1.0, 1.0, 1.0],
    "lightAmbientCoeff": 0.6,
    "lightDiffuseCoeff": 0.4,
    "lightSpecularCoeff": 0.0,
    "shadow": 0,
}


@dataclass
class CameraFrame:
    """One rendered frame and its ground truth."""

    rgb: np.ndarray  # (H, W, 3) uint8
    depth: np.ndarray  # (H, W) float32 metres along the optical axis, 0 = no return
    labels: np.ndarray  # (H, W) uint8: LABEL_*
    ring_ids: np.ndarray  # (H, W) int16: ring index under each pixel, -1 elsewhere
    K: np.ndarray  # (3, 3) intrinsics of this frame
    pose: CameraPose
    visible: np.ndarray  # ring indices the geometric culling reports visible
    rings_robot_xy: np.ndarray  # (len(visible), 2) their positions in the robot frame
    time_s: float


def projection_matrix(cam: CameraConfig) -> list[float]:
    """OpenGL projection equal to the pinhole model with these intrinsics.

    Image row v grows downwards while OpenGL's y grows upwards, hence top = cy * near / fy.
    """
    n = cam.near_m * 0.5  # render a little nearer than the sensor's minimum range
    left = -cam.cx * n / cam.fx
    right = (cam.width - cam.cx) * n / cam.fx
    top = cam.cy * n / cam.fy
    bottom = -(cam.height - cam.cy) * n / cam.fy
    return list(p.computeProjectionMatrix(left, right, bottom, top, n, cam.far_m))


def view_matrix(pose: CameraPose) -> list[float]:
    forward = pose.rotation[2]
    up = -pose.rotation[1]
    eye = pose.position
    return list(p.computeViewMatrix(eye.tolist(), (eye + forward).tolist(), up.tolist()))


def _render(
    world: World, pose: CameraPose, cam: CameraConfig, segment: bool
) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
    """(rgb, depth, PyBullet's segmentation or None) of a camera at `pose` now."""
    world.ensure_ring_visuals()
    near = cam.near_m * 0.5
    _, _, rgba, zbuf, seg = p.getCameraImage(
        cam.width,
        cam.height,
        view_matrix(pose),
        projection_matrix(cam),
        renderer=p.ER_TINY_RENDERER,
        flags=0 if segment else p.ER_NO_SEGMENTATION_MASK,
        physicsClientId=world.client,
        **_LIGHT,
    )
    rgb = np.asarray(rgba, dtype=np.uint8).reshape(cam.height, cam.width, 4)[:, :, :3].copy()
    z = np.asarray(zbuf, dtype=np.float32).reshape(cam.height, cam.width)
    far = cam.far_m
    depth = (far * near / (far - (far - near) * z)).astype(np.float32)
    depth[z >= 1.0 - 1e-7] = 0.0
    if not segment:
        return rgb, depth, None
    return rgb, depth, np.asarray(seg, dtype=np.int64).reshape(cam.height, cam.width)


def render_view(
    world: World, index: int, cam: CameraConfig | None = None
) -> tuple[np.ndarray, np.ndarray]:
    """(rgb, depth) of robot `index`'s camera as render_camera gives them, without the ground
    truth (the renderer skips its segmentation: a frame for a daemon nobody scores)."""
    cam = cam or world.robots[index].config.camera
    rgb, depth, _ = _render(world, sensors.camera_pose(world, index), cam, False)
    return rgb, depth


def render_camera(world: World, index: int, cam: CameraConfig | None = None) -> CameraFrame:
    """Render robot `index`'s camera view of the world as it is now."""
    robot = world.robots[index]
    cam = cam or robot.config.camera
    pose = sensors.camera_pose(world, index)
    rgb, depth, seg = _render(world, pose, cam, True)
    assert seg is not None
    labels = np.zeros(seg.shape, dtype=np.uint8)
    ring_ids = np.full(seg.shape, -1, dtype=np.int16)
    lut_size = int(seg.max()) + 2 if seg.size else 1
    kind_lut = np.zeros(lut_size, dtype=np.uint8)
    ring_lut = np.full(lut_size, -1, dtype=np.int16)
    codes = {"ring": LABEL_RING, "goal": LABEL_GOAL, "robot": LABEL_ROBOT}
    for body, (kind, i) in world.body_kinds().items():
        if body < lut_size:
            kind_lut[body] = codes[kind]
            if kind == "ring":
                ring_lut[body] = i
    valid = seg >= 0
    labels[valid] = kind_lut[seg[valid]]
    ring_ids[valid] = ring_lut[seg[valid]]
    vis = sensors.visible_rings(world, index)
    xy = field_to_robot(world.ring_xy[vis], robot.xy, robot.heading)
    return CameraFrame(
        rgb, depth, labels, ring_ids, cam.intrinsics.matrix, pose, vis, xy, world.time_s
    )


def rgb_to_hsv_opencv(rgb: np.ndarray) -> np.ndarray:
    """uint8 RGB -> HSV on OpenCV's 8-bit scales (H 0-179, S and V 0-255), in numpy.

    The simulator does not depend on OpenCV; tests use this to check ring colours against the
    perception window.
    """
    c = rgb.astype(np.float64)
    r, g, b = c[..., 0], c[..., 1], c[..., 2]
    v = c.max(axis=-1)
    mn = c.min(axis=-1)
    delta = v - mn
    s = np.where(v > 0, delta / np.where(v > 0, v, 1) * 255.0, 0.0)
    safe = np.where(delta > 0, delta, 1.0)
    h = np.where(
        v == r,
        60.0 * (g - b) / safe,
        np.where(v == g, 120.0 + 60.0 * (b - r) / safe, 240.0 + 60.0 * (r - g) / safe),
    )
    h = np.where(delta > 0, np.mod(h, 360.0), 0.0)
    return np.stack([np.round(h / 2.0), np.round(s), v], axis=-1)
