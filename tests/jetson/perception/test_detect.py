"""Pre-filter, classical detector, dataset folders and scoring, on synthetic images."""

from __future__ import annotations

import shutil
from pathlib import Path

import cv2
import numpy as np
import pytest

from jetson.errors import CameraConfigError, DatasetError
from jetson.perception.camera import CameraConfig
from jetson.perception.classical import ClassicalDetector
from jetson.perception.dataset import (
    RingDataset,
    fingerprint,
    holdout_names,
    image_names,
    parse_labels,
    source_group,
    write_meta,
    write_sample,
)
from jetson.perception.detection import Detection, iou_matrix, non_max_suppression
from jetson.perception.evaluate import (
    Counts,
    DatasetScore,
    heldout_of,
    match,
    ring_box_px,
    score_dataset,
    trained_on,
    visible_fraction,
)
from jetson.perception.pipeline import Pipeline
from jetson.perception.prefilter import HsvWindow, PrefilterConfig, prefilter
from jetson.perception.synthetic import Obstacle, Ring, Scene, random_frame, render

CAMERA = CameraConfig()
SMALL = CAMERA.intrinsics.scaled(320, 240)


def test_hsv_window_is_the_reports() -> None:
    w = HsvWindow()
    lo, hi = w.bounds()
    assert lo.tolist() == [124, 39, 76] and hi.tolist() == [169, 192, 255]
    img = np.zeros((1, 3, 3), np.uint8)
    img[0, 0] = (200, 80, 160)  # BGR purple: H 140, S 153, V 200
    img[0, 1] = (204, 0, 153)  # fully saturated purple: S 255, outside
    img[0, 2] = (40, 40, 200)  # red
    assert w.mask(img)[0].tolist() == [255, 0, 0]
    with pytest.raises(CameraConfigError, match="HSV h"):
        HsvWindow(h=(150.0, 120.0))


def test_prefilter_keeps_the_neighbourhood_of_purple_and_blacks_out_the_rest() -> None:
    img = np.full((240, 320, 3), 120, np.uint8)
    img[100:110, 100:110] = (200, 80, 160)
    out = prefilter(img, PrefilterConfig(blur_ksize=35, reference_width=320))
    assert out.colour_mask.sum() == 100 * 255
    # The 35 x 35 box around any purple pixel survives: 17 px beyond the blob, not 18.
    assert out.image[100, 100 - 17].tolist() == [120, 120, 120]
    assert out.image[100, 100 - 18].tolist() == [0, 0, 0]
    assert out.image[0, 0].tolist() == [0, 0, 0]
    assert out.image[105, 105].tolist() == [200, 80, 160]


def test_prefilter_kernel_scales_with_the_image() -> None:
    cfg = PrefilterConfig()
    assert cfg.ksize_for(640) == 35
    assert cfg.ksize_for(320) % 2 == 1 and 17 <= cfg.ksize_for(320) <= 19
    with pytest.raises(CameraConfigError):
        PrefilterConfig(blur_ksize=0)
    assert PrefilterConfig.from_dict(PrefilterConfig().to_dict()) == PrefilterConfig()


def test_iou_and_nms() -> None:
    a = np.array([[0, 0, 10, 10]])
    b = np.array([[5, 0, 15, 10], [20, 20, 30, 30], [0, 0, 10, 10]])
    assert iou_matrix(a, b)[0] == pytest.approx([50 / 150, 0.0, 1.0])
    dets = [
        Detection(0, 0, 10, 10, 0.9),
        Detection(1, 0, 11, 10, 0.8),
        Detection(20, 20, 30, 30, 0.5),
    ]
    kept = non_max_suppression(dets, 0.5)
    assert [d.score for d in kept] == [0.9, 0.5]


