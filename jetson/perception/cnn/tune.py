"""Choose a trained detector's run-time input size and score threshold on held-out images.

    pete-jetson detector tune --model jetson/models/ringnet.onnx --val DIR [--val DIR2] \
        [--sizes 480,528,560] [--write]

A fully convolutional detector runs at any input size. Run larger than it was trained at, its
rings look bigger to it: hidden and distant rings are found more often, and past some size more
floor is taken for rings. Where that balance lies depends on the camera and the scenes, so it is
measured, not guessed: every (size, threshold) pair is scored on each folder's images (only those
the model held out of its training, when it trained on the folder), and the pair with the best
mean F1 over the folders wins, the rule `detector train` uses for the threshold alone. `--write`
records the choice and the whole table in the model's .json. Beside each size it prints the
network's time for a 640x480 frame on one thread, the price of that size in frame rate.
onnxruntime only: it runs on the Jetson too.
"""

from __future__ import annotations

import json
from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path

import numpy as np

from jetson.errors import DatasetError
from jetson.perception.cnn.runtime import CnnDetector, metadata_path, network_ms
from jetson.perception.dataset import RingDataset
from jetson.perception.evaluate import Counts, heldout_of, match

DEFAULT_SIZES = (480, 512, 528, 544, 560, 576, 608, 640)
DEFAULT_THRESHOLDS = (0.3, 0.35, 0.4, 0.45, 0.5, 0.55, 0.6)


@dataclass(frozen=True)
class Tuning:
    input_long_side: int
    score_threshold: float
    mean_f1: float
    # table[size][threshold][folder] = (precision, recall, F1)
    table: dict[int, dict[float, dict[str, tuple[float, float, float]]]]
    # network milliseconds for a 640x480 frame at each size, one thread (the frame-rate cost)
    network_ms: dict[int, float]


def score_size(
    detector: CnnDetector, dataset: RingDataset, thresholds: tuple[float, ...]
) -> dict[float, Counts]:
    """Counts at every threshold, the network run once per image at the lowest."""
    detector.threshold = min(thresholds)
    counts = {t: Counts() for t in thresholds}
    for i in range(len(dataset)):
        img = dataset.image(i)
        h, w = img.shape[:2]
        truth = dataset.boxes(i, w, h)
        dets = detector.detect(img)
        for t in thresholds:
            kept = [d for d in dets if d.score >= t]
            counts[t].add(len(kept), len(truth), len(match(kept, truth)))
    return counts


def tune(
    model: Path,
    folders: list[Path],
    sizes: tuple[int, ...] = DEFAULT_SIZES,
    thresholds: tuple[float, ...] = DEFAULT_THRESHOLDS,
    progress: bool = True,
) -> Tuning:
    if not folders:
        raise DatasetError("tuning needs at least one --val folder of labelled images")
    if not sizes or min(sizes) < 16:
        raise DatasetError(f"input sizes must be at least 16 pixels, got {sizes}")
    if not thresholds or not all(0.0 < t < 1.0 for t in thresholds):
        raise DatasetError(f"thresholds must lie in (0, 1), got {thresholds}")
    detector = CnnDetector(model)
    base = detector.info
    datasets = {}
    for folder in folders:
        ds = RingDataset(folder, heldout_of(base.extra, folder))
        if len(ds) == 0:
            raise DatasetError(f"{folder}: no images to tune on")
        datasets[str(folder)] = ds
    table: dict[int, dict[float, dict[str, tuple[float, float, float]]]] = {}
    ms: dict[int, float] = {}
    for size in _bar(sizes, progress):
        ms[size] = network_ms(model, size, repeats=10)
        detector.info = replace(base, input_long_side=size)
        per_folder = {name: score_size(detector, ds, thresholds) for name, ds in datasets.items()}
        table[size] = {
            t: {n: (c[t].precision, c[t].recall, c[t].f1) for n, c in per_folder.items()}
            for t in thresholds
        }
    best = max(
        ((s, t) for s in sizes for t in thresholds),
        key=lambda st: (_mean_f1(table[st[0]][st[1]]), -st[0]),  # a tie goes to the faster
    )
    return Tuning(best[0], best[1], _mean_f1(table[best[0]][best[1]]), table, ms)


def write_choice(model: Path, tuning: Tuning) -> None:
    """Record the chosen size and threshold, and the table behind them, in the model's .json."""
    path = metadata_path(model)
    meta = json.loads(path.read_text())
    if "tuning" in meta:
        # An int8 model is tuned twice (the float model's size, then its own threshold): keep
        # the earlier table, which chose the size.
        meta.setdefault("tuning_history", []).append(meta["tuning"])
    meta["tuning"] = {
        "from": {
            "input_long_side": meta["input_long_side"],
            "score_threshold": meta["score_threshold"],
        },
        "rule": "best mean F1 over the folders (their held-out images), ties to the smaller input",
        "mean_f1": round(tuning.mean_f1, 4),
        "network_ms_640x480": {str(k): round(v, 2) for k, v in tuning.network_ms.items()},
        "f1": {
            str(s): {str(t): {n: round(v[2], 4) for n, v in row.items()} for t, row in rows.items()}
            for s, rows in tuning.table.items()
        },
    }
    meta["input_long_side"] = tuning.input_long_side
    meta["score_threshold"] = tuning.score_threshold
    path.write_text(json.dumps(meta, indent=2) + "\n")


def calibration_note(model: Path, input_long_side: int) -> str | None:
    """A warning when an int8 model is moved to an input size other than the one its activation
    ranges were measured at: tune the float model, then quantize it."""
    quant = json.loads(metadata_path(model).read_text()).get("quantization")
    if not isinstance(quant, dict):
        return None
    calibrated = quant.get("input_long_side")
    if calibrated == input_long_side:
        return None
    at = f"at input {calibrated}" if calibrated is not None else "at an unrecorded input size"
    return (
        f"note: {model.name} is int8, calibrated {at}; for input {input_long_side} tune the float "
        f"model ({quant.get('float_model', 'the .onnx it was quantized from')}) and quantize it "
        "again"
    )


def format_table(tuning: Tuning) -> str:
    """Mean F1 by input size (rows) and threshold (columns), and the network's time for a
    640x480 frame at each size; the choice starred."""
    sizes = list(tuning.table)
    thresholds = list(tuning.table[sizes[0]])
    lines = ["size  " + "".join(f"{t:>8.2f}" for t in thresholds) + "   network ms"]
    for s in sizes:
        cells = []
        for t in thresholds:
            star = "*" if (s, t) == (tuning.input_long_side, tuning.score_threshold) else " "
            cells.append(f"{_mean_f1(tuning.table[s][t]):>7.3f}{star}")
        lines.append(f"{s:<6d}" + "".join(cells) + f"   {tuning.network_ms[s]:>10.1f}")
    return "\n".join(lines)


def _mean_f1(row: dict[str, tuple[float, float, float]]) -> float:
    return float(np.mean([v[2] for v in row.values()]))


def _bar(sizes: tuple[int, ...], progress: bool) -> Iterable[int]:
    if not progress:
        return sizes
    try:
        from tqdm import tqdm
    except ImportError:  # the Jetson's install has no tqdm
        return sizes
    return tqdm(sizes, desc="input sizes", unit="size")
