"""Which rings the camera sees, checked against slow references; and the rendered camera."""

from __future__ import annotations

import numpy as np
import pytest

from jetson.autonomy.camera import project_points
from sim.camera import LABEL_RING, render_camera, render_view, rgb_to_hsv_opencv
from sim.config import CameraConfig, WorldConfig, merge
from sim.visibility import (
    Obstacles,
    brute_force_visible,
    camera_pose,
    in_frustum,
    occluded,
    visible,
    visible_among_rings,
)
from sim.world import sensors
from sim.world.physics import World
from sim.world.state import RING_FLOOR

CAM = CameraConfig()


def test_numpy_culling_matches_brute_force_on_random_scenes() -> None:
    rng = np.random.default_rng(11)
    seen = 0
    hidden_by_obstacle = 0
    for _ in range(12):
        boxes = [
            (*rng.uniform(-1.5, 1.5, 2), rng.uniform(0, 360), 0.19, 0.19, 0.3) for _ in range(3)
        ]
        discs = [(*rng.uniform(-1.5, 1.5, 2), 0.165, 0.076) for _ in range(7)]
        discs += [(*rng.uniform(-1.5, 1.5, 2), 0.025, 0.6) for _ in range(3)]
        obs = Obstacles.build(boxes, discs)
        pose = camera_pose(tuple(rng.uniform(-1.2, 1.2, 2)), rng.uniform(0, 360), CAM)
        pts = np.column_stack([rng.uniform(-1.8, 1.8, (50, 2)), np.full(50, 0.0127)])
        fast = visible(pts, pose, CAM, obs)
        slow = brute_force_visible(pts, pose, CAM, obs, samples=1500)
        assert np.array_equal(fast, slow)
        seen += int(fast.sum())
        frustum, _, _ = in_frustum(pts, pose, CAM)
        hidden_by_obstacle += int((frustum & ~fast).sum())
    assert seen > 20 and hidden_by_obstacle > 3, "the scenes must exercise both outcomes"


def test_frustum_edges_and_range() -> None:
    pose = camera_pose((0.0, 0.0), 0.0, CAM)  # looking along +y, 0.3 m up, 30 deg down
    # Straight ahead on the floor where the optical axis meets it: the principal point.
    d = CAM.height_m / np.tan(np.radians(30))
    on_axis = np.array([[0.0, CAM.forward_m + d, 0.0]])
    mask, uv, _ = in_frustum(on_axis, pose, CAM)
    assert mask[0] and uv[0] == pytest.approx([CAM.cx, CAM.cy], abs=1e-6)
    behind = np.array([[0.0, -1.0, 0.0]])
    far = np.array([[0.0, CAM.forward_m + 3.5, 0.0]])
    wide = np.array([[2.0, 0.8, 0.0]])
    close = np.array([[0.0, CAM.forward_m + 0.05, 0.0]])  # under the camera: below the image
    for p in (behind, far, wide, close):
        assert not in_frustum(p, pose, CAM)[0][0]


def test_tall_post_hides_what_is_behind_it_but_a_low_base_does_not_hide_far_rings() -> None:
    pose = camera_pose((0.0, 0.0), 0.0, CAM)
    target = np.array([[0.0, 1.6, 0.0127]])
    post = Obstacles.build([], [(0.0, 0.9, 0.025, 0.6)])
    base = Obstacles.build([], [(0.0, 0.9, 0.165, 0.02)])
    assert occluded(pose.position, target, post)[0]
    assert not occluded(pose.position, target, base)[0]


