"""What this robot tells its alliance partner over VEXlink (protocol Partner), and how often.

The Jetson sends its report to its Brain, which keeps the newest and sends it over the radio at
most every 100 ms (brain/README.md, "The partner link"); sending more often only replaces reports
the radio never carries, so the daemon reports every REPORT_PERIOD_S. The target a robot claims
is its decider's (`claim(state)`): the scripted alliance's goal, ring or platform; a policy claims
nothing yet.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

from protocol.messages import Partner, PartnerFlags, PartnerLink, PoseFix, State, TargetKind

REPORT_PERIOD_S = 0.1
NO_INDEX = 255  # Partner.goal / target_id: none
_I16 = 32767


@dataclass(frozen=True)
class Claim:
    """What a robot is going for, so its partner can leave it alone: the kind, where it is
    (field frame, metres) and its index (a goal's in the field file's order; NO_INDEX none: the
    scripted alliance names its goals in the alliance frame and claims no index yet)."""

    target: TargetKind = TargetKind.NOTHING
    xy: tuple[float, float] = (0.0, 0.0)
    index: int = NO_INDEX


NOTHING = Claim()


def _mm(metres: float) -> int:
    """Metres as whole millimetres, held to an i16 (a field is 3.66 m across)."""
    if not math.isfinite(metres):
        return 0
    return max(-_I16, min(_I16, round(1000.0 * metres)))


def partner_report(
    state: State, driving: bool, link: PartnerLink | None, claim: Claim = NOTHING
) -> Partner:
    """This robot's report from the Brain's State: its pose (when it has one), whether it holds
    a goal, its rings, whether its Jetson drives it, whether it plays alone (its partner link is
    not up), and the target it claims."""
    flags = PartnerFlags(0)
    posed = state.pose_fix != PoseFix.LOST
    if posed:
        flags |= PartnerFlags.POSE_OK
    if state.goal_clamped == 1:
        flags |= PartnerFlags.HOLDING_GOAL
    if driving:
        flags |= PartnerFlags.DRIVING
    if link is not PartnerLink.UP:
        flags |= PartnerFlags.ALONE
    heading = state.heading % 360.0 if posed and math.isfinite(state.heading) else 0.0
    return Partner(
        x_mm=_mm(state.x) if posed else 0,
        y_mm=_mm(state.y) if posed else 0,
        heading_cdeg=min(35999, round(heading * 100.0)),
        flags=flags,
        goal=NO_INDEX,
        rings=state.rings_held,
        target=claim.target,
        target_id=claim.index,
        target_x_mm=_mm(claim.xy[0]),
        target_y_mm=_mm(claim.xy[1]),
        match_ms=state.match_ms,
    )