def test_matching_counts_each_truth_once() -> None:
    truth = np.array([[0, 0, 10, 10], [50, 50, 60, 60]], float)
    dets = [
        Detection(0, 0, 10, 10, 0.9),
        Detection(0, 1, 10, 11, 0.8),  # a duplicate of the first: a false positive
        Detection(100, 100, 110, 110, 0.7),  # nothing there
    ]
    pairs = match(dets, truth)
    assert pairs == [(0, 0)]
    c = Counts()
    c.add(len(dets), len(truth), len(pairs))
    assert (c.tp, c.fp, c.fn) == (1, 2, 1)
    assert c.precision == pytest.approx(1 / 3) and c.recall == pytest.approx(0.5)
    assert c.f1 == pytest.approx(2 * (1 / 3) * 0.5 / (1 / 3 + 0.5))


def test_classical_finds_separate_rings_with_tight_boxes() -> None:
    scene = Scene(rings=[Ring(-0.35, 1.2), Ring(0.0, 0.8), Ring(0.3, 1.5)])
    r = render(scene, SMALL, CAMERA.mount, np.random.default_rng(0))
    assert len(r.boxes) == 3
    dets = ClassicalDetector(camera=CAMERA).detect(r.frame.color, r.frame.depth_m)
    assert len(dets) == 3
    ious = iou_matrix(np.array([d.as_array() for d in dets]), r.boxes)
    assert np.all(ious.max(axis=0) > 0.75)


def test_classical_splits_a_row_of_touching_rings() -> None:
    step = 0.1016 * 1.03
    scene = Scene(rings=[Ring(-step + k * step, 1.0) for k in range(3)])
    r = render(scene, SMALL, CAMERA.mount, None)
    dets = ClassicalDetector(camera=CAMERA).detect(r.frame.color, r.frame.depth_m)
    assert len(match(dets, r.boxes)) == 3


def test_classical_ignores_things_that_are_not_rings() -> None:
    img = np.full((240, 320, 3), 128, np.uint8)
    purple = (200, 80, 160)
    cv2.rectangle(img, (10, 10), (300, 20), purple, cv2.FILLED)  # a long purple stripe
    cv2.circle(img, (200, 150), 2, purple, cv2.FILLED)  # a speck
    cv2.circle(img, (80, 150), 20, (40, 40, 200), 4)  # a red ring-shaped thing
    assert ClassicalDetector().detect(img) == []


def test_classical_on_random_frames_has_high_precision_and_recall() -> None:
    # Full 640x480 frames: the classical detector's size tests are tuned at the camera's size.
    counts = Counts()
    det = ClassicalDetector(camera=CAMERA)
    for seed in range(8):
        r = random_frame(np.random.default_rng(500 + seed), CAMERA.intrinsics, max_rings=6)
        dets = det.detect(r.frame.color, r.frame.depth_m)
        counts.add(len(dets), len(r.boxes), len(match(dets, r.boxes)))
    assert counts.tp >= 12
    assert counts.precision >= 0.85 and counts.recall >= 0.8


def test_labels_parse_and_malformed_labels_are_named() -> None:
    boxes = parse_labels("0 0.5 0.5 0.2 0.1\n\n1 0.1 0.1 0.1 0.1\n0 0.25 0.75 0.1 0.1\n", "x.txt")
    assert boxes.tolist() == [[0.5, 0.5, 0.2, 0.1], [0.25, 0.75, 0.1, 0.1]]
    with pytest.raises(DatasetError, match=r"a\.txt:2: expected 'class cx cy w h'"):
        parse_labels("0 0.5 0.5 0.2 0.1\n0 0.5 0.5\n", "a.txt")
    with pytest.raises(DatasetError, match=r"b\.txt:1: not numbers"):
        parse_labels("0 half 0.5 0.2 0.1\n", "b.txt")
    with pytest.raises(DatasetError, match="outside the image or empty"):
        parse_labels("0 0.5 0.5 -0.1 0.1\n", "c.txt")
    with pytest.raises(DatasetError, match="outside the image"):
        parse_labels("0 1.5 0.5 0.1 0.1\n", "d.txt")
    with pytest.raises(DatasetError, match="outside the image"):
        parse_labels("0 1.5 0.5 0 0\n", "e.txt")  # a point, but off the image


