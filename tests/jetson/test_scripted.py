"""The scripted alliance as the daemon's decision-maker (jetson/scripted.py): a State becomes the
strategy's inputs as the twin builds them, the strategy is stepped at its own rate and kept
through the disable between VEX AI's periods, the gates stop it as they stop the policy, and
`pete-jetson run --player alliance` drives a Brain and records a session that replays."""

from __future__ import annotations

import io
import json
import threading
import time
from pathlib import Path
from typing import Any

import numpy as np
import pytest

from jetson.autonomy.alliance import AllianceInputs, AllianceStrategy
from jetson.clock import MonotonicClock
from jetson.decide import PerceptionInput
from jetson.errors import SettingsError
from jetson.replay import replay
from jetson.scripted import ROBOTS, ScriptedDecider
from jetson.service import build
from jetson.settings import DecisionConfig, Settings
from jetson.testing import FakeBrain
from protocol.messages import (
    Alliance,
    ClampAction,
    Fault,
    GpsStatus,
    LiftState,
    MatchPeriod,
    MatchPhase,
    PoseFix,
    State,
)

RED_START = (-1.2, -0.9, 90.0)  # somewhere on red's side


def state(t: float, seq: int, **kw: Any) -> State:
    """A State of a VEX AI match at match time t (isolation until 15 s, then interaction)."""
    iso = t < 15.0
    fields: dict[str, Any] = {
        "seq": seq, "time_ms": round(t * 1000) + 5000,
        "phase": MatchPhase.AUTONOMOUS if iso else MatchPhase.DRIVER,
        "phase_ms": round((t if iso else t - 15.0) * 1000),
        "alliance": Alliance.RED, "x": RED_START[0], "y": RED_START[1], "heading": RED_START[2],
        "gps_error": 0.01, "gps_status": GpsStatus.OK, "left_speed": 0.0, "right_speed": 0.0,
        "last_command_seq": 0, "rings_held": 2, "goal_clamped": 0, "faults": Fault(0),
        "pose_fix": PoseFix.GPS, "pose_std": 0.02, "heading_std": 0.5,
        "period": MatchPeriod.ISOLATION if iso else MatchPeriod.INTERACTION,
        "match_ms": round(t * 1000), "lift": LiftState.DOWN,
    }  # fmt: skip
    fields.update(kw)
    return State(**fields)


def test_the_standard_robots_have_the_settings_roles() -> None:
    assert set(ROBOTS) == {"24in", "15in"}
    assert ROBOTS["24in"].reaches_high_branch and not ROBOTS["15in"].reaches_high_branch
    assert ROBOTS["24in"].partner_mass_kg == ROBOTS["15in"].mass_kg


@pytest.mark.parametrize("role", ["24in", "15in"])
def test_a_state_becomes_the_inputs_the_twin_gives_the_strategy(role: str) -> None:
    decider = ScriptedDecider(DecisionConfig(role=role))
    reference = AllianceStrategy(ROBOTS[role], decider.layout)
    rings = np.array([[0.1, 0.5], [-0.3, 1.1]])
    period_s = 1.0 / decider.decision_hz
    drove = 0
    for k in range(60):  # 5 s of isolation at the strategy's own rate
        t = k * period_s
        s = state(t, k + 1, goal_clamped=1 if k > 30 else 0)
        d = decider.decide(s, PerceptionInput(k, 0.05, rings))
        want = reference.step(
            AllianceInputs(
                x=s.x, y=s.y, heading_deg=s.heading, alliance="red", time_s=s.match_ms / 1000.0,
                rings_robot_xy=rings, rings_held=2, goal_clamped=k > 30, lift_up=False,
            )
        )  # fmt: skip
        assert (d.linear, d.angular, d.intake) == pytest.approx(
            (want.linear, want.angular, want.intake)
        )
        hold = want.clamp
        assert d.clamp == (
            ClampAction.LEAVE if hold is None else ClampAction.HOLD if hold else ClampAction.RELEASE
        )
        assert d.reason == "scripted" and d.drove and d.perception == "fresh" and d.rings == 2
        drove += 1
    assert drove == 60


def test_the_strategy_steps_at_its_rate_and_holds_its_action_between() -> None:
    decider = ScriptedDecider(DecisionConfig())
    calls: list[float] = []
    step = decider.strategy.step

    def counting(inputs: AllianceInputs) -> Any:
        calls.append(inputs.time_s)
        return step(inputs)

    decider.strategy.step = counting  # type: ignore[method-assign]
    answers = [decider.decide(state(k * 0.02, k + 1), None) for k in range(150)]  # 3 s at 50 Hz
    assert 35 <= len(calls) <= 37  # 12 a second
    assert all(a.drove for a in answers)
    assert answers[1].linear == answers[0].linear  # the same action until the next step


def test_the_disable_between_the_periods_keeps_the_match() -> None:
    decider = ScriptedDecider(DecisionConfig(role="15in"))
    for k in range(100):
        decider.decide(state(k / 12.0, k + 1), None)
    phase_before = decider.strategy.phase
    paused = state(15.0, 200, phase=MatchPhase.DISABLED, phase_ms=0, period=MatchPeriod.PAUSE)
    assert decider.decide(paused, None).reason == "phase disabled"
    assert decider.strategy.phase == phase_before  # nothing forgotten
    d = decider.decide(state(15.1, 201), None)
    assert d.drove
    # A new match (autonomous again) starts the strategy afresh.
    decider.decide(state(0.0, 300), None)
    assert decider.strategy.phase == "iso_goal"


