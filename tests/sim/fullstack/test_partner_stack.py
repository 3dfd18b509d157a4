"""`pete-sim match --world tipping_point_2v2 --partner stack`: both red robots on the full stack,
each with its own brain_host, daemon and camera, the two Brains linked by VEXlink in the twin; and
the `vexlink-lost` fault, after which each robot plays on alone and says so."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from sim.errors import MatchError
from sim.fullstack.brain_host import DEFAULT_BINARY
from sim.fullstack.options import MatchOptions
from sim.fullstack.runner import run_match

pytestmark = pytest.mark.skipif(
    not DEFAULT_BINARY.exists(), reason="brain_host is not built: run `make build` first"
)


def options(out: Path, **kw: Any) -> MatchOptions:
    base: dict[str, Any] = dict(
        seed=1, world="tipping_point_2v2", opponent="alliance", partner="stack", seconds=4.0,
        gif=False, plots=False, out=out,
    )  # fmt: skip
    base.update(kw)
    return MatchOptions(**base)


def log(path: Path) -> list[dict[str, Any]]:
    return [json.loads(x) for x in path.read_text().splitlines() if x]


def test_both_red_robots_play_on_the_full_stack_and_hear_each_other(tmp_path: Path) -> None:
    out = tmp_path / "run"
    result = run_match(options(out))
    assert result.passed, [c for c in result.checks if not c.passed]
    p = result.partner
    assert p is not None and p["robot"] == "red_1"
    # The partner's own daemon decided as the 15" of the scripted alliance, and drove its robot.
    config = next(r for r in log(out / "partner_daemon.jsonl") if r.get("event") == "config")
    assert "scripted alliance (15in)" in config["msg"]
    assert p["jetson_share"] >= 0.95 and p["counters"]["commands"] > 150
    assert p["messages"]["down"]["lost"] == 0 and p["messages"]["up"]["lost"] == 0
    # Each Brain heard the other over the radio: its link came up before the match and stayed.
    assert p["our_partner_link"][-1][1] == "up" and p["partner_link"][-1][1] == "up"
    assert p["our_partner_link"][-1][0] < 0 and p["partner_link"][-1][0] < 0
    v = p["vexlink"]
    # About 10 reports a second each way, a few lost as the radio loses them.
    assert v["delivered"] >= 2 * 10 * 4 * 0.8 and v["lost"] < v["frames"] * 0.1
    for name in ("daemon.jsonl", "partner_daemon.jsonl"):
        said = [r for r in log(out / name) if r.get("event") == "partner_link"]
        assert said and "playing as an alliance" in said[0]["msg"], name
    # Our daemon reported to its partner ten times a second (what the partner's heard).
    assert result.daemon is not None and result.daemon["counters"]["partner_reports"] > 30
    summary = (out / "summary.txt").read_text()
    assert "partner (full stack)" in summary and "VEXlink radio" in summary


def test_when_the_vexlink_is_lost_each_robot_plays_on_alone(tmp_path: Path) -> None:
    out = tmp_path / "lost"
    result = run_match(options(out, fault="vexlink-lost", fault_at_s=1.5, camera=False))
    assert result.passed, [c for c in result.checks if not c.passed]
    names = {c.name for c in result.checks}
    assert {"both_play_alone", "both_drive_on"} <= names
    (record,) = result.faults
    assert record["kind"] == "vexlink-lost" and record["passed"]
    ours, theirs = record["alone_after_s"]
    assert 0.9 <= ours <= 1.5 and 0.9 <= theirs <= 1.5  # the Brain's 1 s timeout, then a status
    p = result.partner
    assert p is not None
    assert p["our_partner_link"][-1][1] == "lost" and p["partner_link"][-1][1] == "lost"
    summary = (out / "summary.txt").read_text()
    assert "each robot played on alone" in summary


def test_the_partner_stack_needs_the_whole_game_in_lockstep(tmp_path: Path) -> None:
    with pytest.raises(MatchError, match="whole-game"):
        MatchOptions(partner="stack", out=tmp_path)
    with pytest.raises(MatchError, match="lockstep"):
        options(tmp_path, realtime=True)
    with pytest.raises(MatchError, match="--partner stack"):
        run_match(options(tmp_path, partner="alliance", fault="vexlink-lost", camera=False))


@pytest.mark.parametrize("fault", ["schema-mismatch", "brain-reboot"])
def test_our_faults_leave_the_partner_playing(tmp_path: Path, fault: str) -> None:
    """A fault of ours is ours: the partner's Jetson keeps driving its robot (schema-mismatch:
    our Jetson announces another schema, the partner's does not; brain-reboot: our Brain is down
    a second, and the partner's reports sent meanwhile are lost, not delivered to the new
    Brain late)."""
    out = tmp_path / fault
    result = run_match(options(out, fault=fault, fault_at_s=1.5, camera=False))
    assert result.passed, [c for c in result.checks if not c.passed]
    p = result.partner
    assert p is not None and p["jetson_share"] >= 0.95
    assert p["messages"]["up"]["rejected"] == 0
    if fault == "brain-reboot":
        v = p["vexlink"]
        assert v["late"] == 0 and v["lost"] >= 5  # a second of the partner's reports
        assert p["our_partner_link"][-1][1] == "up"  # the new Brain hears the partner again


def test_a_learned_alliance_plays_its_policy_on_both_robots(tmp_path: Path) -> None:
    """--policy in the whole game: both robots' daemons run the policy (player "policy"), each
    as its own role, and hear each other over VEXlink."""
    from tests.sim.alliance_policy import untrained_alliance_policy

    policy = untrained_alliance_policy(tmp_path / "policy")
    out = tmp_path / "learned"
    result = run_match(options(out, policy=policy, player="policy", seconds=3.0))
    assert result.passed, [c for c in result.checks if not c.passed]
    for name, role in (("daemon.jsonl", "24in"), ("partner_daemon.jsonl", "15in")):
        config = next(r for r in log(out / name) if r.get("event") == "config")
        decision = config["settings"]["decision"]
        assert (decision["player"], decision["role"]) == ("policy", role), name
        assert config["msg"].startswith(f"policy {policy}")
        said = [r for r in log(out / name) if r.get("event") == "partner_link"]
        assert said and "playing as an alliance" in said[0]["msg"], name
    p = result.partner
    assert p is not None and p["jetson_share"] >= 0.95
    with pytest.raises(MatchError, match="whole game"):
        MatchOptions(player="alliance", out=tmp_path)
