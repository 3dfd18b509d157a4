"""bench.perception: its simulator test set (rendered once, rendered again when the scenes
change) and its real-image folders (each alone and pooled)."""

from __future__ import annotations

from pathlib import Path

import cv2
import numpy as np
import pytest

pytest.importorskip("pybullet")

import bench.perception as bench
from bench.common import Result
from jetson.perception.camera import CameraConfig
from jetson.perception.dataset import RingDataset
from jetson.perception.detection import Detection


def test_a_test_set_from_older_scenes_is_rendered_again(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    monkeypatch.setattr(bench, "ROOT", tmp_path)
    out = bench.simulator_test_set(2)
    assert out is not None and len(RingDataset(out)) == 2
    stamp = (out / "done").read_text()
    marker = out / "images" / "left-over.png"
    marker.write_bytes(b"")
    assert bench.simulator_test_set(2) == out and marker.exists()  # reused as it is
    (out / "done").write_text("complete\n")  # what code before scene versions wrote
    assert bench.simulator_test_set(2) == out
    assert not marker.exists() and (out / "done").read_text() == stamp


class _OneBox:
    """A detector that sees one ring, always in the same place."""

    name = "fixed"

    def detect(self, bgr, depth_m=None, colour_mask=None):  # type: ignore[no-untyped-def]
        return [Detection(16.0, 16.0, 32.0, 32.0, 0.9)]


def _folder(root: Path, labels: str) -> Path:
    (root / "images").mkdir(parents=True)
    (root / "labels").mkdir()
    cv2.imwrite(str(root / "images" / "a.png"), np.zeros((64, 64, 3), np.uint8))
    (root / "labels" / "a.txt").write_text(labels)
    return root


def test_real_folders_are_scored_alone_and_pooled(tmp_path: Path) -> None:
    # Folder 1: the fixed box is one of two rings (TP 1, FN 1); folder 2: its one ring is
    # elsewhere (FP 1, FN 1). Pooled: TP 1, FP 1, FN 2, so precision 1/2, recall 1/3, F1 0.4.
    # Its zero-size label line is left out, not an error.
    one = _folder(tmp_path / "one", "0 0.375 0.375 0.25 0.25\n0 0.8 0.8 0.2 0.2\n")
    two = _folder(tmp_path / "two", "0 0.8 0.2 0.2 0.2\n0 0.5 0.5 0 0\n")
    result = Result("perception")
    bench.real_images({"fixed": _OneBox()}, CameraConfig(), [one, two], None, result)
    m = result.metrics
    assert m["real1_fixed_precision"] == 1.0 and m["real1_fixed_recall"] == 0.5
    assert m["real2_fixed_f1"] == 0.0
    assert m["real_fixed_precision"] == 0.5 and m["real_fixed_recall"] == round(1 / 3, 4)
    assert m["real_fixed_f1"] == 0.4 and m["real_images"] == 2
    # One folder alone keeps the plain names.
    alone = Result("perception")
    bench.real_images({"fixed": _OneBox()}, CameraConfig(), [one], None, alone)
    assert alone.metrics["real_fixed_f1"] == round(2 / 3, 4)
    assert not any(k.startswith("real1_") for k in alone.metrics)
