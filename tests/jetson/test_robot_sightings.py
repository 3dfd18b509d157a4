"""The camera's robot sightings on the daemon's side (`[camera] robots`): the setting, its default
(the policy's need), the camera feeds carrying a frame's robots to the decision, the recording
keeping them, and `pete-jetson run` with the robot detector seeing a licence plate in its camera
stream (through the camera's own process), recording it and replaying it."""

from __future__ import annotations

import io
import json
import threading
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

import jetson.service
from jetson.autonomy.camera import Intrinsics
from jetson.camera_feed import CameraWorker, Perceived, SyncPerception
from jetson.clock import ManualClock, MonotonicClock
from jetson.decide import PerceptionInput
from jetson.errors import ReplayError, SettingsError
from jetson.log import EventLog
from jetson.perception.robots import ROBOT_ALLIANCE_CODES
from jetson.recorder import Recorder
from jetson.replay import recorded_perception, replay
from jetson.scripted import ScriptedDecider
from jetson.service import build, make_camera, policy_reads_robots
from jetson.settings import DecisionConfig, Settings
from jetson.testing import FakeBrain, ProbePolicy
from tests.jetson.perception.test_robot_pipeline import assert_robot_at, behind, plate_frame
from tests.jetson.test_daemon_camera import Streamer, wait_for

pytestmark = pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning")
RED, BLUE = ROBOT_ALLIANCE_CODES["red"], ROBOT_ALLIANCE_CODES["blue"]
ROBOTS = np.array([[0.2, 1.3, BLUE], [-0.5, 1.8, RED]])
CLASSICAL = {"detector": "classical"}


def test_robots_are_found_when_set_or_when_the_policy_reads_them() -> None:
    assert not Settings().detects_robots()  # the settings alone: off
    assert Settings().detects_robots(policy_reads_robots=True)
    assert Settings().with_overrides(camera={"robots": True}).detects_robots()
    off = Settings().with_overrides(camera={"robots": False})
    assert not off.detects_robots(policy_reads_robots=True)  # set false: off for any policy


@pytest.mark.parametrize("value", ["yes", 1, 0.0, ["true"]])
def test_a_robots_setting_that_is_not_a_boolean_is_refused_by_name(value: Any) -> None:
    with pytest.raises(SettingsError, match=r"\[camera\] robots: expected boolean"):
        Settings.from_dict({"camera": {"robots": value}})
    with pytest.raises(SettingsError, match=r"\[camera\] robots"):
        Settings().with_overrides(camera={"robots": value})


def test_the_policy_reads_robots_when_its_spec_has_seen_opponents() -> None:
    seeing = SimpleNamespace(spec=SimpleNamespace(seen_opponents=True))
    assert policy_reads_robots(seeing)
    assert not policy_reads_robots(SimpleNamespace(spec=SimpleNamespace(seen_opponents=False)))
    assert not policy_reads_robots(SimpleNamespace(spec=SimpleNamespace()))  # a spec without it
    assert not policy_reads_robots(SimpleNamespace())  # no spec at all
    assert not policy_reads_robots(ScriptedDecider(DecisionConfig()))


def test_the_camera_is_built_with_the_robot_detector_when_robots_are_found() -> None:
    log = EventLog(io.StringIO())
    plain = Settings().with_overrides(camera=CLASSICAL)
    # Its own process gets the settled setting (it sees [camera] only) ...
    assert make_camera(plain, MonotonicClock(), log, own_process=True).settings.robots is False
    seeing = make_camera(plain, MonotonicClock(), log, own_process=True, robots=True)
    assert seeing.settings.robots is True
    off = Settings().with_overrides(camera={**CLASSICAL, "robots": False})
    assert (
        make_camera(off, MonotonicClock(), log, own_process=True, robots=True).settings.robots
        is False
    )
    # ... and the thread (the lockstep full stack) runs the robot detector on each frame.
    frame = plate_frame([("red", 0.0, 1.0)])
    worker = make_camera(plain, ManualClock(), log, robots=True)
    assert_robot_at(worker._process(frame).robots_robot, "red", *behind(0.0, 1.0))
    assert make_camera(plain, ManualClock(), log)._process(frame).robots_robot.shape == (0, 3)


def test_build_hands_the_camera_the_policys_need(monkeypatch: pytest.MonkeyPatch) -> None:
    """`pete-jetson run` builds its camera (in its own process, not started here) with the robot
    detector when the loaded policy reads the robots it sees, unless [camera] robots says no."""
    settings = Settings().with_overrides(
        camera=CLASSICAL, record={"dir": ""}, log={"summary": False}
    )
    assert (
        build(
            settings, MonotonicClock(), io.StringIO(), policy=ProbePolicy()
        ).camera.settings.robots
        is False
    )
    asked: list[Any] = []

    def reads(decider: Any) -> bool:
        asked.append(decider)
        return True

    monkeypatch.setattr(jetson.service, "policy_reads_robots", reads)
    service = build(settings, MonotonicClock(), io.StringIO(), policy=ProbePolicy())
    assert service.camera.settings.robots is True and asked == [service.daemon.decider]
    off = settings.with_overrides(camera={"robots": False})
    assert (
        build(off, MonotonicClock(), io.StringIO(), policy=ProbePolicy()).camera.settings.robots
        is False
    )


