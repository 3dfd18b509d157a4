"""A session recording in the dashboard (`pete-jetson dashboard --recording`, its time slider)
and as plots (`pete-jetson report`)."""

from __future__ import annotations

import asyncio
import json
import os
import re
import signal
import subprocess
import sys
import time
import urllib.request
from pathlib import Path
from typing import Any

import aiohttp
import numpy as np
import pytest

from jetson.dashboard.replay import ReplaySource, Timeline
from jetson.dashboard.server import DashboardServer
from tests.jetson.dashboard.stack import live_stack, wait_for


@pytest.fixture(scope="module")
def recording(tmp_path_factory: pytest.TempPathFactory) -> Path:
    with live_stack(tmp_path_factory.mktemp("rec"), dashboard=None, frames_hz=5.0) as run:
        assert wait_for(lambda: run.daemon.counters.states >= 200)
        run.brain.send_log("a line from the Brain")
        path = Path(run.daemon.recorder.path)
    return path


def test_timeline_rebuilds_the_memories_and_keeps_the_frames(recording: Path) -> None:
    tl = Timeline(recording)
    assert not tl.warnings, tl.warnings
    span = tl.end_t - tl.start_t
    assert len(tl.snapshots) >= 15 * span  # 20 a second
    assert len(tl.frames) >= 3 * span
    last = tl.snapshots[-1]
    assert last["field"]["memory"] and last["field"]["remembered"]
    assert last["field"]["skill"] is not None and last["pose"]["gps_status"] == "ok"
    assert last["link"]["states"] == len(tl.cycles)
    mid = (tl.start_t + tl.end_t) / 2
    snap = tl.snapshot_at(mid)
    assert mid - 0.1 < snap["t"] <= mid
    _, msg = tl.frame_at(mid)
    frame = json.loads(msg)
    assert frame["kind"] == "frame" and frame["stamp"] <= mid and frame["jpeg"]
    assert tl.frame_at(tl.start_t - 10) is None


def test_without_the_policy_the_timeline_still_plays(recording: Path) -> None:
    tl = Timeline(recording, memories=False)
    assert tl.snapshots[-1]["pose"] is not None and not tl.snapshots[-1]["field"]["memory"]


def test_replay_page_follows_its_own_cursor(recording: Path) -> None:
    tl = Timeline(recording)
    server = DashboardServer(ReplaySource(tl), "127.0.0.1", 0).start()
    mid = (tl.start_t + tl.end_t) / 2

    async def talk() -> list[dict[str, Any]]:
        got = []
        async with (
            aiohttp.ClientSession() as session,
            session.ws_connect(server.url.replace("http", "ws") + "ws") as ws,
        ):
            hello = json.loads((await ws.receive(timeout=5)).data)
            got.append(hello)
            await ws.send_str(json.dumps({"seek": mid}))
            deadline = time.monotonic() + 3
            while time.monotonic() < deadline:
                msg = json.loads((await ws.receive(timeout=3)).data)
                got.append(msg)
                if msg["kind"] == "cursor" and abs(msg["t"] - mid) < 1e-6:
                    break
            await ws.send_str(json.dumps({"play": True, "speed": 4}))
            await asyncio.sleep(0.5)
            while True:
                msg = json.loads((await ws.receive(timeout=3)).data)
                got.append(msg)
                if msg["kind"] == "cursor" and msg["t"] > mid + 0.5:
                    break
        return got

    try:
        msgs = asyncio.run(talk())
    finally:
        server.stop()
    hello = msgs[0]
    assert hello["mode"] == "replay" and hello["read_only"] and hello["end_t"] > hello["start_t"]
    states = [m for m in msgs if m["kind"] == "state"]
    assert any(mid - 0.1 < s["t"] <= mid for s in states)
    assert any(m["kind"] == "frame" for m in msgs)
    assert states[-1]["t"] > mid + 0.4  # playing at 4x moved it on


def test_report_writes_plots_and_figures(recording: Path, tmp_path: Path) -> None:
    pytest.importorskip("matplotlib")
    out = tmp_path / "report"
    done = subprocess.run(
        [sys.executable, "-m", "jetson.cli", "report", str(recording), "--out", str(out)],
        capture_output=True, text=True, timeout=120,
    )  # fmt: skip
    assert done.returncode == 0, done.stderr
    info = json.loads((out / "report.json").read_text())
    assert (out / "report.png").stat().st_size > 10_000
    assert info["cycles"] >= 200 and info["driven_s"].get("jetson", 0) > 2.0
    assert info["latency_ms"]["n"] == info["cycles"] and info["frames_kept"] > 0