def test_the_gates_stop_it_as_they_stop_the_policy() -> None:
    decider = ScriptedDecider(DecisionConfig())
    assert decider.decide(state(1.0, 1, alliance=Alliance.UNKNOWN), None).reason.startswith(
        "alliance unknown"
    )
    lost = decider.decide(state(1.1, 2, pose_fix=PoseFix.LOST, gps_status=GpsStatus.ERROR), None)
    assert not lost.drove and lost.reason == "gps error"
    # A worn pose is driven on, slower (jetson.decide.pose_speed_scale), not stopped on.
    sure = decider.decide(state(1.2, 3, pose_fix=PoseFix.ODOMETRY, pose_std=0.05), None)
    unsure = decider.decide(state(1.2, 3, pose_fix=PoseFix.ODOMETRY, pose_std=0.3), None)
    assert sure.drove and unsure.drove
    assert unsure.linear == pytest.approx(0.5 * sure.linear)
    assert unsure.angular == pytest.approx(0.5 * sure.angular)
    d = decider.decide(state(1.3, 4), PerceptionInput(9, 0.05, np.zeros((0, 2)), "boom"))
    assert not d.drove and d.reason == "perception error"


def test_a_bad_player_setting_names_the_choices() -> None:
    with pytest.raises(SettingsError, match="player must be one of policy, alliance"):
        DecisionConfig(player="planner")


def test_pete_jetson_run_with_the_scripted_alliance_drives_and_replays(tmp_path: Path) -> None:
    def make_state(seq: int, t: float) -> dict[str, Any]:
        s = state(t, seq)
        return {
            f.name: getattr(s, f.name) for f in State.FIELDS if f.name not in ("seq", "time_ms")
        }

    brain = FakeBrain(make_state=make_state)
    settings = Settings().with_overrides(
        link={"port": brain.path},
        camera={"enabled": False},
        record={"dir": str(tmp_path / "sessions"), "compress": False},
        log={"summary": False},
        decision={"player": "alliance", "role": "15in"},
    )
    out = io.StringIO()
    service = build(settings, MonotonicClock(), log_stream=out)
    brain.start()
    thread = threading.Thread(target=service.run, daemon=True)
    thread.start()
    try:
        deadline = time.monotonic() + 20
        while len(brain.commands) < 60 and time.monotonic() < deadline:
            time.sleep(0.02)
        assert len(brain.commands) >= 60, out.getvalue()[-2000:]
    finally:
        service.stop()
        thread.join(5.0)
        brain.close()
    records = [json.loads(x) for x in out.getvalue().splitlines() if x.startswith("{")]
    config = next(r for r in records if r["event"] == "config")
    assert "scripted alliance (15in)" in config["msg"]
    assert service.daemon.counters.commands >= 60
    assert any(c.command.linear != 0.0 or c.command.angular != 0.0 for c in brain.commands)
    (path,) = sorted((tmp_path / "sessions").glob("session-*.jsonl"))
    report = replay(path)
    assert report.ok, report.text(5)
    assert report.cycles >= 60 and "scripted alliance" in report.policy


def test_the_steal_setting_reaches_the_strategy() -> None:
    """`[decision] steal_s` is the strategy's AllianceConfig.steal_s (the same on both robots of
    an alliance): by default the steal from the interaction period's start, then the climb;
    0 turns the steal off (the 24" scores rings and both robots climb)."""
    from jetson.scripted import ScriptedDecider
    from jetson.settings import DecisionConfig

    d = ScriptedDecider(DecisionConfig(player="alliance"))
    assert d.strategy.config.steal_s == 104.0 and d.strategy.config.steal_climb
    assert (
        ScriptedDecider(DecisionConfig(player="alliance", steal_s=0)).strategy.config.steal_s
        is None
    )
    d = ScriptedDecider(
        DecisionConfig(player="alliance", role="15in", steal_s=60, steal_climb=False)
    )
    assert d.strategy.config.steal_s == 60.0 and not d.strategy.config.steal_climb


def test_the_claim_for_the_partner_is_the_strategys_target_in_the_field_frame() -> None:
    """The 15" goes for the alliance goal beside its start in the isolation period: it claims that
    goal where the strategy believes it is, turned into the field frame (blue's alliance frame is
    the field's turned half round); before it decides, and with the alliance unknown, nothing."""
    from jetson.autonomy.geometry import to_alliance_frame
    from protocol.messages import TargetKind

    for alliance, name, sign in ((Alliance.RED, "red", 1.0), (Alliance.BLUE, "blue", -1.0)):
        decider = ScriptedDecider(DecisionConfig(role="15in"))
        start = state(0.0, 1, alliance=alliance, x=sign * RED_START[0], y=sign * RED_START[1])
        assert decider.claim(start).target is TargetKind.NOTHING
        decider.decide(start, None)
        claim = decider.claim(start)
        kind, xy = decider.strategy.claim()
        assert kind == "goal" and claim.target is TargetKind.GOAL
        assert decider.strategy.target_goal is not None
        want = to_alliance_frame(xy, None, name)[0]
        assert claim.xy == pytest.approx(tuple(want))
        # The goal it claims lies on its own side of the field, as the alliance goal does.
        assert sign * claim.xy[0] < 0
        unknown = state(0.1, 2, alliance=Alliance.UNKNOWN)
        assert decider.claim(unknown).target is TargetKind.NOTHING
        # Disabled (the pause between the periods, the match's end): it goes for nothing.
        paused = state(15.0, 3, alliance=alliance, phase=MatchPhase.DISABLED, phase_ms=0)
        assert decider.decide(paused, None).reason == "phase disabled"
        assert decider.claim(paused).target is TargetKind.NOTHING
