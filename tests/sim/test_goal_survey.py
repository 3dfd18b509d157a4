"""`python -m sim.goal_survey`: the goal detector on the twin's renders against the twin's
geometric sighting, over random poses (sim/goal_survey.py)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sim.goal_survey import main, run_survey


def test_a_small_survey_adds_up_and_places_goals_at_their_middles() -> None:
    survey = run_survey(24, seed=3)
    report = survey.as_dict()
    assert report["poses"] == 24 and report["goals_seen"] > 0
    assert 0 < report["true"] <= report["goals_seen"]
    assert len(survey.errors_m) == report["true"] == len(survey.range_errors_m)
    assert report["false"] == sum(report["false_by_what"].values())
    assert 0 <= report["false_off_the_platforms"] <= report["false"]
    # At the base's middle, not its near face (a base radius, 0.165 m, short).
    assert report["error_m"]["median"] < 0.05 and abs(report["range_error_m"]["median"]) < 0.05
    by_colour = report["by_colour"]
    assert sum(c.get("seen", 0) for c in by_colour.values()) == report["goals_seen"]
    assert sum(c.get("true", 0) for c in by_colour.values()) == report["true"]


def test_the_command_writes_its_report(tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    out = tmp_path / "survey.json"
    assert main(["--poses", "3", "--out", str(out)]) == 0
    written = json.loads(out.read_text())
    assert written == json.loads(capsys.readouterr().out)
    assert written["poses"] == 3 and written["size"] == "240x180"
    assert main(["--size", "big"]) == 2