def test_zero_size_boxes_are_left_out_and_named() -> None:
    # A stray click in a labelling tool exports as a box of no size (the public BLRSAI export
    # has one); it marks no pixels, so it is left out rather than failing the whole folder.
    skipped: list[str] = []
    text = "0 0.5 0.5 0.2 0.1\n0 0.23 0.04 0 0\n0 0.7 0.7 0.1 0\n0 0.25 0.75 0.1 0.1\n"
    boxes = parse_labels(text, "f.txt", skipped)
    assert boxes.tolist() == [[0.5, 0.5, 0.2, 0.1], [0.25, 0.75, 0.1, 0.1]]
    assert skipped == ["f.txt:2: 0 0.23 0.04 0 0", "f.txt:3: 0 0.7 0.7 0.1 0"]


def test_dataset_folder_errors(tmp_path: Path) -> None:
    with pytest.raises(DatasetError, match="does not exist"):
        RingDataset(tmp_path / "missing")
    with pytest.raises(DatasetError, match="no images/ folder"):
        RingDataset(tmp_path)
    (tmp_path / "train" / "images").mkdir(parents=True)
    with pytest.raises(DatasetError, match=r"split folders \['train'\]"):
        RingDataset(tmp_path)
    with pytest.raises(DatasetError, match="holds no images"):
        RingDataset(tmp_path / "train")
    cv2.imwrite(str(tmp_path / "train" / "images" / "a.png"), np.zeros((8, 8, 3), np.uint8))
    (tmp_path / "train" / "labels").mkdir()
    (tmp_path / "train" / "labels" / "a.txt").write_text("0 0.5 0.5 0.5\n")
    # Labels are read when the folder is opened: the error comes before any work starts.
    with pytest.raises(DatasetError, match=r"a\.txt:1"):
        RingDataset(tmp_path / "train")
    (tmp_path / "train" / "labels" / "a.txt").write_text("0 0.5 0.5 0.5 0.5\n0 0.1 0.1 0 0\n")
    ds = RingDataset(tmp_path / "train")
    assert ds.boxes(0, 8, 8).tolist() == [[2.0, 2.0, 6.0, 6.0]]
    note = ds.skipped_note()
    assert note is not None and "left out 1 empty label box" in note and "a.txt:2" in note


def test_dataset_names_and_subset_without_reading_again(tmp_path: Path) -> None:
    images, labels = tmp_path / "images", tmp_path / "labels"
    images.mkdir()
    labels.mkdir()
    for name, text in (("a", "0 0.5 0.5 0 0\n"), ("b", "0 0.5 0.5 0.5 0.5\n"), ("c", "")):
        cv2.imwrite(str(images / f"{name}.png"), np.zeros((8, 8, 3), np.uint8))
        (labels / f"{name}.txt").write_text(text)
    # Names (to recognise or split a folder) come without opening a single label file.
    (labels / "c.txt").write_text("not a label line\n")
    assert image_names(tmp_path) == ["a", "b", "c"]
    with pytest.raises(DatasetError, match=r"c\.txt:1"):
        RingDataset(tmp_path)
    (labels / "c.txt").write_text("0 0.25 0.25 0.5 0.5\n")
    ds = RingDataset(tmp_path)
    assert ds.skipped_labels and ds.skipped_labels[0].endswith("a.txt:1: 0 0.5 0.5 0 0")
    # The subset keeps its own samples' boxes and notes, from what the folder already read.
    (labels / "c.txt").write_text("not a label line\n")
    part = ds.subset({"b", "c"})
    assert part.names == ["b", "c"] and ds.names == ["a", "b", "c"]
    assert part.boxes(1, 8, 8).tolist() == [[0.0, 0.0, 4.0, 4.0]]
    assert part.skipped_labels == [] and part.skipped_note() is None
    assert ds.subset({"a"}).skipped_note() is not None
    with pytest.raises(DatasetError, match="none of its images"):
        ds.subset({"z"})


