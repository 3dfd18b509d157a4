"""Event day: session recordings stay within their disk budget, a full disk pauses them with one
log line and never stops the robot, and a recording cut off at any byte (power lost mid-write)
replays up to the cut."""

from __future__ import annotations

import errno
import io
import json
import os
import threading
import time
import zlib
from collections.abc import Callable
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest

import jetson.recorder
from jetson import cli
from jetson.camera_feed import Perceived
from jetson.clock import MonotonicClock
from jetson.decide import Decider, PerceptionInput
from jetson.errors import ReplayError
from jetson.log import EventLog
from jetson.loop import Daemon
from jetson.recorder import CycleRecord, RecordingDir
from jetson.replay import replay
from jetson.settings import DecisionConfig, LinkConfig
from jetson.testing import FakeBrain, ProbePolicy
from protocol.messages import Alliance, Command, GpsStatus, MatchPhase, PoseFix, State

CUT_CYCLES = 4  # a small recording: it is replayed once per byte
pytestmark = pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning")


def wait_for(cond: Callable[[], bool], timeout_s: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while not cond():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.002)
    return True


def state(i: int) -> State:
    return State(
        seq=i + 1, time_ms=20 * i, phase=MatchPhase.AUTONOMOUS, phase_ms=20 * i,
        alliance=Alliance.RED, x=0.5 + 0.001 * i, y=-0.5, heading=90.0, gps_error=0.01,
        gps_status=GpsStatus.OK, pose_fix=PoseFix.GPS, pose_std=0.01, heading_std=0.5,
    )  # fmt: skip


def header(decider: Decider) -> dict[str, Any]:
    return {
        "policy": {"path": None, "sha256": None, "description": "probe policy"},
        "decision": decider.config.to_dict(),
        "decision_hz": decider.decision_hz,
        "observation": decider.spec.to_dict(),
    }


def record(recordings: RecordingDir, cycles: int, rings: bool = False) -> jetson.recorder.Recorder:
    """A session of `cycles` States answered by the probe policy, as the daemon records them;
    with `rings`, every other one sees a perception result."""
    decider = Decider(ProbePolicy())
    rec = recordings.open(header(decider))
    rec.reset(0.0)
    for i in range(cycles):
        s = state(i)
        pin = None
        if rings and i % 2:
            seen = Perceived(i, 0.02 * i, np.array([[0.1, 0.5 + 0.1 * i]]))
            rec.perception(seen)
            pin = PerceptionInput(seen.id, 0.05, seen.rings_robot_xy)
        d = decider.decide(s, pin)
        cmd = Command(i + 1, d.linear, d.angular, d.intake, 250)
        p_id, age = (pin.id, pin.age_s) if pin else (None, None)
        rec.cycle(
            CycleRecord(
                0.02 * i, s, p_id, age, cmd, d.reason, d.perception, d.rings, None, 0.5, 0.1
            )
        )
    return rec


# --- a full disk ----------------------------------------------------------------------------------


class FullDisk(io.TextIOBase):
    """A file on a disk that fills after `room` characters: then every write fails ENOSPC."""

    def __init__(self, inner: io.TextIOBase, room: int) -> None:
        self.inner = inner
        self.room = room
        self.failures = 0

    def write(self, s: str) -> int:
        if len(s) > self.room:
            self.failures += 1
            raise OSError(errno.ENOSPC, os.strerror(errno.ENOSPC))
        self.room -= len(s)
        return self.inner.write(s)

    def flush(self) -> None:
        self.inner.flush()

    def close(self) -> None:
        self.inner.close()


