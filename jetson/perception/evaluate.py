"""Detector scoring: IoU matching, precision, recall, F1, and localisation error on a dataset."""

from __future__ import annotations

import itertools
import json
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import CameraMount, Intrinsics
from jetson.errors import DatasetError
from jetson.perception.camera import CameraConfig
from jetson.perception.dataset import RingDataset, fingerprint, holdout_names, image_names
from jetson.perception.detection import RING_MINOR_M, RING_OUTER_M, Detection, iou_matrix
from jetson.perception.frame import Frame
from jetson.perception.localise import Localiser
from jetson.perception.pipeline import Pipeline


def match(
    detections: list[Detection], truth: NDArray[np.float64], iou_threshold: float = 0.5
) -> list[tuple[int, int]]:
    """Greedy matching, best-scoring detection first (as VOC/COCO do): each detection takes the
    unmatched true box it overlaps most, if that IoU reaches the threshold.

    Returns (detection index, truth index) pairs.
    """
    truth = np.asarray(truth, dtype=np.float64).reshape(-1, 4)
    if not detections or len(truth) == 0:
        return []
    boxes = np.array([d.as_array() for d in detections])
    ious = iou_matrix(boxes, truth)
    taken = np.zeros(len(truth), dtype=bool)
    pairs = []
    for i in sorted(range(len(detections)), key=lambda k: -detections[k].score):
        row = np.where(taken, -1.0, ious[i])
        j = int(np.argmax(row))
        if row[j] >= iou_threshold:
            taken[j] = True
            pairs.append((i, j))
    return pairs


@dataclass
class Counts:
    tp: int = 0
    fp: int = 0
    fn: int = 0

    def add(self, n_detections: int, n_truth: int, n_matched: int) -> None:
        self.tp += n_matched
        self.fp += n_detections - n_matched
        self.fn += n_truth - n_matched

    @property
    def precision(self) -> float:
        # No detections at all: nothing was wrong, but say 0 only if there was something to find.
        d = self.tp + self.fp
        return self.tp / d if d else (1.0 if self.fn == 0 else 0.0)

    @property
    def recall(self) -> float:
        t = self.tp + self.fn
        return self.tp / t if t else 1.0

    @property
    def f1(self) -> float:
        p, r = self.precision, self.recall
        return 2 * p * r / (p + r) if p + r > 0 else 0.0

    def summary(self) -> str:
        return (
            f"precision {self.precision:.3f}  recall {self.recall:.3f}  F1 {self.f1:.3f}  "
            f"(TP {self.tp}, FP {self.fp}, FN {self.fn})"
        )


@dataclass
class DatasetScore:
    """A detector's result on a dataset folder."""

    counts: Counts
    frames: int
    # Per matched ring with ground truth: (true distance from the robot, localisation error), m.
    localisation: list[tuple[float, float]]
    unplaced: int  # matched rings with ground truth that could not be placed (no depth)
    # Per labelled ring with ground truth and a known camera: (visible fraction, detected).
    visibility: list[tuple[float, bool]] = field(default_factory=list)

    def recall_by_visibility(
        self, edges: tuple[float, ...] = (0.0, 0.25, 0.5, 0.75, 1.0)
    ) -> list[tuple[float, float, int, float]]:
        """(low, high, count, recall) per band of visible fraction with data; the last band
        includes its upper edge."""
        return [
            (lo, hi, int(sel.size), float(sel.mean()))
            for lo, hi, sel in _bands(self.visibility, edges, close_last=True)
        ]

    def counts_visible(self, min_fraction: float) -> Counts:
        """Counts as PASCAL VOC treats 'difficult' objects: rings less visible than
        min_fraction are neither to be found nor false when found (a detection matched to one
        is ignored); every unmatched detection is still false. Needs `visibility` for every
        label, i.e. a folder with ground truth and known cameras."""
        arr = np.asarray(self.visibility, dtype=np.float64).reshape(-1, 2)
        if len(arr) != self.counts.tp + self.counts.fn:
            raise DatasetError("visible fractions are known for only some labels")
        easy = arr[:, 0] >= min_fraction
        found = arr[:, 1] > 0
        return Counts(int((easy & found).sum()), self.counts.fp, int((easy & ~found).sum()))

    def localisation_bands(
        self, edges: tuple[float, ...] = (0.0, 1.0, 2.0, 3.0)
    ) -> list[tuple[float, float, int, float, float]]:
        """(low, high, count, median error, p90 error) per distance band with data."""
        return [
            (lo, hi, int(sel.size), float(np.median(sel)), float(np.quantile(sel, 0.9)))
            for lo, hi, sel in _bands(self.localisation, edges)
        ]