def test_the_feeds_carry_a_frames_robots_and_none_on_an_error() -> None:
    def process(frame: Any) -> Any:
        if frame.bad:
            raise ValueError("bad depth")
        return SimpleNamespace(rings_robot_xy=[[0.0, 1.0]], detections=[1], robots_robot=ROBOTS)

    feed = SyncPerception(process, ManualClock(5.0))
    good = feed.submit(SimpleNamespace(bad=False, index=1))
    assert np.array_equal(good.robots_robot, ROBOTS) and good.goals_robot.shape == (0, 3)
    bad = feed.submit(SimpleNamespace(bad=True, index=2))
    assert bad.error is not None and bad.robots_robot.shape == (0, 3)
    # A pipeline without a robot detector (a result without robots_robot) reports none.
    ringsonly = SyncPerception(lambda f: SimpleNamespace(rings_robot_xy=[]), ManualClock())
    assert ringsonly.submit(SimpleNamespace(index=3)).robots_robot.shape == (0, 3)
    # The camera thread the same way.
    worker = CameraWorker(lambda: None, process, ManualClock(), EventLog(io.StringIO()))  # type: ignore[arg-type,return-value]
    worker._handle(SimpleNamespace(bad=False, index=4, timestamp_s=0.0))
    latest = worker.latest()
    assert latest is not None and np.array_equal(latest.robots_robot, ROBOTS)
    worker._handle(SimpleNamespace(bad=True, index=5, timestamp_s=0.0))
    latest = worker.latest()
    assert latest is not None and latest.error and latest.robots_robot.shape == (0, 3)


def test_the_decision_is_given_the_robots() -> None:
    seen = Perceived(7, 1.0, np.zeros((0, 2)), robots_robot=ROBOTS)
    pin = PerceptionInput.of(seen, 0.1)
    assert pin.id == 7 and np.array_equal(pin.robots_robot, ROBOTS)
    assert PerceptionInput.of(Perceived(8, 1.0, np.zeros((0, 2))), 0.1).robots_robot.shape == (0, 3)
    # A feed's result that knows nothing of robots (an older Perceived, a test double) has none.
    bare = SimpleNamespace(id=9, rings_robot_xy=np.zeros((0, 2)), error=None, goals_robot=ROBOTS)
    assert PerceptionInput.of(bare, 0.1).robots_robot.shape == (0, 3)
    assert PerceptionInput(1, 0.0, np.zeros((0, 2))).robots_robot.shape == (0, 3)


def test_a_recording_keeps_the_robots_seen_and_replay_reads_them_back(tmp_path: Path) -> None:
    path = tmp_path / "session.jsonl"
    recorder = Recorder(path, {})
    recorder.perception(Perceived(1, 1.0, np.array([[0.1, 0.9]]), robots_robot=ROBOTS))
    recorder.perception(Perceived(2, 1.1, np.zeros((0, 2))))
    recorder.close()
    first, second = (json.loads(x) for x in path.read_text().splitlines() if '"perception"' in x)
    assert first["robots"] == ROBOTS.tolist()
    assert "robots" not in second  # none seen: the key is left out, as before robots
    back = recorded_perception(first)
    assert np.array_equal(back.robots_robot, ROBOTS) and back.goals_robot.shape == (0, 3)
    assert recorded_perception(second).robots_robot.shape == (0, 3)


def test_pete_jetson_run_with_the_robot_detector_sees_a_plate_records_and_replays_it(
    tmp_path: Path,
) -> None:
    """A blue licence plate 1 m ahead in the camera stream reaches the decision through the
    daemon's camera process as a robot behind it; the recording keeps it, replays, and a
    recording whose robots are not (x, y, code) rows is a clear error."""
    frame = plate_frame([("blue", 0.0, 1.0)], intr=Intrinsics().scaled(320, 240))
    address = f"unix:{tmp_path / 'frames.sock'}"
    brain = FakeBrain(link_path=tmp_path / "pete-brain")
    streamer = Streamer(address, frame)
    settings = Settings().with_overrides(
        link={"port": str(tmp_path / "pete-brain")},
        camera={"source": address, "detector": "classical", "retry_s": 0.1, "robots": True},
        record={"dir": str(tmp_path / "sessions"), "compress": False},
        log={"summary": False},
    )
    policy = ProbePolicy()
    service = build(settings, MonotonicClock(), io.StringIO(), policy=policy)
    got: list[np.ndarray] = []
    decider = service.daemon.decider
    decide = decider.decide

    def spy(state: Any, perception: Any, *rest: Any) -> Any:
        if perception is not None:
            got.append(perception.robots_robot)
        return decide(state, perception, *rest)

    decider.decide = spy
    brain.start()
    runner = threading.Thread(target=service.run, daemon=True)
    runner.start()
    try:
        assert wait_for(lambda: sum(len(r) > 0 for r in got) >= 10, 30.0), got[-3:]
    finally:
        service.stop()
        runner.join(5.0)
        streamer.close()
        brain.close()
    for report in (r for r in got if len(r)):
        assert_robot_at(report, "blue", *behind(0.0, 1.0))
    (path,) = sorted((tmp_path / "sessions").glob("session-*.jsonl"))
    records = [json.loads(line) for line in path.read_text().splitlines()]
    kept = [r["robots"] for r in records if r["kind"] == "perception" and "robots" in r]
    assert kept and all(len(k) == 1 and k[0][2] == BLUE for k in kept)
    report = replay(path, policy)
    assert report.ok and report.cycles > 0, report.text(5)
    bad = tmp_path / "session-bad.jsonl"
    bad.write_text(
        "".join(
            json.dumps({**r, "robots": [[1.0, 2.0]]} if "robots" in r else r) + "\n"
            for r in records
        )
    )
    with pytest.raises(ReplayError, match="perception record is malformed"):
        replay(bad, policy)
