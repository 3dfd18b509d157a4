"""The scripted alliance's own state types (jetson/autonomy/alliance.py): where the robot is in
the alliance frame, one control step's command (the tug-of-war windows read them), and what it
believes of one goal. Plain data, numpy only."""

from __future__ import annotations

from dataclasses import dataclass
from typing import NamedTuple

from jetson.autonomy.alliance_config import Vec
from jetson.autonomy.field_layout import GoalLayout

__all__ = ["GoalBelief", "Move", "Pose", "Vec"]


class Move(NamedTuple):
    """One control step's command and where it left the robot (the tug-of-war windows)."""

    t: float
    x: float
    y: float
    heading: float
    v: float  # the commanded speed, m/s (forward positive)


@dataclass
class Pose:
    xy: Vec  # alliance frame
    heading: float
    t: float


@dataclass
class GoalBelief:
    goal: GoalLayout
    xy: Vec | None  # where it is believed to be (alliance frame); None: missing
    tries: float = 0.0  # seconds spent backing onto it
