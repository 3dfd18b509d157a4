"""The simulated world's plain data: commands, readings, robot and goal state, step events, scores.

No PyBullet here. `WorldState` names what the rules (sim.world.rules) and the sensors
(sim.world.sensors) read of a world; sim.world.physics.World is the one that exists.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Literal, Protocol

import numpy as np

from jetson.autonomy.geometry import AllianceName
from sim.config import RobotConfig, WorldConfig
from sim.field import FieldSpec, GoalSpec
from sim.world.batch import GameConsts

RING_FLOOR = 0
RING_HELD = 1
RING_SCORED = 2
RING_OUT = 3  # not in play (never used in this match)

POST_RADIUS = 0.025  # the goal's vertical post, for occlusion and rendering


@dataclass
class DriveCommand:
    """What a robot is told to do for one control step.

    linear: m/s forward; angular: rad/s, positive clockwise (heading increasing), as in the wire
    protocol's Command. intake: run the ring intake. clamp: True grabs a goal at the back when one
    is there, False releases, None leaves it to WorldConfig.auto_clamp.
    """

    linear: float = 0.0
    angular: float = 0.0
    intake: bool = True
    clamp: bool | None = None

    @classmethod
    def from_wheels(
        cls, robot: RobotConfig, left_mps: float, right_mps: float, intake: bool = True
    ) -> DriveCommand:
        v, w = robot.from_wheel_speeds(left_mps, right_mps)
        return cls(v, w, intake)


@dataclass(frozen=True)
class GpsReading:
    x: float
    y: float
    heading_deg: float
    error_m: float
    time_s: float


@dataclass
class RobotState:
    index: int
    alliance: AllianceName
    slot: int  # 0, 1 within the alliance
    config: RobotConfig
    body: int
    x: float = 0.0
    y: float = 0.0
    heading: float = 0.0
    v: float = 0.0  # commanded forward speed after the limits, m/s
    w: float = 0.0  # commanded turn rate after the limits, rad/s clockwise
    measured_v: float = 0.0  # what the robot actually did over the last step (0 when blocked)
    measured_w: float = 0.0
    held: int = 0
    collected: int = 0  # rings taken in through the intake this match
    carried_goal: int | None = None
    on_platform: AllianceName | None = None  # the whole game: the platform it drove onto
    transfer_timer: float = 0.0
    intake_on: bool = True
    history: deque[tuple[float, float, float, float]] = field(default_factory=deque)

    @property
    def name(self) -> str:
        return f"{self.alliance}_{self.slot}"

    @property
    def xy(self) -> tuple[float, float]:
        return (self.x, self.y)

    @property
    def room(self) -> int:
        cap = self.config.ring_capacity
        return 1 << 30 if cap is None else max(0, cap - self.held)

    def wheel_speeds(self) -> tuple[float, float]:
        """Left and right wheel surface speeds as encoders would measure them, m/s."""
        return self.config.wheel_speeds(self.measured_v, self.measured_w)


@dataclass
class GoalState:
    """A mobile goal. `rings` counts every ring on it; in the whole game `rings_high` of them are
    on the high branch and `rings_base` in the base, the rest on the low branches (the ring race
    counts them all as on a branch). `contested_by`: a robot of the other alliance that clamped it
    too (a tug of war with `carried_by`)."""

    index: int
    spec: GoalSpec
    body: int
    x: float
    y: float
    carried_by: int | None = None
    rings: int = 0
    rings_high: int = 0
    rings_base: int = 0
    contested_by: int | None = None

    @property
    def rings_low(self) -> int:
        return self.rings - self.rings_high - self.rings_base

    @property
    def holders(self) -> tuple[int, ...]:
        return tuple(i for i in (self.carried_by, self.contested_by) if i is not None)


@dataclass
class StepEvents:
    """What happened in one control step (indices are robot indices)."""

    collected: list[int]  # rings each robot took in
    scored: list[int]  # rings each robot moved onto its goal
    clamped: list[tuple[int, int]] = field(default_factory=list)  # (robot, goal)
    released: list[tuple[int, int]] = field(default_factory=list)
    pins: list[tuple[int, int]] = field(default_factory=list)  # (red robot, blue robot)
    fouls: list[Foul] = field(default_factory=list)  # the whole game: fouls called this step
    phase_changed: bool = False
    match_over: bool = False


FoulKind = Literal["isolation_contact", "isolation_home_zone", "platform_protection"]


@dataclass(frozen=True)
class Foul:
    """A rule broken (sim.world.rules.update_fouls): by robot `robot` of `alliance`."""

    time_s: float
    robot: int
    alliance: AllianceName
    kind: FoulKind


@dataclass(frozen=True)
class AutonomousResult:
    """An alliance's result of the isolation (autonomous) period, fixed when it ends."""

    score: int  # its points at the end of the period
    bonus: int  # the Autonomous Bonus it gets (all, a tie's share, or 0)
    win_point: bool  # the Autonomous Win Point


