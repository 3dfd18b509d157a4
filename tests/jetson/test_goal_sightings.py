"""The camera's goal sightings on the daemon's side (`[camera] goals`): the setting and its
default, the camera feeds carrying a frame's goals, the decision handing them to the scripted
alliance by the rings' age rule, and `pete-jetson run --player alliance` seeing a goal base in its
camera stream, recording it and replaying the scripted decisions it made with it."""

from __future__ import annotations

import io
import json
import threading
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np
import pytest

from jetson.autonomy.alliance import GOAL_COLOUR_CODES, AllianceInputs, AllianceStrategy
from jetson.autonomy.camera import Intrinsics
from jetson.camera_feed import Perceived, SyncPerception
from jetson.clock import ManualClock, MonotonicClock
from jetson.decide import PerceptionInput, perceived_goals
from jetson.errors import SettingsError
from jetson.log import EventLog
from jetson.perception.pipeline import make_pipeline
from jetson.replay import replay
from jetson.scripted import ROBOTS, ScriptedDecider
from jetson.service import build, make_camera
from jetson.settings import CameraSettings, DecisionConfig, Settings
from jetson.testing import FakeBrain
from protocol.messages import State
from tests.jetson.perception.test_goal_pipeline import PLACED_M, assert_goal_at, goal_frame
from tests.jetson.test_daemon_camera import Streamer, wait_for
from tests.jetson.test_scripted import state

pytestmark = pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning")
YELLOW = GOAL_COLOUR_CODES["yellow"]
GOALS = np.array([[0.3, 1.2, YELLOW], [-0.6, 2.0, GOAL_COLOUR_CODES["blue"]]])


def test_goals_are_found_for_the_scripted_alliance_unless_set_otherwise() -> None:
    alliance = {"player": "alliance"}
    assert not Settings().detects_goals()  # a policy reads no goals
    assert Settings().with_overrides(decision=alliance).detects_goals()
    assert not Settings().with_overrides(decision=alliance, camera={"goals": False}).detects_goals()
    assert Settings().with_overrides(camera={"goals": True}).detects_goals()
    with pytest.raises(SettingsError, match=r"\[camera\] goals"):
        Settings.from_dict({"camera": {"goals": "yes"}})


def test_the_camera_is_built_with_the_goal_detector_when_goals_are_found() -> None:
    assert make_pipeline(CameraSettings(detector="classical"))[1].goal_detector is None
    assert make_pipeline(CameraSettings(detector="classical", goals=True))[1].goal_detector
    log = EventLog(io.StringIO())
    alliance = Settings().with_overrides(
        camera={"detector": "classical"}, decision={"player": "alliance"}
    )
    # Its own process gets the settled setting (it sees [camera] only) ...
    assert make_camera(alliance, MonotonicClock(), log, own_process=True).settings.goals is True
    # ... and the thread (the lockstep full stack) runs the goal detector on each frame.
    worker = make_camera(alliance, ManualClock(), log)
    frame = goal_frame([("yellow", 0.2, 1.4)])
    assert_goal_at(worker._process(frame).goals_robot, "yellow", 0.2, 1.4)
    policy = make_camera(
        Settings().with_overrides(camera={"detector": "classical"}), ManualClock(), log
    )
    assert policy._process(frame).goals_robot.shape == (0, 3)


def test_a_feed_carries_a_frames_goals_and_none_on_an_error() -> None:
    def process(frame: Any) -> Any:
        if frame.bad:
            raise ValueError("bad depth")
        return SimpleNamespace(rings_robot_xy=[[0.0, 1.0]], detections=[1], goals_robot=GOALS)

    feed = SyncPerception(process, ManualClock(5.0))
    good = feed.submit(SimpleNamespace(bad=False, index=1))
    assert np.array_equal(good.goals_robot, GOALS)
    bad = feed.submit(SimpleNamespace(bad=True, index=2))
    assert bad.error is not None and bad.goals_robot.shape == (0, 3)
    # A pipeline without a goal detector (a result without goals_robot) reports none.
    ringsonly = SyncPerception(lambda f: SimpleNamespace(rings_robot_xy=[]), ManualClock())
    assert ringsonly.submit(SimpleNamespace(index=3)).goals_robot.shape == (0, 3)


def test_the_goals_age_as_the_rings_do() -> None:
    config = DecisionConfig(perception_max_age_s=0.3)
    seen = Perceived(7, 1.0, np.zeros((0, 2)), goals_robot=GOALS)
    fresh = PerceptionInput.of(seen, 0.1)
    assert fresh.id == 7 and np.array_equal(perceived_goals(fresh, config), GOALS)
    assert perceived_goals(PerceptionInput.of(seen, 0.5), config).shape == (0, 3)  # old: none
    assert perceived_goals(None, config).shape == (0, 3)


def test_the_scripted_decider_hands_the_strategy_the_fresh_goals() -> None:
    decider = ScriptedDecider(DecisionConfig())
    got: list[AllianceInputs] = []
    step = decider.strategy.step

    def spy(inputs: AllianceInputs) -> Any:
        got.append(inputs)
        return step(inputs)

    decider.strategy.step = spy  # type: ignore[method-assign]
    rings = np.zeros((0, 2))
    decider.decide(state(1.0, 1), PerceptionInput(1, 0.05, rings, None, GOALS))
    decider.decide(state(1.1, 2), PerceptionInput(1, 0.5, rings, None, GOALS))  # stale
    decider.decide(state(1.2, 3), None)
    assert np.array_equal(got[0].goals_robot, GOALS)
    assert got[1].goals_robot.shape == (0, 3) and got[2].goals_robot.shape == (0, 3)


