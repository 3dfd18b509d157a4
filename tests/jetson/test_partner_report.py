"""jetson.partner: the report this robot sends its alliance partner, from the Brain's State."""

from __future__ import annotations

import math
from dataclasses import replace

from jetson.partner import NO_INDEX, Claim, partner_report
from jetson.testing import default_state
from protocol import framing
from protocol.messages import PartnerFlags, PartnerLink, PoseFix, State, TargetKind


def state(**kw: object) -> State:
    base = State(**default_state(1, 0.0), seq=1, time_ms=0, last_command_seq=0, faults=0)
    return replace(base, **kw)


def test_the_pose_goal_and_rings_come_from_the_state() -> None:
    s = state(x=-1.234, y=0.9, heading=271.5, pose_fix=PoseFix.GPS, goal_clamped=1,
              rings_held=6, match_ms=47250)  # fmt: skip
    r = partner_report(s, driving=True, link=PartnerLink.UP)
    assert (r.x_mm, r.y_mm, r.heading_cdeg) == (-1234, 900, 27150)
    assert r.flags == PartnerFlags.POSE_OK | PartnerFlags.HOLDING_GOAL | PartnerFlags.DRIVING
    assert r.rings == 6 and r.match_ms == 47250 and r.goal == NO_INDEX
    assert r.target is TargetKind.NOTHING
    # It is a valid message on the wire.
    decoded, _ = framing.decode_packet(framing.encode_packet(r, 0))
    assert decoded == r


def test_a_lost_pose_reports_no_position_and_a_link_not_up_says_alone() -> None:
    s = state(x=0.7, y=0.7, heading=90.0, pose_fix=PoseFix.LOST)
    for link in (None, PartnerLink.CONNECTING, PartnerLink.LOST, PartnerLink.ABSENT):
        r = partner_report(s, driving=False, link=link)
        assert (r.x_mm, r.y_mm, r.heading_cdeg) == (0, 0, 0)
        assert PartnerFlags.POSE_OK not in r.flags and PartnerFlags.ALONE in r.flags


def test_numbers_out_of_range_are_held_to_the_field() -> None:
    s = state(x=1e6, y=-2e6, heading=359.999, pose_fix=PoseFix.ODOMETRY)
    r = partner_report(s, True, PartnerLink.UP, Claim(TargetKind.GOAL, (40.0, -40.0), 3))
    assert r.x_mm == 32767 and r.y_mm == -32767 and r.heading_cdeg <= 35999
    assert (r.target_x_mm, r.target_y_mm, r.target_id) == (32767, -32767, 3)
    framing.encode_packet(r, 0)
    # A pose that is not a number is no pose: the report says so rather than send the middle.
    r = partner_report(state(x=1.0, y=-math.inf, pose_fix=PoseFix.ODOMETRY), True, PartnerLink.UP)
    assert PartnerFlags.POSE_OK not in r.flags and (r.x_mm, r.y_mm) == (0, 0)
    framing.encode_packet(r, 0)
