"""The twin hosts the scripted alliance (jetson/autonomy/alliance.py) and the ring-race alliance.

`AlliancePlayer` drives one robot with the robot's own strategy object, built from what the
daemon has: the robot's settings (its role, size, mass, speeds, intake: `robot_role`), the field's
layout file the robot carries (jetson/autonomy/data/tipping_point.json), and every control step
its GPS reading, the rings its camera sees, the rings in its intake, the clamp's state and the
match clock, all through MatchCore.view (the sensors, never the World's truth of other robots,
goals or rings). The strategy's clamp command goes to the World as DriveCommand.clamp (True hold,
False release); the lift is not modelled in the twin (where a ring lands is the robot config's
`reaches_high_branch`).

The ring-race alliance is two robots playing the original team's ring race in the whole game: the
route planner without its endgame (`planner-collector`, camera and GPS) on the 24" and the greedy
chaser (`scripted`, ground-truth rings) on the 15". They collect rings, back onto a goal when the
intake is full, and ignore the platforms, the isolation rule and the endgame.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from jetson.autonomy.alliance import AllianceStrategy
from jetson.autonomy.alliance_config import (
    AllianceAction,
    AllianceConfig,
    AllianceInputs,
    RobotRole,
)
from jetson.autonomy.field_layout import FieldLayout, PlatformLayout, load_layout
from jetson.autonomy.goal_sightings import off_the_platforms
from sim.baselines.planner import Planner, PlannerConfig
from sim.baselines.scripted import GreedyChaser
from sim.config import ROBOTS, RobotConfig
from sim.goal_sight import visible_goals
from sim.match import MatchCore
from sim.world.physics import World
from sim.world.state import DriveCommand


def robot_role(world: World, index: int) -> RobotRole:
    """The strategy's RobotRole from a robot's config (what the daemon's settings would say)."""
    r = world.robots[index]
    rc: RobotConfig = r.config
    role = "24in" if rc.reaches_high_branch or rc.name == "24in" else "15in"
    partner = ROBOTS["15in" if role == "24in" else "24in"]
    (x0, x1), (y0, y1) = world.intake_rect(r)
    return RobotRole(
        role=role,
        length_m=rc.length_m,
        width_m=rc.width_m,
        mass_kg=rc.mass_kg,
        max_linear_mps=rc.max_linear_mps,
        max_angular_rad_s=rc.max_angular_rad_s,
        intake_zone=(float(x0), float(x1), float(y0), float(y1)),
        reaches_high_branch=rc.reaches_high_branch,
        partner_mass_kg=partner.mass_kg,
        ring_capacity=rc.ring_capacity,
    )


def inputs_from_view(
    core: MatchCore, index: int, goals: bool = True, platform: PlatformLayout | None = None
) -> AllianceInputs:
    """What the daemon hands the strategy: the GPS pose, the camera's rings (robot frame), the
    intake's count, the clamp, the match clock, and with `goals` the goals the camera sees
    (sim/goal_sight.py: what the robot's goal detector reports; None without one), less those
    the daemon's scripted decider drops (red and blue ones on a platform's footprint,
    jetson/autonomy/goal_sightings.py; `platform`: the layout's, else the robot's file's)."""
    view = core.view(index)
    seen = None
    if goals:
        plat = platform if platform is not None else load_layout().platform
        seen = off_the_platforms(
            visible_goals(core.world, index), (view.x, view.y), view.heading_deg, plat
        )
    return AllianceInputs(
        x=view.x,
        y=view.y,
        heading_deg=view.heading_deg,
        alliance=view.alliance,
        time_s=view.time_s,
        rings_robot_xy=np.asarray(view.rings_robot_xy, dtype=np.float64).reshape(-1, 2),
        rings_held=view.rings_held,
        goal_clamped=view.goal_clamped,
        goals_robot=seen,
    )


def to_command(action: AllianceAction) -> DriveCommand:
    return DriveCommand(action.linear, action.angular, action.intake, action.clamp)


class AlliancePlayer:
    """One robot of the scripted alliance (the Player interface, sim/players.py)."""

    name = "alliance"

    def __init__(
        self,
        config: AllianceConfig | None = None,
        layout: FieldLayout | None = None,
        goal_detector: bool = True,
    ):
        self.config = config or AllianceConfig()
        self.layout = layout or load_layout()
        self.goal_detector = goal_detector
        self.strategy: AllianceStrategy | None = None
        self.last_action: AllianceAction | None = None

    def reset(self, core: MatchCore, index: int, rng: np.random.Generator | None = None) -> None:
        layout = self.layout
        w = core.world
        if (
            abs(layout.isolation_s - w.isolation_s) > 1e-9
            or abs(layout.match_length_s - w.match_length_s) > 1e-9
        ):
            # A match with other periods than the layout file's (e.g. a short test match).
            layout = replace(
                layout,
                isolation_s=w.isolation_s,
                interaction_s=w.match_length_s - w.isolation_s,
            )
        self.strategy = AllianceStrategy(robot_role(w, index), layout, self.config)

    def act(self, core: MatchCore, index: int, obs: np.ndarray | None = None) -> DriveCommand:
        assert self.strategy is not None, "act() before reset()"
        inputs = inputs_from_view(core, index, self.goal_detector, self.layout.platform)
        self.last_action = self.strategy.step(inputs)
        if core.claims:  # the partner's observation reads it (spec.partner), as on the robot
            got = self.strategy.field_claim(inputs.alliance)
            core.claims[index] = None if got is None else got[1]
        return to_command(self.last_action)


class _GreedyChaserPlayer:
    """The greedy ring-chaser (sim.baselines.scripted, ground-truth rings) as a Player."""

    name = "scripted"

    def __init__(self) -> None:
        self._chaser: GreedyChaser | None = None

    def reset(self, core: MatchCore, index: int, rng: np.random.Generator | None = None) -> None:
        self._chaser = GreedyChaser(index)

    def act(self, core: MatchCore, index: int, obs: np.ndarray | None = None) -> DriveCommand:
        assert self._chaser is not None, "act() before reset()"
        return self._chaser.act(core.world)


def ring_race_player(robot: str) -> Planner | _GreedyChaserPlayer:
    """One robot of the ring-race alliance: the route planner without its endgame on the 24",
    the greedy chaser on the 15" (see the module docstring)."""
    if robot == "24in":
        return Planner(PlannerConfig(endgame=False))
    return _GreedyChaserPlayer()
