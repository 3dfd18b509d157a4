"""`pete-sim match --world tipping_point_2v2` on the full stack: the red 24" is brain_host, the
wire and the daemon running the scripted alliance; its partner and the blue alliance are players
in the twin; the summary breaks both alliances' scores down by element with the fouls."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sim import cli
from sim.errors import MatchError
from sim.fullstack.brain_host import DEFAULT_BINARY
from sim.fullstack.options import MatchOptions
from sim.fullstack.runner import run_match

pytestmark = pytest.mark.skipif(
    not DEFAULT_BINARY.exists(), reason="brain_host is not built: run `make build` first"
)


def test_the_full_stack_plays_one_robot_of_the_whole_game(tmp_path: Path) -> None:
    options = MatchOptions(
        seed=3, world="tipping_point_2v2", opponent="alliance", seconds=6.0,
        camera=False, gif=False, plots=False, out=tmp_path / "run",
    )  # fmt: skip
    result = run_match(options)
    assert result.passed, [c for c in result.checks if not c.passed]
    # The daemon decided with the scripted alliance as the 24" robot, and drove.
    log = [json.loads(x) for x in (tmp_path / "run" / "daemon.jsonl").read_text().splitlines()]
    config = next(r for r in log if r.get("event") == "config")
    assert "scripted alliance (24in)" in config["msg"]
    assert result.daemon is not None and result.daemon["counters"]["commands"] > 250  # 50 a second
    pose = result.brain["pose"] if result.brain else {}
    assert pose["by_fix"].get("gps", 0) > 0 and pose["error_max_m"] < 0.1
    # Both alliances' scores by element, with their fouls; the totals are the match's.
    assert result.game is not None and set(result.game) == {"red", "blue"}
    assert result.game["red"]["total"] == result.score
    assert result.game["blue"]["total"] == result.opponent_score
    assert {"rings_high", "goals_in_zone", "robots_elevated"} <= set(result.game["red"])
    summary = (tmp_path / "run" / "summary.txt").read_text()
    assert "red by element" in summary and "blue fouls" in summary
    # The isolation period: the scripted alliances stay off each other (no contact foul).
    for alliance in ("red", "blue"):
        assert not result.game[alliance]["fouls_by_kind"].get("isolation_contact"), alliance


def test_the_command_line_plays_the_whole_game_on_the_full_stack(tmp_path: Path) -> None:
    out = tmp_path / "cli"
    rc = cli.main([
        "match", "--world", "tipping_point_2v2", "--opponent", "alliance", "--seconds", "2",
        "--no-camera", "--no-gif", "--no-plots", "--quiet", "--out", str(out),
    ])  # fmt: skip
    assert rc == 0
    summary = json.loads((out / "summary.json").read_text())
    assert summary["game"]["red"]["total"] == summary["score"]


def test_a_side_with_the_wrong_number_of_players_is_refused(tmp_path: Path) -> None:
    options = MatchOptions(
        world="tipping_point_2v2", opponent="scripted,scripted,scripted", seconds=1.0,
        camera=False, gif=False, plots=False, out=tmp_path / "bad",
    )  # fmt: skip
    with pytest.raises(MatchError, match="3 players for 2 robots"):
        run_match(options)


def test_an_unknown_world_is_refused() -> None:
    with pytest.raises(MatchError, match="world must be one of"):
        MatchOptions(world="ring_toss")
