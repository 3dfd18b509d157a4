"""The field as the robot may know it before a match: where things start, as data.

A team's autonomous routine knows the field's layout (the manual publishes it): the rings' and the
mobile goals' starting spots, its platform and the see-saw's numbers, its home zone and AWP line,
the robots' start poses, the periods' lengths. `load_layout()` reads them from a JSON file
(`data/tipping_point.json`), in the ALLIANCE frame (red's view; blue sees the field rotated by
180 degrees, which the point-symmetric field makes the same), metres, kilograms and seconds. A
goal's `owner` is "own", "opponent" or None (neutral). The simulator's field file
(`sim/field/tipping_point.toml`) stays the twin's source; a test checks the two agree.

Nothing here is the match's state: where things are now is what the robot's sensors and memories
say (jetson/autonomy/ring_memory.py, goal_memory.py).
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass
from pathlib import Path
from typing import Any

DEFAULT_LAYOUT = Path(__file__).parent / "data" / "tipping_point.json"

Point = tuple[float, float]


@dataclass(frozen=True)
class GoalLayout:
    name: str
    kind: str  # "alliance", "neutral", "neutral_tall"
    owner: str | None  # "own", "opponent", None (neutral)
    xy: Point
    base_radius_m: float
    mass_kg: float
    high_branch_capacity: int


@dataclass(frozen=True)
class PlatformLayout:
    """The alliance's own see-saw: the board (centre, extent along x and y), its hinge's height,
    and the torque-balance numbers (sim/world/seesaw.py models the same board)."""

    center: Point
    size: Point
    height_m: float
    board_mass_kg: float
    hinge_flat_m: float
    balanced_tilt_deg: float
    climb_edge_m: float
    overhang_m: float

    @property
    def field_side(self) -> float:
        """+1 or -1: the direction along x from the board toward the field."""
        return 1.0 if self.center[0] < 0 else -1.0

    def along(self, x: float) -> float:
        """A point's distance from the hinge toward the field (a load's lever arm)."""
        return (x - self.center[0]) * self.field_side

    def x_at(self, along: float) -> float:
        """The x of a point `along` metres from the hinge toward the field."""
        return self.center[0] + along * self.field_side

    @property
    def wall_heading_deg(self) -> float:
        """The heading of a robot on the board facing the alliance wall."""
        return 270.0 if self.field_side > 0 else 90.0

    def contains(self, xy: Point, margin: float = 0.0) -> bool:
        """A point (the alliance frame) on this board, or within `margin` of it."""
        return (
            abs(xy[0] - self.center[0]) <= self.size[0] / 2 + margin
            and abs(xy[1] - self.center[1]) <= self.size[1] / 2 + margin
        )

    def other_contains(self, xy: Point, margin: float = 0.0) -> bool:
        """A point on the other alliance's board (this one's half-turn mirror about the field's
        centre), or within `margin` of it."""
        return self.contains((-xy[0], -xy[1]), margin)

    def either_contains(self, xy: Point, margin: float = 0.0, other: float | None = None) -> bool:
        """A point on either alliance's board, or within `margin` of this one and `other`
        (None: `margin`) of the other's."""
        return self.contains(xy, margin) or self.other_contains(
            xy, margin if other is None else other
        )


@dataclass(frozen=True)
class StartLayout:
    xy: Point
    heading_deg: float


@dataclass(frozen=True)
class FieldLayout:
    name: str
    half_m: float
    rings: tuple[Point, ...]
    goals: tuple[GoalLayout, ...]
    platform: PlatformLayout
    home_zone: tuple[float, float, float, float]  # x0, y0, x1, y1
    awp_line: tuple[float, float, float, float]
    awp_goal: str
    starts: dict[str, StartLayout]  # by robot role ("24in", "15in")
    isolation_s: float
    interaction_s: float
    endgame_s: float

    @property
    def match_length_s(self) -> float:
        return self.isolation_s + self.interaction_s

    def goal(self, name: str) -> GoalLayout:
        for g in self.goals:
            if g.name == name:
                return g
        raise KeyError(f"no goal {name!r} in layout {self.name!r}")

    def in_home_zone(self, xy: Point, margin: float = 0.0) -> bool:
        x0, y0, x1, y1 = self.home_zone
        return x0 - margin <= xy[0] <= x1 + margin and y0 - margin <= xy[1] <= y1 + margin


def _point(value: Any, what: str) -> Point:
    if not (isinstance(value, list | tuple) and len(value) == 2):
        raise ValueError(f"field layout: {what} must be [x, y], got {value!r}")
    x, y = float(value[0]), float(value[1])
    if not (math.isfinite(x) and math.isfinite(y)):
        raise ValueError(f"field layout: {what} must be finite, got {value!r}")
    return (x, y)


def _box(value: Any, what: str) -> tuple[float, float, float, float]:
    if not (isinstance(value, list | tuple) and len(value) == 4):
        raise ValueError(f"field layout: {what} must be [x0, y0, x1, y1], got {value!r}")
    a, b, c, d = (float(v) for v in value)
    return (a, b, c, d)


def parse_layout(data: dict[str, Any]) -> FieldLayout:
    """A FieldLayout from the JSON file's dict; a missing or malformed key names itself."""
    try:
        p = data["platform"]
        platform = PlatformLayout(
            center=_point(p["center"], "platform.center"),
            size=_point(p["size"], "platform.size"),
            height_m=float(p["height_m"]),
            board_mass_kg=float(p["board_mass_kg"]),
            hinge_flat_m=float(p["hinge_flat_m"]),
            balanced_tilt_deg=float(p["balanced_tilt_deg"]),
            climb_edge_m=float(p["climb_edge_m"]),
            overhang_m=float(p["overhang_m"]),
        )
        goals = tuple(
            GoalLayout(
                name=str(g["name"]),
                kind=str(g["kind"]),
                owner=None if g["owner"] is None else str(g["owner"]),
                xy=_point(g["xy"], f"goals.{g['name']}.xy"),
                base_radius_m=float(g["base_radius_m"]),
                mass_kg=float(g["mass_kg"]),
                high_branch_capacity=int(g["high_branch_capacity"]),
            )
            for g in data["goals"]
        )
        for g in goals:
            if g.owner not in ("own", "opponent", None):
                raise ValueError(f"field layout: goal {g.name}'s owner is {g.owner!r}")
        starts = {
            str(k): StartLayout(_point(v["xy"], f"starts.{k}.xy"), float(v["heading_deg"]))
            for k, v in data["starts"].items()
        }
        layout = FieldLayout(
            name=str(data["name"]),
            half_m=float(data["half_m"]),
            rings=tuple(_point(r, "rings[]") for r in data["rings"]),
            goals=goals,
            platform=platform,
            home_zone=_box(data["home_zone"], "home_zone"),
            awp_line=_box(data["awp_line"], "awp_line"),
            awp_goal=str(data["awp_goal"]),
            starts=starts,
            isolation_s=float(data["isolation_s"]),
            interaction_s=float(data["interaction_s"]),
            endgame_s=float(data["endgame_s"]),
        )
    except KeyError as e:
        raise ValueError(f"field layout: missing key {e.args[0]!r}") from None
    layout.goal(layout.awp_goal)  # names a bad awp_goal
    return layout


def load_layout(path: str | Path = DEFAULT_LAYOUT) -> FieldLayout:
    """The field layout from its JSON file (default: the Tipping Point field)."""
    return parse_layout(json.loads(Path(path).read_text()))
