"""What the dashboard shows of the alliance (jetson.dashboard.snapshot): the partner (the VEXlink
link as the Brain reports it and the partner's newest report), the target our robot claims, and
the goals the camera sees, in the page's units; and, live, the scripted alliance's claim and goals
reaching the page."""

from __future__ import annotations

import json
from pathlib import Path
from typing import Any

import numpy as np

from protocol.messages import Partner, PartnerFlags, PartnerLink, PartnerStatus, TargetKind


def report(**kw: object) -> Partner:
    base = dict(
        x_mm=-900, y_mm=350, heading_cdeg=27050, flags=PartnerFlags.POSE_OK | PartnerFlags.DRIVING,
        goal=255, rings=4, target=TargetKind.GOAL, target_id=3, target_x_mm=600,
        target_y_mm=-1200, match_ms=4000,
    )  # fmt: skip
    base.update(kw)
    return Partner(**base)  # type: ignore[arg-type]


def test_no_word_from_the_brain_is_no_partner() -> None:
    from jetson.dashboard.snapshot import partner_view

    assert partner_view(None, None, 1000) is None


def test_the_link_and_the_report_in_metres_and_degrees() -> None:
    from jetson.dashboard.snapshot import partner_view

    v = partner_view(report(), PartnerStatus(PartnerLink.UP, 40, 12, 13, 0, 1, 2), 4180)
    assert v is not None
    assert (v["link"], v["age_ms"], v["received"], v["sent"], v["lost"], v["errors"]) == (
        "up", 40, 12, 13, 1, 2,
    )  # fmt: skip
    r = v["report"]
    assert r["pose"] == [-0.9, 0.35, 270.5]
    assert r["rings"] == 4 and r["driving"] and not r["holding"] and not r["alone"]
    assert r["target"] == "goal" and r["target_xy"] == [0.6, -1.2]
    assert r["delay_ms"] == 180  # by the two match clocks


def test_a_report_without_a_pose_or_target_shows_neither() -> None:
    from jetson.dashboard.snapshot import partner_view

    flags = PartnerFlags.HOLDING_GOAL | PartnerFlags.ALONE
    v = partner_view(report(flags=flags, target=TargetKind.NOTHING, rings=255), None, None)
    assert v is not None and v["link"] is None
    r = v["report"]
    assert r["pose"] is None and r["target_xy"] is None and r["rings"] is None
    assert r["holding"] and r["alone"] and r["delay_ms"] is None


def test_a_lost_link_with_no_report_for_ever_says_so() -> None:
    from jetson.dashboard.snapshot import partner_view

    v = partner_view(None, PartnerStatus(PartnerLink.LOST, 0xFFFF, 9, 9, 0, 0, 0), 5000)
    assert v is not None
    assert v["link"] == "lost" and v["age_ms"] is None and v["report"] is None


def test_our_claim_in_the_field_frame_and_nothing_claimed_is_none() -> None:
    from jetson.dashboard.snapshot import claim_view
    from jetson.partner import NOTHING, Claim

    assert claim_view(None) is None and claim_view(NOTHING) is None
    assert claim_view(Claim(TargetKind.PLATFORM, (-1.2345, 0.5))) == {
        "target": "platform", "xy": [-1.234, 0.5],
    }  # fmt: skip


def test_goals_seen_go_to_the_field_frame_with_their_colour() -> None:
    from jetson.dashboard.snapshot import goals_field
    from jetson.testing import default_state
    from protocol.messages import State

    s = State(**default_state(1, 0.0), seq=1, time_ms=0, last_command_seq=0, faults=0)
    assert goals_field(np.zeros((0, 3)), s) == []
    # One goal 1 m straight ahead of the robot, yellow (code 0).
    got = goals_field(np.array([[0.0, 1.0, 0.0]]), s)
    assert len(got) == 1 and got[0][2] == 0
    h = np.radians(s.heading)
    assert got[0][:2] == [round(s.x + np.sin(h), 3), round(s.y + np.cos(h), 3)]


def test_the_scripted_alliances_claim_reaches_the_page(tmp_path: Path) -> None:
    """A daemon playing the scripted alliance (the 15", which goes for its alliance goal first)
    shows its claim on the field."""
    from tests.jetson.dashboard.stack import live_stack, wait_for
    from tests.jetson.dashboard.test_live import get

    scripted = {"player": "alliance", "role": "15in"}
    with live_stack(tmp_path, camera=False, decision=scripted) as live:
        assert wait_for(lambda: live.dashboard_ready, 60.0), live.out.getvalue()

        def claim() -> Any:
            snap = json.loads(get(live.url + "api/snapshot")[1])
            return snap["field"].get("claim")

        got = wait_for(claim)
        assert got and got["target"] in ("goal", "ring", "platform", "zone")
        assert all(abs(v) < 1.83 for v in got["xy"])  # on the field


def test_robots_seen_go_to_the_field_frame_with_their_alliance() -> None:
    from jetson.dashboard.snapshot import robots_field
    from jetson.testing import default_state
    from protocol.messages import State

    s = State(**default_state(1, 0.0), seq=1, time_ms=0, last_command_seq=0, faults=0)
    assert robots_field(np.zeros((0, 3)), s) == []
    # A blue robot (code 2) 1.5 m straight ahead of the robot.
    got = robots_field(np.array([[0.0, 1.5, 2.0]]), s)
    h = np.radians(s.heading)
    assert got == [[round(s.x + 1.5 * np.sin(h), 3), round(s.y + 1.5 * np.cos(h), 3), 2]]


def test_the_skill_shown_is_the_one_the_controller_drove() -> None:
    """A ring left to the partner (split_with_partner): the page shows the option the controller
    drove and where it drove, not the policy's best score."""
    from types import SimpleNamespace

    from jetson.autonomy.observation import PartnerView, RobotView, build_frame
    from jetson.autonomy.skills import SkillConfig, SkillDriver
    from jetson.autonomy.spec import ObservationSpec
    from jetson.dashboard.snapshot import DecisionView, field_view
    from protocol.messages import Alliance

    spec = ObservationSpec(version=6, n_stack=0, partner=True)
    skills = SkillConfig(ring_options=2, goal_options=0, split_with_partner=True)
    view = RobotView(
        x=1.0, y=0.0, heading_deg=0.0, alliance="red", time_s=30.0,
        rings_robot_xy=np.array([(0.0, 0.8), (1.5, 1.0)]),
        partner=PartnerView(xy=(-0.2, 1.1), clamped=False, rings=0, claim_xy=None),
    )  # fmt: skip
    obs = build_frame(spec, view)
    action = np.array([1.0, 0.5, -1.0])  # ring 0 scores best; it is the partner's
    driver = SkillDriver(skills, spec)
    driver.command(obs, action)
    assert driver.driven == 1
    decision = DecisionView(
        spec, skills, np.zeros((0, 2)), np.zeros((0, 2)), False, obs, action, None,
        driver.driven, driver.target,
    )  # fmt: skip
    state = SimpleNamespace(x=1.0, y=0.0, heading=0.0, alliance=Alliance.RED)
    out = field_view(decision, state)
    assert out["skill"] == "ring1"
    assert out["target"] == [2.5, 1.0]  # ring 1, 1.5 m right and 1 m ahead of the robot