def _bands(
    pairs: list[tuple[float, float]] | list[tuple[float, bool]],
    edges: tuple[float, ...],
    close_last: bool = False,
) -> list[tuple[float, float, NDArray[np.float64]]]:
    """(low, high, values) for each band [low, high) of the pairs' keys that holds any; with
    close_last the last band also takes keys equal to its high edge."""
    if not pairs:
        return []
    arr = np.asarray(pairs, dtype=np.float64)
    key = arr[:, 0]
    out = []
    for k, (lo, hi) in enumerate(itertools.pairwise(edges)):
        below = key <= hi if close_last and k == len(edges) - 2 else key < hi
        sel = arr[(key >= lo) & below, 1]
        if sel.size:
            out.append((lo, hi, sel))
    return out


def ring_box_px(
    mount: CameraMount, intr: Intrinsics, robot_xy: NDArray[np.float64]
) -> NDArray[np.float64] | None:
    """The box (x0, y0, x1, y1) a whole ring lying flat at robot_xy projects to, not clipped to
    the image and as if nothing hid it; None when part of it is behind the camera."""
    a = np.linspace(0.0, 2 * np.pi, 36, endpoint=False)
    rim = RING_OUTER_M / 2 * np.stack([np.cos(a), np.sin(a)], axis=1) + np.asarray(robot_xy)
    pts = np.concatenate(
        [np.column_stack([rim, np.full(len(a), z)]) for z in (0.0, 2 * RING_MINOR_M)]
    )
    cam = mount.robot_to_camera_points(pts)
    if np.any(cam[:, 2] <= 1e-3):
        return None
    u = intr.fx * cam[:, 0] / cam[:, 2] + intr.cx
    v = intr.fy * cam[:, 1] / cam[:, 2] + intr.cy
    return np.array([u.min(), v.min(), u.max(), v.max()])


def visible_fraction(label: NDArray[np.float64], whole: NDArray[np.float64]) -> float:
    """How much of a ring shows: its label (the box of its visible pixels) over the box of the
    whole ring. Cut by the image's edge or hidden in part, a ring's label shrinks."""
    whole_area = (whole[2] - whole[0]) * (whole[3] - whole[1])
    area = max(0.0, label[2] - label[0]) * max(0.0, label[3] - label[1])
    return float(min(1.0, area / whole_area)) if whole_area > 0 else 0.0


def frame_mounts(root: Path) -> dict[str, CameraMount]:
    """Per-frame camera mounts from a `pete-sim dataset` folder's frames.jsonl (empty if none)."""
    path = Path(root) / "frames.jsonl"
    if not path.exists():
        return {}
    mounts: dict[str, CameraMount] = {}
    for n, line in enumerate(path.read_text().splitlines(), 1):
        if not line.strip():
            continue
        try:
            entry = json.loads(line)
            if "mount" in entry:
                mounts[str(entry["name"])] = CameraMount.from_dict(entry["mount"])
        except (ValueError, KeyError, TypeError) as exc:
            raise DatasetError(f"{path}:{n}: not a frame entry ({exc})") from None
    return mounts


