"""What this robot tells its alliance partner over VEXlink (protocol Partner), and how often.

The Jetson sends its report to its Brain, which keeps the newest and sends it over the radio at
most every 100 ms (brain/README.md, "The partner link"); sending more often only replaces reports
the radio never carries, so the daemon reports every REPORT_PERIOD_S. The target a robot claims
is its decider's (`claim(state)`): the scripted alliance's goal, ring or platform; a skill
policy's, the target of the skill it drives.

What the partner reports comes back the same way: the loop keeps the newest Partner its Brain
handed up and the link's state (PartnerStatus); `PartnerInput.of` turns them into what the
decision reads (none while the link is not up), and `PartnerInput.view` into the observation's
partner block (jetson.autonomy.observation.PartnerView: the robot frame).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jetson.autonomy.geometry import field_to_robot
from jetson.autonomy.observation import PartnerView
from protocol.messages import (
    Partner,
    PartnerFlags,
    PartnerLink,
    PartnerStatus,
    PoseFix,
    State,
    TargetKind,
)

REPORT_PERIOD_S = 0.1
NO_INDEX = 255  # Partner.goal / target_id: none
# A reported point farther than this from the field's middle (metres, either axis: the field is
# 3.66 m across) is no place on the field: the receiver reads it as none.
FIELD_REACH_M = 2.5
MAX_RINGS = 30  # more than a robot carries: a count beyond it (255: no counter) reads as none
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
    posed = state.pose_fix != PoseFix.LOST and math.isfinite(state.x) and math.isfinite(state.y)
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


@dataclass(frozen=True)
class PartnerInput:
    """The partner's newest report as the decision reads it, and how old it is (seconds)."""

    report: Partner
    age_s: float

    @classmethod
    def of(
        cls, report: Partner | None, status: PartnerStatus | None, match_ms: int
    ) -> PartnerInput | None:
        """The newest report while the link is up (None otherwise: the robot plays alone). Its
        age is the larger of our match clock less the report's (both follow field control) and
        what the Brain last said (status.age_ms, at most a status period old): clocks that stand
        still (no field control) or a report stamped after our clock still age."""
        if report is None or status is None or status.link is not PartnerLink.UP:
            return None
        ms = max(match_ms - report.match_ms, status.age_ms)
        return cls(report, ms / 1000.0)

    def view(self, x: float, y: float, heading_deg: float) -> PartnerView:
        """The report in the frame of a robot at (x, y, heading_deg), field frame: where the
        partner is (when its report has a pose) and what it claimed (when anything)."""
        r = self.report
        here = np.array([x, y])

        def local(x_mm: int, y_mm: int) -> tuple[float, float] | None:
            if max(abs(x_mm), abs(y_mm)) > 1000.0 * FIELD_REACH_M:
                return None  # off the field: a report's garbage, not a place
            p = field_to_robot(np.array([[x_mm / 1000.0, y_mm / 1000.0]]), here, heading_deg)
            return float(p[0, 0]), float(p[0, 1])

        posed = PartnerFlags.POSE_OK in r.flags
        claimed = r.target != TargetKind.NOTHING
        return PartnerView(
            xy=local(r.x_mm, r.y_mm) if posed else None,
            clamped=PartnerFlags.HOLDING_GOAL in r.flags,
            rings=r.rings if r.rings <= MAX_RINGS else 0,
            claim_xy=local(r.target_x_mm, r.target_y_mm) if claimed else None,
        )
