"""Detector scoring: IoU matching, precision, recall, F1, and localisation error on a dataset."""

from __future__ import annotations

import itertools
import json
from dataclasses import dataclass
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from jetson.perception.camera import CameraConfig, CameraMount
from jetson.perception.dataset import RingDataset, fingerprint, holdout_names
from jetson.perception.detection import Detection, iou_matrix
from jetson.perception.errors import DatasetError
from jetson.perception.frame import Frame, Intrinsics
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

    def localisation_bands(
        self, edges: tuple[float, ...] = (0.0, 1.0, 2.0, 3.0)
    ) -> list[tuple[float, float, int, float, float]]:
        """(low, high, count, median error, p90 error) per distance band with data."""
        if not self.localisation:
            return []
        arr = np.asarray(self.localisation)
        out = []
        for lo, hi in itertools.pairwise(edges):
            sel = arr[(arr[:, 0] >= lo) & (arr[:, 0] < hi), 1]
            if sel.size:
                med, p90 = float(np.median(sel)), float(np.quantile(sel, 0.9))
                out.append((lo, hi, int(sel.size), med, p90))
        return out


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
) -> DatasetScore:
    """Run the pipeline over a dataset folder; count matches; measure localisation where the
    folder has depth and ground-truth positions."""
    counts = Counts()
    errors: list[tuple[float, float]] = []
    unplaced = 0
    n = len(dataset) if limit is None else min(limit, len(dataset))
    intr = None
    if dataset.meta is not None and "intrinsics" in dataset.meta:
        intr = Intrinsics.from_dict(dataset.meta["intrinsics"])
    mounts = frame_mounts(dataset.root)
    localisers: dict[CameraMount, Localiser] = {}
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
        true_xy = dataset.truth(i)
        if true_xy is None or frame.depth_m is None:
            continue
        if len(true_xy) != len(truth):
            raise DatasetError(
                f"{dataset.samples[i].name}: {len(true_xy)} true positions for {len(truth)} labels"
            )
        placed = {id(r.detection): r for r in result.rings}
        for d, t in pairs:
            ring = placed.get(id(result.detections[d]))
            if ring is None:
                unplaced += 1
                continue
            err = float(np.hypot(*(np.asarray(ring.robot_xy) - true_xy[t])))
            errors.append((float(np.hypot(*true_xy[t])), err))
    return DatasetScore(counts, n, errors, unplaced)


def heldout_of(model_meta: dict[str, object] | None, folder: Path) -> set[str] | None:
    """The images of `folder` that a model held out of its training, or None when the model
    never trained on that folder. A model's score on images it trained on means little.

    Folders are recognised by their image names (dataset.fingerprint), wherever they are."""
    if not model_meta or not isinstance(model_meta.get("holdout"), dict):
        return None
    h = model_meta["holdout"]
    assert isinstance(h, dict)
    names = RingDataset(folder).names
    if fingerprint(names) not in h.get("fingerprints", []):
        return None
    return holdout_names(names, float(h["fraction"]), int(h["seed"]))


def trained_on(model_meta: dict[str, object] | None, folder: Path) -> bool:
    prints = (model_meta or {}).get("data_fingerprints", [])
    return isinstance(prints, list) and fingerprint(RingDataset(folder).names) in prints
