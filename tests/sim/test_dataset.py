"""`pete-sim dataset`: simulator renders written as a jetson.perception dataset folder."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pybullet")
pytest.importorskip("cv2")

from jetson.autonomy.camera import CameraMount
from jetson.perception.dataset import RingDataset
from sim.camera import rgb_to_hsv_opencv
from sim.cli import main
from sim.dataset import DatasetConfig, iter_samples, write_dataset
from sim.errors import ConfigError

CFG = DatasetConfig(frames=4, seed=11, width=160, height=120)


@pytest.fixture(scope="module")
def folder(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("simset")
    write_dataset(CFG, out)
    return out


@pytest.fixture(scope="module")
def samples() -> list:
    return list(iter_samples(CFG))


def test_folder_loads_with_the_perception_reader(folder: Path) -> None:
    ds = RingDataset(folder)
    assert len(ds) == CFG.frames
    assert ds.meta is not None and ds.meta["intrinsics"]["width"] == 160
    labelled = 0
    for i in range(len(ds)):
        img = ds.image(i)
        assert img.shape == (120, 160, 3)
        depth = ds.depth(i)
        assert depth is not None and depth.shape == (120, 160)
        assert float(depth[depth > 0].min()) > 0.1 and float(depth.max()) < 8.0
        boxes, truth = ds.boxes(i, 160, 120), ds.truth(i)
        assert truth is not None and len(truth) == len(boxes)
        labelled += len(boxes)
    assert labelled >= CFG.frames  # the poses face rings: most frames hold some
    lines = (folder / "frames.jsonl").read_text().splitlines()
    assert [json.loads(line)["name"] for line in lines] == ds.names


def test_boxes_are_the_visible_pixels_of_each_ring(folder: Path, samples: list) -> None:
    ds = RingDataset(folder)
    for i, s in enumerate(samples):
        boxes = ds.boxes(i, 160, 120)
        assert len(boxes) == len(s.ring_index)
        ids, counts = np.unique(s.ring_ids[s.ring_ids >= 0], return_counts=True)
        # Every ring with enough visible pixels is labelled, and no other.
        assert set(s.ring_index.tolist()) == set(ids[counts >= CFG.min_pixels_here].tolist())
        for box, ring in zip(boxes, s.ring_index, strict=True):
            ys, xs = np.nonzero(s.ring_ids == ring)
            # Tight: the box is exactly the extent of that ring's pixels (YOLO text rounds).
            expect = [xs.min(), ys.min(), xs.max() + 1, ys.max() + 1]
            np.testing.assert_allclose(box, expect, atol=1e-3 * 160)


def test_truth_positions_agree_with_the_depth_image(folder: Path, samples: list) -> None:
    """Back-project each labelled ring's own pixels with the depth and the frame's mount (the
    Jetson's camera code, not the simulator's): they lie on the ring around its true centre."""
    ds = RingDataset(folder)
    frames = [json.loads(line) for line in (folder / "frames.jsonl").read_text().splitlines()]
    intr = ds.meta["intrinsics"]  # type: ignore[index]
    checked = 0
    for i, s in enumerate(samples):
        mount = CameraMount.from_dict(frames[i]["mount"])
        depth = ds.depth(i)
        truth = ds.truth(i)
        assert depth is not None and truth is not None
        for ring, xy in zip(s.ring_index, truth, strict=True):
            ys, xs = np.nonzero((s.ring_ids == ring) & (depth > 0))
            if len(xs) < 15:
                continue
            z = depth[ys, xs].astype(np.float64)
            cam = np.stack(
                [
                    (xs + 0.5 - intr["cx"]) / intr["fx"] * z,
                    (ys + 0.5 - intr["cy"]) / intr["fy"] * z,
                    z,
                ],
                axis=1,
            )
            pts = mount.camera_to_robot(cam)
            # On the floor, at most a ring's thickness up.
            assert np.all(pts[:, 2] > -0.01) and np.all(pts[:, 2] < 0.035)
            # Within the ring's outer radius (5.1 cm) of the true centre, plus depth rounding.
            assert np.hypot(*(pts[:, :2] - xy).T).max() < 0.058
            checked += 1
    assert checked >= 2


def test_no_ring_lies_inside_a_goal_base_or_under_a_robot() -> None:
    from sim.dataset import _world_config, render_sample
    from sim.world.physics import World

    world = World(_world_config())
    try:
        for k in range(12):
            render_sample(world, CFG, k)
            f = world.field
            for g in world.goals:
                d = np.hypot(world.ring_xy[:, 0] - g.x, world.ring_xy[:, 1] - g.y)
                assert (d > g.spec.base_radius + f.ring.radius).all()
            for r in world.robots:
                if abs(r.x) < f.half:  # not parked out of the scene
                    d = np.hypot(world.ring_xy[:, 0] - r.x, world.ring_xy[:, 1] - r.y)
                    assert (d > r.config.radius_m + f.ring.radius).all()
    finally:
        world.close()


def test_ring_colours_and_light_stay_inside_the_hsv_window() -> None:
    cfg = DatasetConfig(frames=3, seed=5, width=160, height=120, augment=False)
    ring_px = []
    for s in iter_samples(cfg):
        hsv = rgb_to_hsv_opencv(s.bgr[:, :, ::-1])
        ring_px.append(hsv[s.ring_ids >= 0])
    hsv = np.concatenate(ring_px)
    assert len(hsv) > 100
    inside = ((hsv[:, 0] >= 123) & (hsv[:, 0] <= 169) & (hsv[:, 1] >= 39) & (hsv[:, 1] <= 192)) & (
        hsv[:, 2] >= 76
    )
    # Anti-aliased silhouette pixels mix with the floor; the ring's own colour never leaves.
    assert inside.mean() > 0.97


def test_same_seed_same_folder_other_seed_other_frames(tmp_path: Path, folder: Path) -> None:
    cfg = DatasetConfig(frames=2, seed=11, width=160, height=120)
    write_dataset(cfg, tmp_path / "again")
    for sub, suffix in (("images", ".png"), ("labels", ".txt"), ("truth", ".json")):
        for k in range(2):
            name = f"sim_11_{k:06d}{suffix}"
            assert (tmp_path / "again" / sub / name).read_bytes() == (
                folder / sub / name
            ).read_bytes()
    other = next(iter_samples(DatasetConfig(frames=1, seed=12, width=160, height=120)))
    first = next(iter_samples(DatasetConfig(frames=1, seed=11, width=160, height=120)))
    assert not np.array_equal(other.bgr, first.bgr)


def test_bad_arguments_are_clear_errors(tmp_path: Path, folder: Path, capsys) -> None:
    with pytest.raises(ConfigError, match="unknown robots"):
        DatasetConfig(frames=1, robots=("18in",))
    assert main(["dataset", "--frames", "0", "--out", str(tmp_path / "x")]) == 2
    assert "frames must be at least 1" in capsys.readouterr().err
    assert main(["dataset", "--frames", "1", "--out", str(folder), "--no-progress"]) == 2
    assert "already holds a dataset" in capsys.readouterr().err
    assert main(["dataset", "--frames", "1", "--viewpoint", "drone", "--out", str(tmp_path)]) == 2
    assert "viewpoint must be one of ('robot', 'spectator')" in capsys.readouterr().err


def test_evaluation_places_each_frame_with_its_own_robots_camera(tmp_path: Path) -> None:
    from jetson.autonomy.camera import Intrinsics
    from jetson.perception.camera import CameraConfig
    from jetson.perception.classical import ClassicalDetector
    from jetson.perception.evaluate import frame_mounts, score_dataset
    from jetson.perception.pipeline import Pipeline

    cfg = DatasetConfig(frames=6, seed=5, width=320, height=240, robots=("15in", "24in"))
    write_dataset(cfg, tmp_path)
    mounts = frame_mounts(tmp_path)
    assert len(mounts) == 6 and len(set(mounts.values())) == 2  # both robots' cameras appear
    ds = RingDataset(tmp_path)
    intr = Intrinsics.from_dict(ds.meta["intrinsics"])
    pipeline = Pipeline(ClassicalDetector(), CameraConfig(intr, CameraMount()))
    errors = [err for _, err in score_dataset(pipeline, ds).localisation]
    assert errors, "no ring was matched and placed"
    # With one mount for every frame the 24 in robot's rings land ~10 cm off; per frame, ~1 cm.
    assert float(np.median(errors)) < 0.04


def test_spectator_frames_photograph_the_same_scenes_from_outside_the_field(
    tmp_path: Path,
) -> None:
    from jetson.autonomy.geometry import heading_vector, robot_to_field
    from sim.field import load_field

    half = load_field().half
    robot_cfg = DatasetConfig(frames=4, seed=3, width=320, height=240)
    spec_cfg = DatasetConfig(frames=4, seed=3, width=320, height=240, viewpoint="spectator")
    common = 0
    robot_sizes, spec_sizes = [], []
    for r, s in zip(iter_samples(robot_cfg), iter_samples(spec_cfg), strict=True):
        x, y, heading = s.info["pose"]
        assert max(abs(x), abs(y)) > half + 0.05  # outside a wall
        # ... looking in across it: within 35 deg of square to that wall.
        wall = np.array([np.sign(x), 0.0] if abs(x) > abs(y) else [0.0, np.sign(y)])
        assert float(-wall @ heading_vector(heading)) >= np.cos(np.radians(35.01))
        assert 0.8 <= s.info["mount"]["height_m"] <= 1.9 and s.info["viewpoint"] == "spectator"
        # The scene is robot frame k's: each ring both frames label sits where it did.
        rx, ry, rh = r.info["pose"]
        in_r = dict(zip(r.ring_index, robot_to_field(r.rings_robot_xy, (rx, ry), rh), strict=True))
        in_s = robot_to_field(s.rings_robot_xy, (x, y), heading)
        for i, xy in zip(s.ring_index, in_s, strict=True):
            if i in in_r:
                assert np.allclose(xy, in_r[i], atol=1e-3)  # poses are saved rounded
                common += 1
        robot_sizes += list(np.sqrt(np.prod(r.boxes_px[:, 2:] - r.boxes_px[:, :2], axis=1)))
        spec_sizes += list(np.sqrt(np.prod(s.boxes_px[:, 2:] - s.boxes_px[:, :2], axis=1)))
    assert common > 0
    # Seen from further away, rings are smaller: the small rings of photos of a field.
    assert np.median(spec_sizes) < 0.75 * np.median(robot_sizes)
    write_dataset(DatasetConfig(frames=1, seed=3, viewpoint="spectator"), tmp_path)
    meta = json.loads((tmp_path / "dataset.json").read_text())
    assert meta["viewpoint"] == "spectator" and "mount" not in meta and "mounts" not in meta
    with pytest.raises(ConfigError, match="viewpoint"):
        DatasetConfig(frames=1, viewpoint="drone")