def test_a_strategy_told_of_no_goals_looks_before_backing_onto_a_goal() -> None:
    """A daemon whose camera finds no goals hands the strategy an empty report every step. In
    the isolation period that plays as the strategy without a goal detector
    (AllianceInputs.goals_robot None); in the interaction period a robot with a detector does
    not back onto a goal it has not just seen where it believes it (what stands there may be
    another robot's goal): it looks first, where the one without a detector backs on."""
    decider = ScriptedDecider(DecisionConfig())
    a = AllianceStrategy(ROBOTS["24in"], decider.layout)
    b = AllianceStrategy(ROBOTS["24in"], decider.layout)
    isolation_s = decider.layout.isolation_s
    rng = np.random.default_rng(3)
    poses = {"a": (-1.2, -0.9, 90.0), "b": (-1.2, -0.9, 90.0)}
    intents: dict[str, set[str]] = {"a": set(), "b": set()}
    for k in range(600):  # 50 s at 12 Hz, each driving where its strategy says
        t = k / 12.0
        rings = rng.uniform(-0.5, 0.5, (k % 3, 2)) + np.array([0.0, 1.0])
        actions = {}
        for name, strategy, goals in (("a", a, None), ("b", b, np.zeros((0, 3)))):
            x, y, heading = poses[name]
            actions[name] = strategy.step(
                AllianceInputs(
                    x=x, y=y, heading_deg=heading, alliance="red", time_s=t,
                    rings_robot_xy=rings, rings_held=2, goal_clamped=30 < k < 300,
                    goals_robot=goals,
                )
            )  # fmt: skip
            if t > isolation_s:
                intents[name].add(strategy.intent.split(":")[0])
            heading = (heading + np.degrees(actions[name].angular) / 12.0) % 360.0
            x += actions[name].linear / 12.0 * np.sin(np.radians(heading))
            y += actions[name].linear / 12.0 * np.cos(np.radians(heading))
            poses[name] = (float(np.clip(x, -1.6, 1.6)), float(np.clip(y, -1.6, 1.6)), heading)
        if t <= isolation_s:
            assert actions["b"] == actions["a"], k
    assert "look" in intents["b"] and "look" not in intents["a"]
    assert "back_onto" in intents["a"]


def test_pete_jetson_run_as_the_alliance_sees_a_goal_base_records_and_replays_it(
    tmp_path: Path,
) -> None:
    """A yellow goal base 1.2 m ahead and 0.3 m right in the camera stream reaches the strategy
    through the daemon's camera process, at its base's middle; the session replays, and
    replaying it without its goals does not."""
    truth = (0.3, 1.2)
    frame = goal_frame([("yellow", *truth)], intr=Intrinsics().scaled(320, 240))
    address = f"unix:{tmp_path / 'frames.sock'}"

    def make_state(seq: int, t: float) -> dict[str, Any]:
        s = state(20.0 + t, seq)  # the interaction period: the 24" goes for a neutral goal
        return {
            f.name: getattr(s, f.name) for f in State.FIELDS if f.name not in ("seq", "time_ms")
        }

    brain = FakeBrain(link_path=tmp_path / "pete-brain", make_state=make_state)
    streamer = Streamer(address, frame)
    settings = Settings().with_overrides(
        link={"port": str(tmp_path / "pete-brain")},
        camera={"source": address, "detector": "classical", "retry_s": 0.1},
        record={"dir": str(tmp_path / "sessions"), "compress": False},
        log={"summary": False},
        decision={"player": "alliance"},
    )
    service = build(settings, MonotonicClock(), io.StringIO())
    got: list[np.ndarray] = []
    strategy = service.daemon.decider.strategy
    step = strategy.step

    def spy(inputs: AllianceInputs) -> Any:
        got.append(np.asarray(inputs.goals_robot))
        return step(inputs)

    strategy.step = spy
    brain.start()
    runner = threading.Thread(target=service.run, daemon=True)
    runner.start()
    try:
        assert wait_for(lambda: sum(len(g) > 0 for g in got) >= 24, 30.0), got[-3:]
    finally:
        service.stop()
        runner.join(5.0)
        streamer.close()
        brain.close()
    seen = [g for g in got if len(g)]
    for report in seen:
        assert_goal_at(report, "yellow", *truth)
    assert PLACED_M <= 0.05  # "the right place": at the base's middle
    (path,) = sorted((tmp_path / "sessions").glob("session-*.jsonl"))
    report = replay(path)
    assert report.ok and report.cycles > 0, report.text(5)
    records = [json.loads(line) for line in path.read_text().splitlines()]
    assert any("goals" in r for r in records if r["kind"] == "perception")
    blind = tmp_path / "session-blind.jsonl"
    blind.write_text(
        "".join(json.dumps({k: v for k, v in r.items() if k != "goals"}) + "\n" for r in records)
    )
    assert replay(blind).differing_cycles > 0  # the goals changed what the strategy did