def test_dashboard_command_serves_a_recording(recording: Path) -> None:
    # Ctrl-C as a user's terminal delivers it: the child must not inherit an ignored SIGINT
    # (a shell's background job ignores it, and so would the dashboard the test starts).
    proc = subprocess.Popen(
        [sys.executable, "-m", "jetson.cli", "dashboard", "--recording", str(recording),
         "--address", "127.0.0.1:0"],
        stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
        preexec_fn=lambda: signal.signal(signal.SIGINT, signal.SIG_DFL),
    )  # fmt: skip
    try:
        line = proc.stdout.readline()
        url = re.search(r"(http://\S+/)", line)
        assert url, line + proc.stderr.read() if proc.poll() is not None else line
        with urllib.request.urlopen(url.group(1) + "api/snapshot", timeout=5) as r:
            snap = json.load(r)
        assert snap["kind"] == "state" and snap["pose"] is not None
        with urllib.request.urlopen(url.group(1), timeout=5) as r:
            assert b"Read-only" in r.read()
    finally:
        proc.send_signal(signal.SIGINT)
        assert proc.wait(10) == 0
    bad = subprocess.run(
        [sys.executable, "-m", "jetson.cli", "dashboard", "--recording", os.devnull],
        capture_output=True, text=True, timeout=60,
    )  # fmt: skip
    assert bad.returncode == 2 and "error" in bad.stderr


def test_the_timeline_shows_the_goals_the_camera_saw(recording: Path, tmp_path: Path) -> None:
    """A daemon with the goal detector records each result's goals (jetson/recorder.py): the
    timeline hands them to the decision and shows the last fresh result's goals in the field
    frame, as it shows its rings."""
    from jetson.autonomy.geometry import robot_to_field
    from jetson.replay import Records

    goal = [0.1, 0.9, 2.0]  # a blue goal 0.9 m ahead, a little right
    path = tmp_path / "with-goals.jsonl"
    with path.open("w") as f:
        for rec in Records(recording):
            if rec.get("kind") == "perception" and rec["id"] % 2 == 0:
                rec["goals"] = [goal]
            f.write(json.dumps(rec) + "\n")
    plain, tl = Timeline(recording, memories=False), Timeline(path, memories=False)
    assert not any(s["field"]["goals_seen"] for s in plain.snapshots)
    assert not any(c["goals"] for c in plain.cycles)
    shown = [s for s in tl.snapshots if s["field"]["goals_seen"]]
    assert shown and len(shown) < len(tl.snapshots)  # the odd results have none
    for snap in shown:
        assert snap["perception"]["goals"] == 1 and snap["perception"]["id"] % 2 == 0
        assert snap["command"]["perception"] == "fresh"
        pose = snap["pose"]
        want = robot_to_field(np.array([goal[:2]]), (pose["x"], pose["y"]), pose["heading"])[0]
        ((x, y, code),) = snap["field"]["goals_seen"]
        assert code == 2 and np.hypot(x - want[0], y - want[1]) < 0.01
    assert any(c["goals"] == 1 for c in tl.cycles)


def test_the_timeline_shows_the_robots_the_camera_saw(recording: Path, tmp_path: Path) -> None:
    """A daemon with the robot detector records each result's robots (jetson/recorder.py): the
    timeline hands them to the decision and shows the last fresh result's robots in the field
    frame, with their alliance, as it shows its goals."""
    from jetson.autonomy.geometry import robot_to_field
    from jetson.replay import Records

    robot = [-0.2, 1.4, 1.0]  # a red robot 1.4 m ahead, a little left
    path = tmp_path / "with-robots.jsonl"
    with path.open("w") as f:
        for rec in Records(recording):
            if rec.get("kind") == "perception" and rec["id"] % 2 == 0:
                rec["robots"] = [robot]
            f.write(json.dumps(rec) + "\n")
    plain, tl = Timeline(recording, memories=False), Timeline(path, memories=False)
    assert not any(s["field"]["robots_seen"] for s in plain.snapshots)
    shown = [s for s in tl.snapshots if s["field"]["robots_seen"]]
    assert shown and len(shown) < len(tl.snapshots)  # the odd results have none
    for snap in shown:
        assert snap["perception"]["robots"] == 1 and snap["perception"]["id"] % 2 == 0
        assert snap["command"]["perception"] == "fresh"
        pose = snap["pose"]
        want = robot_to_field(np.array([robot[:2]]), (pose["x"], pose["y"]), pose["heading"])[0]
        ((x, y, code),) = snap["field"]["robots_seen"]
        assert code == 1 and np.hypot(x - want[0], y - want[1]) < 0.01
