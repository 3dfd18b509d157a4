"""The simulated world's plain data: commands, readings, robot and goal state, step events, scores.

No PyBullet here. `WorldState` names what the rules (sim.world.rules) and the sensors
(sim.world.sensors) read of a world; sim.world.physics.World is the one that exists.
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from typing import Protocol

import numpy as np

from jetson.autonomy.geometry import AllianceName
from sim.config import RobotConfig, WorldConfig
from sim.field import FieldSpec, GoalSpec

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
    index: int
    spec: GoalSpec
    body: int
    x: float
    y: float
    carried_by: int | None = None
    rings: int = 0


@dataclass
class StepEvents:
    """What happened in one control step (indices are robot indices)."""

    collected: list[int]  # rings each robot took in
    scored: list[int]  # rings each robot moved onto its goal
    clamped: list[tuple[int, int]] = field(default_factory=list)  # (robot, goal)
    released: list[tuple[int, int]] = field(default_factory=list)
    pins: list[tuple[int, int]] = field(default_factory=list)  # (red robot, blue robot)
    phase_changed: bool = False
    match_over: bool = False


@dataclass(frozen=True)
class AllianceScore:
    rings: int
    goals_in_zone: int
    goals_elevated: int
    robots_elevated: int
    total: int


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
    ring_xy: np.ndarray
    ring_z: np.ndarray
    ring_state: np.ndarray
    ring_owner: np.ndarray
    ring_bodies: list[int]  # high fidelity: one PyBullet body per ring
