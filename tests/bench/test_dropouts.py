"""bench.dropouts on one short seed: both matches are played, and every metric and target lands
in its JSON."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench import dropouts
from sim.fullstack.brain_host import DEFAULT_BINARY


@pytest.mark.skipif(not DEFAULT_BINARY.exists(), reason="brain_host is not built")
def test_a_tiny_run_writes_every_metric(tmp_path: Path) -> None:
    rc = dropouts.main([
        "--seeds", "1", "--seconds", "3", "--jobs", "2",
        "--out", str(tmp_path / "runs"), "--results", str(tmp_path),
    ])  # fmt: skip
    assert rc == 0
    data = json.loads((tmp_path / "dropouts.json").read_text())
    m = data["metrics"]
    for key in ("red_score_clear", "red_score_occluded", "score_ratio", "gps_hidden_share",
                "pose_error_max_m", "pose_std_max_m", "pose_stops", "checks_failed"):  # fmt: skip
        assert key in m, key
    assert m["checks_failed"] == 0 and 0 <= m["gps_hidden_share"] <= 1
    assert set(data["targets"]) == {"score_ratio", "checks_failed"}
    assert sorted(p.name for p in (tmp_path / "runs").iterdir()) == [
        "seed0-clear", "seed0-occluded", "seeds.json",
    ]  # fmt: skip
    per_match = json.loads((tmp_path / "runs" / "seeds.json").read_text())
    assert [(r["seed"], r["occluded"]) for r in per_match] == [(0, False), (0, True)]
    # --collect plays nothing and reports the same from the folders the run left.
    again = tmp_path / "again"
    rc = dropouts.main([
        "--collect", "--seeds", "3", "--out", str(tmp_path / "runs"), "--results", str(again),
    ])  # fmt: skip
    assert rc == 0
    collected = json.loads((again / "dropouts.json").read_text())["metrics"]
    assert collected["seeds"] == 1  # seeds 1 and 2 were never played there
    for key in ("red_score_clear", "red_score_occluded", "pose_error_max_m", "pose_stops"):
        assert collected[key] == m[key], key