def test_dataset_round_trip_with_depth_and_truth(tmp_path: Path) -> None:
    r = render(Scene(rings=[Ring(0.0, 1.0), Ring(0.3, 1.4)]), SMALL, CAMERA.mount, None)
    write_meta(tmp_path, {"intrinsics": SMALL.to_dict(), "mount": CAMERA.mount.to_dict()})
    write_sample(tmp_path, "f0", r.frame.color, r.boxes, r.frame.depth_m, r.rings_robot_xy)
    ds = RingDataset(tmp_path)
    assert len(ds) == 1 and ds.meta is not None
    assert ds.boxes(0, 320, 240) == pytest.approx(r.boxes, abs=1e-3)
    assert ds.truth(0) == pytest.approx(r.rings_robot_xy, abs=1e-4)
    depth = ds.depth(0)
    assert depth is not None
    assert np.abs(depth - r.frame.depth_m).max() <= 0.0006
    assert np.array_equal(ds.image(0), r.frame.color)


def test_score_dataset_measures_detection_and_localisation(tmp_path: Path) -> None:
    write_meta(tmp_path, {"intrinsics": SMALL.to_dict(), "mount": CAMERA.mount.to_dict()})
    for k in range(3):
        scene = Scene(rings=[Ring(-0.3 + 0.3 * k, 0.8 + 0.3 * k)])
        r = render(scene, SMALL, CAMERA.mount, np.random.default_rng(k))
        write_sample(tmp_path, f"f{k}", r.frame.color, r.boxes, r.frame.depth_m, r.rings_robot_xy)
    pipeline = Pipeline(ClassicalDetector(camera=CAMERA), CAMERA)
    score = score_dataset(pipeline, RingDataset(tmp_path))
    assert (score.counts.tp, score.counts.fp, score.counts.fn) == (3, 0, 0)
    assert len(score.localisation) == 3
    assert max(err for _, err in score.localisation) < 0.04
    bands = score.localisation_bands()
    assert sum(b[2] for b in bands) == 3
    # Whole rings in the middle of the image: each label is nearly all of its ring.
    assert len(score.visibility) == 3
    assert all(frac > 0.8 and found for frac, found in score.visibility)


def test_whole_ring_box_matches_the_render_and_shrinks_when_cut_by_the_edge() -> None:
    whole = render(Scene(rings=[Ring(0.1, 1.0)]), SMALL, CAMERA.mount, None)
    box = ring_box_px(CAMERA.mount, SMALL, whole.rings_robot_xy[0])
    assert box is not None
    assert iou_matrix(box[None], whole.boxes)[0, 0] > 0.85
    assert visible_fraction(whole.boxes[0], box) > 0.85
    # Moved right until its whole box is centred on the image's edge: about half shows.
    x = next(
        float(x)
        for x in np.linspace(0.0, 1.0, 201)
        if (b := ring_box_px(CAMERA.mount, SMALL, np.array([x, 1.0]))) is not None
        and b[0] + b[2] >= 2 * SMALL.width
    )
    cut = render(Scene(rings=[Ring(x, 1.0)]), SMALL, CAMERA.mount, None)
    assert len(cut.boxes) == 1 and cut.boxes[0][2] >= SMALL.width - 1
    box = ring_box_px(CAMERA.mount, SMALL, cut.rings_robot_xy[0])
    assert box is not None and box[2] > SMALL.width
    inside = (SMALL.width - box[0]) / (box[2] - box[0])
    assert visible_fraction(cut.boxes[0], box) == pytest.approx(inside, abs=0.1)
    assert 0.4 < inside < 0.6
    # Behind the camera there is no box.
    assert ring_box_px(CAMERA.mount, SMALL, np.array([0.0, -1.0])) is None


def test_rings_too_hidden_to_label_are_ignore_regions() -> None:
    # A ring behind a box, all but its left edge hidden.
    wall = Obstacle((-0.04, 0.85, 0.0), (0.4, 0.9, 0.3), (60, 60, 60))
    scene = Scene(rings=[Ring(-0.3, 1.0), Ring(0.0, 1.0)], obstacles=[wall])
    r = render(scene, SMALL, CAMERA.mount, None)
    assert r.ring_ids.tolist() == [0]
    assert len(r.ignore_boxes) == 1
    x0, y0, x1, y1 = r.ignore_boxes[0]
    assert (r.id_buffer[int(y0) : int(y1), int(x0) : int(x1)] == 1).any()
    assert (r.id_buffer == 1).sum() < 0.35 * (r.id_buffer == 0).sum()
    # Apart, both are rings and nothing is ignored.
    apart = render(Scene(rings=[Ring(-0.3, 1.0), Ring(0.3, 1.0)]), SMALL, CAMERA.mount, None)
    assert len(apart.boxes) == 2 and len(apart.ignore_boxes) == 0


