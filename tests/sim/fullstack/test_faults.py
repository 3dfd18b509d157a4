"""`pete-sim match --fault NAME` / `--faults NAME@S,...`: every fault scenario, in a short lockstep
match, keeps its promises (sim/fullstack/faults.py lists them); the daemon as its own process
plays exactly as the in-process one; bad schedules and options are refused by name."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import pytest

from sim.errors import MatchError
from sim.fullstack import cli
from sim.fullstack.brain_host import DEFAULT_BINARY
from sim.fullstack.faults import FAULTS, make_scenario, parse_schedule, read_log
from sim.fullstack.options import MatchOptions
from sim.fullstack.report import MatchResult
from sim.fullstack.runner import run_match

pytestmark = pytest.mark.skipif(
    not DEFAULT_BINARY.exists(), reason="brain_host is not built: run `make build` first"
)

# The faults that are not about perception render a small camera: a fraction of the cost.
SMALL_CAMERA = {"camera_width": 96, "camera_height": 72, "camera_hz": 5.0, "detector": "classical"}


@pytest.fixture(scope="module")
def policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    from jetson.testing import write_mlp_policy

    return write_mlp_policy(tmp_path_factory.mktemp("policy"), seed=3)


def play(
    policy: Path,
    folder: Path,
    fault: str | None,
    seconds: float = 4.0,
    at: float = 1.0,
    **kw: Any,
) -> MatchResult:
    result = run_match(
        MatchOptions(
            policy=policy, out=folder, seconds=seconds, fault=fault, fault_at_s=at,
            opponent="none", gif=False, plots=False, **kw,
        )
    )  # fmt: skip
    failed = [f"{c.name}: {c.detail}" for c in result.checks if not c.passed]
    assert not failed, failed
    return result


def checks(result: MatchResult) -> dict[str, str]:
    return {c.name: c.detail for c in result.checks}


def test_every_fault_has_a_scenario_and_a_flag() -> None:
    assert set(FAULTS) == {
        "link-cut", "corruption", "jetson-killed", "schema-mismatch", "camera-stops",
        "jetson-sigterm", "jetson-sigkill", "disk-full", "brain-reboot", "vexlink-lost",
    }  # fmt: skip
    assert set(cli.FAULT_NAMES) == set(FAULTS)


def test_link_cut(policy: Path, tmp_path: Path) -> None:
    r = play(policy, tmp_path, "link-cut")
    assert set(checks(r)) == {
        "integrity", "valid_commands", "stops_in_time", "stays_stopped", "daemon_reconnects",
        "match_goes_on", "back_in_time",
    }  # fmt: skip
    # Two seconds of Brain output went nowhere; nothing came down meanwhile.
    assert r.messages["up"]["lost"] >= 90 and r.messages["up"]["bytes_dropped"] > 0
    assert r.messages["plugs"] == 2
    assert r.daemon["counters"]["disconnects"] == 1 and r.daemon["counters"]["connects"] == 2
    assert "command_timeout" in r.brain["faults_seen"]
    assert r.brain["source_s"]["none"] == pytest.approx(2.0, abs=0.3), "out for the cut only"
    # The Brain's validity window, to the step: the last Command drove for 240 ms after it
    # arrived, and the first step without one is 250 ms after the cut.
    assert r.brain["max_command_age_ms"] <= 250
    (fault,) = r.faults
    assert fault["kind"] == "link-cut" and fault["passed"]
    assert fault["stop_after_fault_ms"] <= 250 and fault["reconnect_ms"] <= 1000
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
    assert r.brain["invalid_command_steps"] == 0


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


def test_jetson_sigterm_exits_in_time_with_a_stop_and_restarts(
    policy: Path, tmp_path: Path
) -> None:
    r = play(policy, tmp_path, "jetson-sigterm", **SMALL_CAMERA)
    assert {"exits_in_time", "sends_stop", "stops_in_time", "back_in_time"} <= set(checks(r))
    assert r.daemon["mode"] == "process", "a real signal needs a real process"
    first, last = r.daemon["exits"]
    assert first["how"] == "sigterm" and first["returncode"] == 0 and not first["forced"]
    assert first["stop_sent"] and first["exit_s"] <= 1.0
    assert last["how"] == "quit" and r.daemon["processes"] == 2
    log = read_log(tmp_path / "daemon.jsonl")
    events = [e["event"] for e in log]
    assert "signal" in events and events.count("start") == 2
    signal_at = events.index("signal")
    assert "stop_sent" in events[signal_at:], "the stop goes out after the signal"
    assert r.faults[0]["reconnect_ms"] <= 1000
    assert r.brain["invalid_command_steps"] == 0


def test_jetson_sigkill_restarts(policy: Path, tmp_path: Path) -> None:
    r = play(policy, tmp_path, "jetson-sigkill", **SMALL_CAMERA)
    first = r.daemon["exits"][0]
    assert first["how"] == "sigkill" and first["returncode"] == -9
    assert not first["said_bye"] and not first["stop_sent"]
    log = read_log(tmp_path / "daemon.jsonl")
    starts = [i for i, e in enumerate(log) if e["event"] == "start"]
    assert len(starts) == 2
    between = {e["event"] for e in log[starts[0] : starts[1]]}
    assert not between & {"signal", "stop_sent", "exit"}, "a killed daemon says nothing"
    assert r.faults[0]["stop_after_fault_ms"] <= 250
    assert r.brain["invalid_command_steps"] == 0


def test_disk_full_pauses_the_recording_not_the_robot(policy: Path, tmp_path: Path) -> None:
    r = play(policy, tmp_path, "disk-full", record=True, **SMALL_CAMERA)
    assert set(checks(r)) >= {"keeps_driving", "daemon_lives", "logs_it"}
    assert r.daemon["processes"] == 1
    assert 1 <= r.faults[0]["log_lines"] <= 3
    assert any((tmp_path / "sessions").glob("session-*"))


def test_a_second_full_disk_finds_the_recording_paused(policy: Path, tmp_path: Path) -> None:
    """The first full disk pauses the recording (one line); it starts again only with the next
    Brain session, so the second has nothing to fail and says nothing."""
    schedule = (("disk-full", 1.0), ("disk-full", 7.5))
    r = play(policy, tmp_path, None, seconds=13.0, faults=schedule, record=True, **SMALL_CAMERA)
    first, second = r.faults
    assert first["was_recording"] and first["log_lines"] == 1
    assert not second["was_recording"] and second["log_lines"] == 0
    log = read_log(tmp_path / "daemon.jsonl")
    assert [e["event"] for e in log].count("record_paused") == 1


def test_disk_full_needs_a_recording(policy: Path, tmp_path: Path) -> None:
    with pytest.raises(MatchError, match="add --record"):
        run_match(MatchOptions(policy=policy, out=tmp_path, fault="disk-full", seconds=2.0))


def test_brain_reboot(policy: Path, tmp_path: Path) -> None:
    r = play(policy, tmp_path, "brain-reboot", **SMALL_CAMERA)
    assert r.brain["brains"] == 2 and r.messages["brains"] == 2
    assert r.daemon["mode"] == "inprocess"
    log = read_log(tmp_path / "daemon.jsonl")
    restart = [e for e in log if e["event"] == "brain_restart"]
    assert len(restart) == 1 and restart[0]["brain_boot_id"] in checks(r)["daemon_sees_new_boot"]
    assert r.faults[0]["reconnect_ms"] <= 1000
    assert "brain_host.stderr" in r.files["brain_stderr"]


def test_a_schedule_of_faults_with_windows(policy: Path, tmp_path: Path) -> None:
    """Several faults in one match, each with its own checks; camera-stops and corruption last
    their window, then the match goes on as before."""
    schedule = (("camera-stops", 1.0), ("corruption", 5.5), ("link-cut", 12.5))
    r = play(policy, tmp_path, None, seconds=17.0, faults=schedule, **SMALL_CAMERA)
    names = set(checks(r))
    assert "camera-stops@1s sees_again" in names and "link-cut@12.5s back_in_time" in names
    assert [f["kind"] for f in r.faults] == ["camera-stops", "corruption", "link-cut"]
    assert r.faults[0]["frames_after_return"] > 0
    events = (tmp_path / "events.txt").read_text()
    assert "camera back" in events and "no more corruption" in events


def test_the_daemon_as_a_process_plays_the_same_match(policy: Path, tmp_path: Path) -> None:
    """Same seed, same inputs: the daemon in its own process decides exactly as in this one."""
    a = play(policy, tmp_path / "in", None, seconds=3.0, daemon="inprocess", **SMALL_CAMERA)
    b = play(policy, tmp_path / "proc", None, seconds=3.0, daemon="process", **SMALL_CAMERA)
    assert (a.rings, a.score) == (b.rings, b.score)
    assert a.messages == b.messages
    assert a.perception == b.perception
    assert a.daemon["counters"] == b.daemon["counters"]
    strip = lambda p: (p / "timeline.csv").read_text()  # noqa: E731
    assert strip(tmp_path / "in") == strip(tmp_path / "proc")


@pytest.mark.parametrize(
    ("text", "why"),
    [
        ("link-cut", "NAME@SECONDS"),
        ("link-cut@", "NAME@SECONDS"),
        ("@3", "NAME@SECONDS"),
        ("link-cut@x", "NAME@SECONDS"),
    ],
)
def test_a_bad_schedule_is_named(text: str, why: str) -> None:
    with pytest.raises(MatchError, match=why):
        parse_schedule(text)


def test_schedules_and_options_are_checked(policy: Path) -> None:
    got = parse_schedule("link-cut@10, disk-full@20.5")
    assert got == (("link-cut", 10.0), ("disk-full", 20.5))

    def scenario(**kw: Any) -> Any:
        o = MatchOptions(policy=policy, **kw)
        return make_scenario(o.fault, o.fault_at_s, o)

    with pytest.raises(MatchError, match="faults overlap: link-cut@10s lasts until 14 s"):
        scenario(faults=(("link-cut", 10.0), ("corruption", 12.0)))
    with pytest.raises(MatchError, match="schema-mismatch lasts the whole match"):
        scenario(faults=(("schema-mismatch", 1.0),))
    with pytest.raises(MatchError, match="unknown fault 'unplug'"):
        scenario(faults=(("unplug", 1.0),))
    with pytest.raises(MatchError, match="not both"):
        scenario(fault="link-cut", faults=(("corruption", 1.0),))
    with pytest.raises(MatchError, match="needs the daemon as its own process"):
        scenario(fault="jetson-sigterm", daemon="inprocess")
    with pytest.raises(MatchError, match="lockstep only"):
        scenario(fault="brain-reboot", realtime=True)
    with pytest.raises(MatchError, match="lockstep only"):
        MatchOptions(policy=policy, daemon="process", realtime=True)
    with pytest.raises(MatchError, match="daemon must be one of"):
        MatchOptions(policy=policy, daemon="thread")
    s = scenario(faults=(("jetson-sigkill", 3.0), ("link-cut", 7.0)))
    assert s.daemon_mode(MatchOptions(policy=policy)) == "process"
    assert [p.label for p in s.parts] == ["jetson-sigkill@3s", "link-cut@7s"]


def test_restart_sec_follows_the_unit(tmp_path: Path) -> None:
    from sim.fullstack.faults import UNIT, restart_sec

    assert "RestartSec=" in UNIT.read_text(), "the shipped unit restarts the daemon"
    unit = tmp_path / "pete-jetson.service"
    unit.write_text("[Service]\nRestart=always\nRestartSec=2s\n")
    assert restart_sec(unit) == 2.0
    assert restart_sec(tmp_path / "none.service") == 1.0


def test_the_command_line_plays_a_schedule(
    policy: Path, tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from sim import cli as sim_cli

    args = ["match", "--policy", str(policy), "--seconds", "4", "--opponent", "none", "--quiet"]
    args += ["--no-gif", "--no-plots", "--camera-size", "96x72", "--camera-hz", "5"]
    args += ["--detector", "classical"]
    code = sim_cli.main([*args, "--faults", "link-cut@1", "--out", str(tmp_path / "ok")])
    out = capsys.readouterr().out
    assert code == 0 and "check link-cut@1s back_in_time" in out
    assert sim_cli.main([*args, "--faults", "link-cut", "--out", str(tmp_path / "bad")]) == 2
    assert "NAME@SECONDS" in capsys.readouterr().err
    bad = ["--fault", "jetson-sigterm", "--daemon", "inprocess", "--out", str(tmp_path / "bad")]
    assert sim_cli.main([*args, *bad]) == 2
    assert "needs the daemon as its own process" in capsys.readouterr().err