def test_a_full_disk_pauses_the_recording_with_one_line_and_the_robot_drives_on(
    tmp_path: Path, monkeypatch: pytest.MonkeyPatch
) -> None:
    disks: list[FullDisk] = []
    real_open = jetson.recorder._open

    def open_on_a_small_disk(path: Path) -> io.TextIOBase:
        disks.append(FullDisk(real_open(path), room=20_000))
        return disks[-1]

    monkeypatch.setattr(jetson.recorder, "_open", open_on_a_small_disk)
    brain = FakeBrain(link_path=tmp_path / "pete-brain").start()
    clock = MonotonicClock()
    out = io.StringIO()
    daemon = Daemon(
        Decider(ProbePolicy(), DecisionConfig()), clock, EventLog(out, None, clock, "debug"),
        link=LinkConfig(port=brain.path), summary_period_s=0.1,
        recordings=RecordingDir(tmp_path / "sessions", flush_s=0.05, compress=False),
        header={"policy": {"path": None, "sha256": None}},
    )  # fmt: skip
    stop = threading.Event()
    thread = threading.Thread(target=daemon.run, args=(stop,), daemon=True)
    thread.start()
    try:
        assert wait_for(lambda: bool(disks) and disks[0].failures > 0), "the disk never filled"
        full_at = len(brain.commands)
        # The robot never waits for the disk: States go on being answered by the policy.
        assert wait_for(lambda: len(brain.commands) >= full_at + 60)
        assert wait_for(lambda: daemon.recorder is None), "the recording was not paused"
        time.sleep(0.5)  # several summaries later: still one line
        assert thread.is_alive()
    finally:
        stop.set()
        thread.join(5.0)
        brain.close()
    after = [c.command for c in brain.commands[full_at:-1]]
    assert after and all(c.intake for c in after), "a stop was sent because the disk was full"
    lines = [json.loads(x) for x in out.getvalue().splitlines()]
    paused = [r for r in lines if r["event"] == "record_paused"]
    assert len(paused) == 1, paused
    assert "disk is full" in paused[0]["msg"] and "drives on" in paused[0]["msg"]
    assert paused[0]["t"] < lines[-1]["t"]  # said while running, not at exit
    assert not [r for r in lines if r["event"] in ("internal_error", "record")]
    # What reached the disk replays, up to where the disk filled.
    [session] = (tmp_path / "sessions").glob("session-*")
    report = replay(session, ProbePolicy())
    assert report.cycles > 10 and report.identical == report.cycles


def test_a_flush_that_fails_pauses_the_recording_too(tmp_path: Path) -> None:
    rec = record(RecordingDir(tmp_path, flush_s=0.02), 5)

    class Broken:
        def write(self, s: str) -> int:
            return len(s)

        def flush(self) -> None:
            raise OSError(errno.EIO, "Input/output error")

        def close(self) -> None:
            pass

    rec._file = Broken()  # type: ignore[assignment]
    rec.reset(1.0)
    assert wait_for(lambda: rec.failed is not None)
    assert "Input/output error" in str(rec.failed)
    rec.close(1.0)


# --- rotation by size -----------------------------------------------------------------------------


def test_the_oldest_sessions_go_first_and_a_session_stops_at_the_budget(tmp_path: Path) -> None:
    now = time.time()
    old = []
    for i in range(3):  # three earlier sessions, 1500 bytes each, oldest first
        p = tmp_path / f"session-20260101-00000{i}-001.jsonl"
        p.write_bytes(b"x" * 1500)
        os.utime(p, (now - 300 + 100 * i, now - 300 + 100 * i))
        old.append(p)
    recordings = RecordingDir(tmp_path, keep_bytes=3000, compress=False, flush_s=0.02)
    rec = record(recordings, 1)
    # At the start 4500 bytes were there: the oldest went first, down to the budget.
    assert not old[0].exists() and old[1].exists() and old[2].exists()
    # While it is written, older sessions make room; then it stops, whole, at the budget.
    for i in range(1, 400):
        s = state(i)
        rec.cycle(
            CycleRecord(0.0, s, None, None, Command(i, 0, 0, False, 250), "x", "-", 0, None, 0, 0)
        )
        time.sleep(0.001)
        if rec.failed:
            break
    assert wait_for(lambda: rec.failed is not None), "the session never reached the budget"
    rec.close(2.0)
    assert "budget" in str(rec.failed)
    assert [p.name for p, _ in recordings.sessions()] == [rec.path.name]
    size = rec.path.stat().st_size
    assert 3000 <= size < 3000 + 20 * 600, size  # stopped within a flush of the budget
    lines = rec.path.read_text().splitlines()
    assert all(json.loads(x) for x in lines)  # closed whole: no line cut


def test_the_budget_never_deletes_the_session_being_written(tmp_path: Path) -> None:
    recordings = RecordingDir(tmp_path, keep_bytes=10, compress=False)
    current = tmp_path / "session-20260101-000000-001.jsonl"
    current.write_bytes(b"y" * 100)
    assert recordings.prune(keep=current) == []
    assert current.exists()
    assert "budget" in str(recordings.enforce(current))


# --- cut off at any byte --------------------------------------------------------------------------


def whole_lines(data: bytes) -> list[dict[str, Any]]:
    """The oracle: the records a prefix holds whole."""
    *lines, last = data.split(b"\n")
    out = [json.loads(x) for x in lines if x.strip()]
    with_last = out
    try:
        rec = json.loads(last.decode())
        if isinstance(rec, dict):
            with_last = [*out, rec]
    except (UnicodeDecodeError, json.JSONDecodeError):
        pass
    return with_last