def test_sight_lines_along_a_box_side_match_brute_force() -> None:
    """A sight line parallel to a box's side (no slab crossing to divide by) is blocked when it
    runs on or inside the side, clear outside it, as the sampled reference says."""
    box = Obstacles.build([(0.0, 1.0, 0.0, 0.19, 0.19, 0.3)], [])
    ys = np.linspace(1.4, 2.0, 4)  # straight ahead, in the image and in range
    for x, hidden in ((0.0, True), (0.19, True), (0.19 + 1e-6, False), (0.3, False)):
        pose = camera_pose((x, 0.0), 0.0, CAM)  # looking along +y, beside or behind the box
        pts = np.column_stack([np.full(len(ys), x), ys, np.full(len(ys), 0.0127)])
        assert in_frustum(pts, pose, CAM)[0].all()
        assert occluded(pose.position, pts, box).tolist() == [hidden] * len(ys), x
        fast = visible(pts, pose, CAM, box)
        assert np.array_equal(fast, brute_force_visible(pts, pose, CAM, box, samples=1500)), x


def test_world_culling_matches_brute_force() -> None:
    rng = np.random.default_rng(2)
    with World(WorldConfig()) as w:
        w.reset(rng)
        agree = total = nvis = 0
        for _ in range(8):
            for i in range(2):
                w.place_robot(i, *rng.uniform(-1.4, 1.4, 2), rng.uniform(0, 360))
            for i in range(2):
                fast = set(sensors.visible_rings(w, i).tolist())
                floor = np.flatnonzero(w.ring_state == RING_FLOOR)
                pts = np.column_stack([w.ring_xy[floor], w.ring_z[floor]])
                slow = brute_force_visible(
                    pts,
                    sensors.camera_pose(w, i),
                    w.robots[i].config.camera,
                    sensors.obstacles(w, i),
                    800,
                )
                slow_set = set(floor[slow].tolist())
                agree += int(fast == slow_set)
                total += 1
                nvis += len(fast)
        assert agree == total and nvis > 10


def test_high_fidelity_ray_tests_agree_with_the_geometry() -> None:
    """PyBullet rays against real bodies and the numpy prisms (rings hiding rings included, as
    rays see them) must agree."""
    rng = np.random.default_rng(4)
    with World(WorldConfig(fidelity="high")) as w:
        w.reset(rng)
        both = differ = 0
        for _ in range(10):
            for i in range(2):
                w.place_robot(i, *rng.uniform(-1.3, 1.3, 2), rng.uniform(0, 360))
            for i in range(2):
                rays = set(sensors.visible_rings(w, i).tolist())
                floor = np.flatnonzero(w.ring_state == RING_FLOOR)
                pts = np.column_stack([w.ring_xy[floor], w.ring_z[floor]])
                cam = w.robots[i].config.camera
                pose = sensors.camera_pose(w, i)
                ring = w.field.ring
                geo = visible_among_rings(
                    pts, pose, cam, sensors.obstacles(w, i), ring.radius, ring.thickness
                )
                geo_set = set(floor[geo].tolist())
                both += len(rays | geo_set)
                differ += len(rays ^ geo_set)
        assert both > 10
        assert differ <= 0.05 * both, f"{differ} of {both} rings disagree"


def test_turning_fast_hides_everything_when_configured() -> None:
    cfg = merge(
        WorldConfig(blue=()), {"robots": {"15in": {"camera": {"max_turn_rate_rad_s": 0.5}}}}
    )
    assert cfg.robots["15in"].camera.fx == CAM.fx, "merging keeps the other camera values"
    with World(cfg) as w:
        w.reset()
        w.place_robot(0, -1.0, 0.3, 90.0)
        assert len(sensors.visible_rings(w, 0)) > 0
        w.robots[0].w = 1.0
        assert len(sensors.visible_rings(w, 0)) == 0


@pytest.fixture(scope="module")
def frame():
    with World(WorldConfig(blue=())) as w:
        w.reset()
        w.place_robot(0, -0.9, 0.9, 100.0)
        cam = w.robots[0].config.camera.scaled(320, 240)
        yield w, render_camera(w, 0, cam), cam