def score_dataset(
    pipeline: Pipeline,
    dataset: RingDataset,
    iou_threshold: float = 0.5,
    limit: int | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> DatasetScore:
    """Run the pipeline over a dataset folder; count matches; measure localisation where the
    folder has depth and ground-truth positions. `progress(done, total)` after each image."""
    counts = Counts()
    errors: list[tuple[float, float]] = []
    unplaced = 0
    n = len(dataset) if limit is None else min(limit, len(dataset))
    intr = None
    if dataset.meta is not None and "intrinsics" in dataset.meta:
        intr = Intrinsics.from_dict(dataset.meta["intrinsics"])
    mounts = frame_mounts(dataset.root)
    localisers: dict[CameraMount, Localiser] = {}
    visibility: list[tuple[float, bool]] = []
    visibility_known = True
    for i in range(n):
        img = dataset.image(i)
        h, w = img.shape[:2]
        truth = dataset.boxes(i, w, h)
        frame_intr = intr if intr is not None else pipeline.camera.intrinsics
        if (frame_intr.width, frame_intr.height) != (w, h):
            frame_intr = frame_intr.scaled(w, h)
        frame = Frame(img, dataset.depth(i), frame_intr, 0.0, i)
        mount = mounts.get(dataset.samples[i].name)
        if mount is None:
            result = pipeline.process(frame)
        else:
            # A simulator folder mixes robots whose cameras sit differently: place each frame's
            # rings from its own robot's mount, or the errors measure the mount, not perception.
            if mount not in localisers:
                localisers[mount] = Localiser(
                    CameraConfig(pipeline.camera.intrinsics, mount), pipeline.localiser.config
                )
            result = pipeline.process(frame, localiser=localisers[mount])
        pairs = match(result.detections, truth, iou_threshold)
        counts.add(len(result.detections), len(truth), len(pairs))
        if progress is not None:
            progress(i + 1, n)
        true_xy = dataset.truth(i)
        if true_xy is not None and len(true_xy) != len(truth):
            raise DatasetError(
                f"{dataset.samples[i].name}: {len(true_xy)} true positions for {len(truth)} labels"
            )
        if true_xy is None or intr is None:
            visibility_known = False
        else:
            found = {t for _, t in pairs}
            cam_mount = mount if mount is not None else pipeline.camera.mount
            for t, box in enumerate(truth):
                whole = ring_box_px(cam_mount, frame_intr, true_xy[t])
                frac = visible_fraction(box, whole) if whole is not None else 0.0
                visibility.append((frac, t in found))
        if true_xy is None or frame.depth_m is None:
            continue
        placed = {id(r.detection): r for r in result.rings}
        for d, t in pairs:
            ring = placed.get(id(result.detections[d]))
            if ring is None:
                unplaced += 1
                continue
            err = float(np.hypot(*(np.asarray(ring.robot_xy) - true_xy[t])))
            errors.append((float(np.hypot(*true_xy[t])), err))
    # Fractions for only some labels would skew every band: all or none.
    return DatasetScore(counts, n, errors, unplaced, visibility if visibility_known else [])


def heldout_of(model_meta: dict[str, object] | None, folder: Path) -> set[str] | None:
    """The images of `folder` that a model held out of its training, or None when the model
    never trained on that folder. A model's score on images it trained on means little.

    Folders are recognised by their image names (dataset.fingerprint), wherever they are."""
    if not model_meta or not isinstance(model_meta.get("holdout"), dict):
        return None
    h = model_meta["holdout"]
    assert isinstance(h, dict)
    names = image_names(folder)
    if fingerprint(names) not in h.get("fingerprints", []):
        return None
    return holdout_names(names, float(h["fraction"]), int(h["seed"]))


def trained_on(model_meta: dict[str, object] | None, folder: Path) -> bool:
    prints = (model_meta or {}).get("data_fingerprints", [])
    return isinstance(prints, list) and fingerprint(image_names(folder)) in prints