@pytest.mark.parametrize("compress", [True, False], ids=["gzip", "plain"])
def test_a_recording_cut_at_any_byte_replays_up_to_the_cut(tmp_path: Path, compress: bool) -> None:
    rec = record(RecordingDir(tmp_path / "full", compress=compress), CUT_CYCLES, rings=True)
    rec.close(5.0)
    assert rec.failed is None
    data = rec.path.read_bytes()
    full = replay(rec.path, ProbePolicy())
    assert full.ok and full.cycles == CUT_CYCLES and full.cut is None
    cut = tmp_path / rec.path.name
    cut.write_bytes(data)
    seen_cycles = set()
    for n in reversed(range(len(data))):  # cut shorter and shorter, in place
        os.truncate(cut, n)
        plain = zlib.decompressobj(wbits=31).decompress(data[:n]) if compress else data[:n]
        expected = whole_lines(plain)
        if not expected:
            with pytest.raises(ReplayError, match="cut off before its header"):
                replay(cut, ProbePolicy())
            continue
        report = replay(cut, ProbePolicy())
        cycles = sum(r["kind"] == "cycle" for r in expected)
        assert report.cycles == cycles, n
        assert report.identical == cycles, n  # every whole cycle replays exactly
        if compress or not any(r["kind"] == "end" for r in expected):
            # (A plain file whose end record is whole lacks nothing but a newline.)
            assert report.cut is not None, f"a cut at byte {n} of {len(data)} went unreported"
        seen_cycles.add(cycles)
    assert seen_cycles == set(range(CUT_CYCLES + 1))  # cuts everywhere from 0 to all cycles


def test_replay_reports_the_cut_and_exits_0_when_what_is_whole_matches(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    from jetson.testing import write_mlp_policy

    policy = write_mlp_policy(tmp_path / "policy")
    from jetson.autonomy.policy import OnnxPolicy

    onnx = OnnxPolicy(policy)
    decider = Decider(onnx)
    rec = RecordingDir(tmp_path / "s").open(
        {**header(decider), "policy": {"path": str(policy), "sha256": onnx.sha256}}
    )
    rec.reset(0.0)
    for i in range(20):
        d = decider.decide(state(i), None)
        cmd = Command(i + 1, d.linear, d.angular, d.intake, 250)
        rec.cycle(CycleRecord(0.0, state(i), None, None, cmd, d.reason, "-", 0, None, 0.5, 0.1))
    rec.close(5.0)
    data = rec.path.read_bytes()
    rec.path.write_bytes(data[: len(data) * 2 // 3])
    assert cli.main(["replay", str(rec.path)]) == 0
    text = capsys.readouterr().out
    assert "cut off" in text and "whole cycles before the cut were replayed" in text


def test_a_recording_from_before_protocol_v4_replays_as_it_was_decided(tmp_path: Path) -> None:
    """A v3 State has no pose_fix: its x, y, heading were the GPS's while gps_status was ok."""
    decider = Decider(ProbePolicy())
    rec = RecordingDir(tmp_path, compress=False).open(header(decider))
    rec.reset(0.0)
    for i in range(6):
        if i < 4:  # a GPS fix: the v3 daemon drove, as this one does
            st = state(i)
            d = decider.decide(st, None)
            cmd, why = Command(i + 1, d.linear, d.angular, d.intake, 250), d.reason
        else:  # no fix: the v3 daemon stopped ("gps error"); its State had zeros for the pose
            st = replace(state(i), gps_status=GpsStatus.ERROR, x=0.0, y=0.0, heading=0.0)
            cmd, why = Command(i + 1, 0.0, 0.0, False, 250), "gps error"
        rec.cycle(CycleRecord(0.0, st, None, None, cmd, why, "-", 0, None, 0.5, 0.1))
    rec.close(1.0)
    v4 = ("pose_fix", "pose_std", "heading_std", "period", "match_ms", "clamp", "lift")
    lines = []
    for line in rec.path.read_text().splitlines():
        r = json.loads(line)
        if r.get("kind") == "cycle":
            r["state"] = {k: v for k, v in r["state"].items() if k not in v4}
        lines.append(json.dumps(r))
    rec.path.write_text("\n".join(lines) + "\n")
    report = replay(rec.path, ProbePolicy())
    assert report.cycles == 6
    # The four with a GPS fix drove then and drive now; the two without stopped then, and stop
    # now (no pose, "gps error"): the same Commands.
    assert report.identical == 6, report.differences


def test_a_damaged_line_before_the_end_is_still_an_error(tmp_path: Path) -> None:
    rec = record(RecordingDir(tmp_path, compress=False), 4)
    rec.close(5.0)
    lines = rec.path.read_bytes().split(b"\n")
    lines[2] = lines[2][:10]
    rec.path.write_bytes(b"\n".join(lines))
    with pytest.raises(ReplayError, match=":3: not a JSON line"):
        replay(rec.path, ProbePolicy())