def test_render_shapes_and_types(frame) -> None:
    _, f, cam = frame
    assert f.rgb.shape == (240, 320, 3) and f.rgb.dtype == np.uint8
    assert f.depth.shape == (240, 320) and f.depth.dtype == np.float32
    assert f.labels.shape == f.ring_ids.shape == (240, 320)
    assert np.allclose(f.K, [[cam.fx, 0, cam.cx], [0, cam.fy, cam.cy], [0, 0, 1]])
    assert len(f.visible) >= 3


def test_the_view_without_truth_is_the_same_picture(frame) -> None:
    # render_view skips the renderer's segmentation (the partner's frames on the full stack):
    # the colour and depth a daemon gets are render_camera's, pixel for pixel.
    w, f, cam = frame
    rgb, depth = render_view(w, 0, cam)
    assert np.array_equal(rgb, f.rgb) and np.array_equal(depth, f.depth)


def test_rendered_rings_fall_inside_the_perception_hsv_window(frame) -> None:
    _, f, _ = frame
    hsv = rgb_to_hsv_opencv(f.rgb)
    window = (
        (hsv[..., 0] >= 123)
        & (hsv[..., 0] <= 169)
        & (hsv[..., 1] >= 39)
        & (hsv[..., 1] <= 192)
        & (hsv[..., 2] >= 76)
    )
    rings = f.labels == LABEL_RING
    assert rings.sum() > 200
    assert window[rings].mean() > 0.99
    assert window[~rings].mean() < 0.01, "field, goals or robots look like rings"


def test_rendered_rings_sit_where_the_pinhole_model_puts_them(frame) -> None:
    w, f, cam = frame
    checked = 0
    for i in f.visible:
        ys, xs = np.nonzero(f.ring_ids == i)
        # Only whole rings: a ring cut by the image edge or half behind a goal has a biased
        # centroid. Compare the pixels' extent with the projected outline's.
        a = np.linspace(0, 2 * np.pi, 32, endpoint=False)
        rad = w.field.ring.radius
        rim = np.column_stack(
            [w.ring_xy[i, 0] + rad * np.cos(a), w.ring_xy[i, 1] + rad * np.sin(a), np.zeros(32)]
        )
        rim_uv, _ = project_points(f.pose.to_camera(rim), cam.fx, cam.fy, cam.cx, cam.cy)
        span = rim_uv.max(axis=0) - rim_uv.min(axis=0)
        if len(xs) < 30 or np.ptp(xs) < 0.85 * span[0] or np.ptp(ys) < 0.7 * span[1]:
            continue
        centre = np.array([[*w.ring_xy[i], w.ring_z[i]]])
        uv, z = project_points(f.pose.to_camera(centre), cam.fx, cam.fy, cam.cx, cam.cy)
        assert xs.mean() == pytest.approx(uv[0, 0], abs=2.5)
        assert ys.mean() == pytest.approx(uv[0, 1], abs=2.5)
        assert np.median(f.depth[ys, xs]) == pytest.approx(z[0], abs=0.06)
        checked += 1
    assert checked >= 3
    # Every geometrically visible ring shows up in the segmentation.
    assert set(f.visible.tolist()) <= set(np.unique(f.ring_ids).tolist())


def test_rings_can_hide_rings_when_configured() -> None:
    # Rings in a row straight ahead, almost touching: seen along the row, the near ones hide the
    # far ones only when ring-on-ring occlusion is on.
    row = np.array([[0.0, -0.4 + 0.105 * k] for k in range(8)])
    counts = {}
    for flag in (False, True):
        with World(WorldConfig(blue=(), occlude_with_rings=flag)) as w:
            w.reset()
            for i, _ in enumerate(w.goals):
                w.place_goal(i, -1.5 + 0.5 * i, 1.6)
            w.set_floor_rings(row)
            w.place_robot(0, 0.0, -1.3, 0.0)
            counts[flag] = len(sensors.visible_rings(w, 0))
    assert counts[False] >= 6
    assert counts[True] < counts[False]
