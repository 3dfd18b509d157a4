"""bench.perception's simulator test set: rendered once, rendered again when the scenes change."""

from __future__ import annotations

from pathlib import Path

import pytest

pytest.importorskip("pybullet")

import bench.perception as bench
from jetson.perception.dataset import RingDataset


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