def test_difficult_rings_are_neither_to_be_found_nor_false() -> None:
    # Three labels: a sliver missed, a whole ring found, a half ring missed; two false alarms.
    score = DatasetScore(Counts(1, 2, 2), 1, [], 0, [(0.1, False), (0.9, True), (0.6, False)])
    c = score.counts_visible(0.25)
    assert (c.tp, c.fp, c.fn) == (1, 2, 1)
    assert score.recall_by_visibility() == [
        (0.0, 0.25, 1, 0.0),
        (0.5, 0.75, 1, 0.0),
        (0.75, 1.0, 1, 1.0),
    ]
    # Fractions known for only some labels cannot be split into easy and difficult.
    with pytest.raises(DatasetError, match="only some labels"):
        DatasetScore(Counts(1, 0, 2), 1, [], 0, [(0.9, True)]).counts_visible(0.25)


def test_pipeline_with_prefilter_gives_the_same_rings() -> None:
    r = render(Scene(rings=[Ring(0.1, 1.0)]), SMALL, CAMERA.mount, np.random.default_rng(1))
    plain = Pipeline(ClassicalDetector(camera=CAMERA), CAMERA).process(r.frame)
    pre = Pipeline(ClassicalDetector(camera=CAMERA), CAMERA, PrefilterConfig(enabled=True))
    filtered = pre.process(r.frame)
    assert len(plain.rings) == len(filtered.rings) == 1
    assert plain.rings[0].robot_xy == pytest.approx(filtered.rings[0].robot_xy, abs=1e-6)
    assert set(plain.timings_ms) == {"prefilter", "detect", "localise"}


def test_holdout_keeps_augmented_copies_of_one_source_together() -> None:
    names = [f"IMG_{i}_jpg.rf.{h}" for i in range(40) for h in ("aa", "bb", "cc")]
    held = holdout_names(names, 0.25)
    assert held == holdout_names(list(reversed(names)), 0.25)  # order does not matter
    groups = {source_group(n) for n in held}
    assert 3 <= len(groups) <= 18  # about a quarter of 40
    for g in groups:
        assert {f"{g}.rf.{h}" for h in ("aa", "bb", "cc")} <= held
    assert holdout_names(names, 0.0) == set()
    with pytest.raises(DatasetError, match="holdout fraction"):
        holdout_names(names, 1.0)


def test_a_model_is_scored_only_on_what_it_held_out(tmp_path: Path) -> None:
    for i in range(12):
        write_sample(tmp_path, f"S{i}_jpg.rf.x", np.zeros((16, 16, 3), np.uint8), np.zeros((0, 4)))
    names = RingDataset(tmp_path).names
    fp = fingerprint(names)
    meta = {"holdout": {"fraction": 0.5, "seed": 3, "fingerprints": [fp]},
            "data_fingerprints": [fp]}  # fmt: skip
    held = heldout_of(meta, tmp_path)
    assert held == holdout_names(names, 0.5, 3)
    # The same images elsewhere are the same folder; other images are not.
    moved = tmp_path / "moved"
    shutil.copytree(tmp_path, moved, ignore=shutil.ignore_patterns("moved"))
    assert heldout_of(meta, moved) == held
    write_sample(moved, "extra", np.zeros((16, 16, 3), np.uint8), np.zeros((0, 4)))
    assert heldout_of(meta, moved) is None and not trained_on(meta, moved)
    assert heldout_of({"data_fingerprints": [fp]}, tmp_path) is None
    assert trained_on(meta, tmp_path) and not trained_on({}, tmp_path)
    assert len(RingDataset(tmp_path, held)) == len(held)
