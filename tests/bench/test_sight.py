"""bench.sight in a tiny config (a few scenes): the result file's shape, sane numbers and the
per-class details; and its matching of sightings to the truth."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest

pytest.importorskip("pybullet")

from bench import sight


def test_a_tiny_sight_benchmark_writes_its_results(tmp_path: Path) -> None:
    assert sight.main(["--scenes", "6", "--seed", "3", "--results", str(tmp_path)]) == 0
    result = json.loads((tmp_path / "sight.json").read_text())
    assert set(result) == {"benchmark", "metrics", "targets", "machine", "date"}
    assert result["benchmark"] == "sight"
    m, t = result["metrics"], result["targets"]
    assert m["scenes"] == 6
    for cls in sight.CLASSES:
        assert t[f"f1_{cls}"]["op"] == ">=" and t[f"f1_{cls}"]["target"] == 0.95
        assert t[f"median_error_m_{cls}"]["op"] == "<="
        assert m[f"true_{cls}"] + m[f"missed_{cls}"] == m[f"truths_{cls}"]
        if f"f1_{cls}" in m:
            assert 0.0 <= m[f"f1_{cls}"] <= 1.0
        if f"median_error_m_{cls}" in m:
            assert 0.0 <= m[f"median_error_m_{cls}"] <= sight.REACH_M
    assert sum(m[f"truths_{cls}"] for cls in sight.CLASSES) > 0
    assert sum(m[f"true_{cls}"] for cls in sight.CLASSES) > 0
    assert m["fps_one_core"] > 0 and m["fps_one_core_with_rings"] > 0
    assert t["fps_one_core"] == {"target": 60.0, "op": ">=", "met": m["fps_one_core"] >= 60.0}
    details = json.loads((tmp_path / "sight_details.json").read_text())
    assert details["scenes"] == 6 and set(details["classes"]) == set(sight.CLASSES)
    for cls, row in details["classes"].items():
        assert row["truths"] == m[f"truths_{cls}"] and row["false"] == m[f"false_{cls}"]


def _truth(cls: str, colour: str, x: float, y: float, counted: bool = True) -> sight.Truth:
    return sight.Truth(cls, colour, np.array([x, y]), counted)


def _seen(colour: str, x: float, y: float, kind: str = "goal") -> sight.Sighting:
    return sight.Sighting(colour, np.array([x, y]), kind)


def test_sightings_match_the_nearest_truth_of_their_colour_and_kind() -> None:
    scene = [
        _truth("red_goal", "red", 0.0, 1.0),
        _truth("red_goal", "red", 0.5, 1.0),
        _truth("blue_goal", "blue", 0.0, 3.0, counted=False),  # beyond 2 m
        _truth("red_robot", "red", -1.0, 1.0),
    ]
    seen = [
        _seen("red", 0.45, 1.0),  # the second red goal, nearer than the first
        _seen("red", 0.1, 1.0),  # then the first
        _seen("red", 0.2, 1.1),  # a second sighting of the goals, farther: false
        _seen("blue", 0.1, 3.0),  # at a goal the truth leaves out: neither way
        _seen("red", -1.0, 1.0),  # a red goal's colour where a red robot stands: false
        _seen("red", -0.95, 1.0, "robot"),  # the red robot
        _seen("blue", 2.0, 2.0, "robot"),  # nothing there
    ]
    assert sight.match(seen, scene) == [
        ("true", 1),
        ("true", 0),
        ("false", -1),
        ("beyond", 2),
        ("false", -1),
        ("true", 3),
        ("false", -1),
    ]


def test_goal_classes_tell_the_tall_neutral_goal_from_the_others() -> None:
    from sim.goal_survey import survey_world

    world = survey_world()
    classes = sight.goal_classes(world)
    assert classes.count("tall_neutral_goal") == 1 and classes.count("neutral_goal") == 2
    assert classes.count("red_goal") == 2 and classes.count("blue_goal") == 2
    tall = world.goals[classes.index("tall_neutral_goal")]
    assert tall.spec.alliance is None and tall.spec.name == "neutral_tall"
