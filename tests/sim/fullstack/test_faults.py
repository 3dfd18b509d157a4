"""`pete-sim match --fault NAME`: every fault scenario, in a short lockstep match, keeps its
promises (sim/fullstack/faults.py lists them)."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from sim.fullstack.brain_host import DEFAULT_BINARY
from sim.fullstack.faults import FAULTS, read_log
from sim.fullstack.options import MatchOptions
from sim.fullstack.report import MatchResult
from sim.fullstack.runner import run_match

pytestmark = pytest.mark.skipif(
    not DEFAULT_BINARY.exists(), reason="brain_host is not built: run `make build` first"
)


@pytest.fixture(scope="module")
def policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from jetson.testing import write_mlp_policy

    return write_mlp_policy(tmp_path_factory.mktemp("policy"), seed=3)


def play(
    policy: Path, folder: Path, fault: str, seconds: float = 4.0, at: float = 1.0
) -> MatchResult:
    result = run_match(
        MatchOptions(
            policy=policy, out=folder, seconds=seconds, fault=fault, fault_at_s=at,
            opponent="none", gif=False, plots=False,
        )
    )  # fmt: skip
    failed = [f"{c.name}: {c.detail}" for c in result.checks if not c.passed]
    assert not failed, failed
    return result


def checks(result: MatchResult) -> dict[str, str]:
    return {c.name: c.detail for c in result.checks}


def test_every_fault_has_a_scenario() -> None:
    assert set(FAULTS) == {
        "link-cut", "corruption", "jetson-killed", "schema-mismatch", "camera-stops",
    }  # fmt: skip


def test_link_cut(policy: Path, tmp_path: Path) -> None:
    r = play(policy, tmp_path, "link-cut")
    assert set(checks(r)) == {
        "integrity", "stops_in_time", "stays_stopped", "daemon_reconnects", "match_goes_on",
    }  # fmt: skip
    # Two seconds of Brain output went nowhere; nothing came down meanwhile.
    assert r.messages["up"]["lost"] >= 90 and r.messages["up"]["bytes_dropped"] > 0
    assert r.messages["plugs"] == 2
    assert r.daemon["counters"]["disconnects"] == 1 and r.daemon["counters"]["connects"] == 2
    assert "command_timeout" in r.brain["faults_seen"]
    assert r.brain["source_s"]["none"] == pytest.approx(2.0, abs=0.3), "out for the cut only"
    log = read_log(tmp_path / "daemon.jsonl")
    assert any(e["event"] == "link_down" for e in log)


def test_corruption(policy: Path, tmp_path: Path) -> None:
    r = play(policy, tmp_path, "corruption", at=0.0)
    up, down = r.messages["up"], r.messages["down"]
    assert up["bytes_corrupted"] > 0 and down["bytes_corrupted"] > 0
    assert up["rejected"] > 0 and down["rejected"] > 0
    assert up["altered"] == down["altered"] == 0
    assert "link_errors" in r.brain["faults_seen"]
    assert r.brain["commands_applied"] >= 50, "Commands still get through"


def test_jetson_killed(policy: Path, tmp_path: Path) -> None:
    r = play(policy, tmp_path, "jetson-killed")
    assert "driver" in r.brain["source_s"]
    log = read_log(tmp_path / "daemon.jsonl")
    assert not any(e["event"] == "stop_sent" for e in log), "a killed daemon says no goodbye"


def test_schema_mismatch(policy: Path, tmp_path: Path) -> None:
    r = play(policy, tmp_path, "schema-mismatch", seconds=2.0, at=0.0)
    assert r.brain["commands_applied"] == 0
    assert r.brain["driven_s"] == 0.0
    assert r.messages["down"]["sent_by_type"].get("Command", 0) == 0, "the daemon never commands"
    assert "fingerprint_mismatch" in r.brain["faults_seen"]


def test_camera_stops(policy: Path, tmp_path: Path) -> None:
    r = play(policy, tmp_path, "camera-stops")
    # Frames at 0, 0.1 ... 0.9 s were perceived; the 1.0 s one was in flight when it stopped.
    assert r.perception["frames"] == 10 and r.perception["frames_sent"] == 11
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["passed"] is True