@dataclass(frozen=True)
class AllianceScore:
    """An alliance's match score. The first five fields are the ring race's; the whole game fills
    the rest (rings counts the rings that score for it, wherever they sit)."""

    rings: int
    goals_in_zone: int
    goals_elevated: int
    robots_elevated: int
    total: int
    rings_high: int = 0  # of `rings`, on a high branch
    rings_base: int = 0  # of `rings`, in a base
    autonomous_bonus: int = 0
    autonomous_win_point: bool = False
    fouls: int = 0  # fouls its robots committed
    foul_credit: int = 0  # Elevated robots credited to it for the opponent's <SG3> fouls
    balanced: bool = False  # its platform is Balanced now

    @property
    def rings_low(self) -> int:
        return self.rings - self.rings_high - self.rings_base


@dataclass
class PlatformState:
    """The whole game: one alliance's see-saw. tilt: radians, positive with its field-side edge
    down (sim.world.seesaw moves it)."""

    alliance: AllianceName
    tilt: float = 0.0


def intake_rect(
    rc: RobotConfig, ring_radius: float
) -> tuple[tuple[float, float], tuple[float, float]]:
    """A robot's intake zone, robot frame: x (across) and y (forward) ranges a ring centre must
    be in. It starts one ring radius behind the front face, so a ring touching the bumper
    counts, and reaches intake_depth_m plus a radius ahead of it."""
    front = rc.length_m / 2
    return (-rc.intake_width_m / 2, rc.intake_width_m / 2), (
        front - ring_radius,
        front + rc.intake_depth_m + ring_radius,
    )


class WorldState(Protocol):
    """What the rules and the sensors read of a world. Rings are a table: position (N, 2), height
    of the centre (N), state (RING_*) and owner (the robot holding it or the goal it is on)."""

    config: WorldConfig
    field: FieldSpec
    client: int  # the PyBullet client (high fidelity's ray tests)
    training: bool  # training fidelity: no ring bodies, visibility is geometry
    time_s: float
    pin_time_s: float
    pin_timers: dict[tuple[int, int], float]  # (red robot, blue robot) -> s in contact
    robots: list[RobotState]
    goals: list[GoalState]
    isolation_s: float
    match_length_s: float
    # The whole game: the see-saws, the fouls so far, the isolation period's result once it ended
    # (None before, and always in the ring race), and which contacts were going on last step.
    platforms: dict[str, PlatformState]
    fouls: list[Foul]
    autonomous: dict[str, AutonomousResult] | None
    foul_contacts: set[tuple[int, int, str]]
    game_consts: GameConsts  # what the whole game's compiled rules read (sim.world.batch)
    ring_xy: np.ndarray
    ring_z: np.ndarray
    ring_state: np.ndarray
    ring_owner: np.ndarray
    ring_bodies: list[int]  # high fidelity: one PyBullet body per ring
