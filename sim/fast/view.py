"""One match of a FastWorld seen as the per-match world scripted players and pictures read.

    view = match_view(fast, k)          # robots, goals, rings, clock of match k, as World has them
    command = GreedyChaser(0).act(view)

The view holds sim.world.state's own RobotState and GoalState, so anything written against
World's state (sim.world.state.WorldState: the baselines, sim.render's top-down picture) reads a
fast match unchanged. It is a copy: stepping the FastWorld does not change a view taken before.
"""

from __future__ import annotations

from dataclasses import dataclass, field, replace

import numpy as np

from jetson.autonomy.geometry import AllianceName
from sim.config import WorldConfig
from sim.fast.world import FastWorld
from sim.field import FieldSpec
from sim.world.batch import ALLIANCE_CODES
from sim.world.state import (
    RING_FLOOR,
    RING_HELD,
    GoalState,
    PlatformState,
    RobotState,
    intake_rect,
)


@dataclass
class MatchView:
    """World's state of one fast match (the attributes scripted players read)."""

    config: WorldConfig
    field: FieldSpec
    time_s: float
    isolation_s: float
    match_length_s: float
    robots: list[RobotState]
    goals: list[GoalState]
    ring_xy: np.ndarray
    ring_state: np.ndarray
    ring_z: np.ndarray
    training: bool = True
    lineup: list[tuple[str, str]] = field(default_factory=list)
    platforms: dict[str, PlatformState] = field(default_factory=dict)  # the whole game's boards

    def intake_rect(self, r: RobotState) -> tuple[tuple[float, float], tuple[float, float]]:
        """Robot r's intake zone, robot frame, as World.intake_rect."""
        return intake_rect(r.config, self.field.ring.radius)


def match_view(world: FastWorld, k: int) -> MatchView:
    """Match `k` of `world` now."""
    robots = []
    slots = {"red": 0, "blue": 0}
    for i, (alliance, _) in enumerate(world.lineup):
        rc = world.robot_configs[i]
        if world.room_cap[k, i] != world.capacity[i]:
            rc = replace(rc, ring_capacity=None)
        carried = int(world.carried[k, i])
        r = RobotState(
            index=i,
            alliance=alliance,
            slot=slots[alliance],
            config=rc,
            body=-1,
            x=float(world.x[k, i]),
            y=float(world.y[k, i]),
            heading=float(world.heading[k, i]),
            v=float(world.v[k, i]),
            w=float(world.w[k, i]),
            measured_v=float(world.measured_v[k, i]),
            measured_w=float(world.measured_w[k, i]),
            held=int(world.held[k, i]),
            collected=int(world.collected[k, i]),
            carried_goal=None if carried < 0 else carried,
            on_platform=_alliance(int(world.on_platform[k, i])),
        )
        slots[alliance] += 1
        robots.append(r)
    goals = []
    for g, spec in enumerate(world.field.goals):
        carrier = int(world.carrier[k, g])
        goals.append(
            GoalState(
                index=g,
                spec=spec,
                body=-1,
                x=float(world.gx[k, g]),
                y=float(world.gy[k, g]),
                carried_by=None if carrier < 0 else carrier,
                rings=int(world.goal_rings[k, g]),
                rings_high=int(world.rings_high[k, g]),
                rings_base=int(world.rings_base[k, g]),
                contested_by=None if world.contester[k, g] < 0 else int(world.contester[k, g]),
            )
        )
    floor = world.ring_floor[k]
    return MatchView(
        config=world.config,
        field=world.field,
        time_s=float(world.time_s[k]),
        isolation_s=world.isolation_s,
        match_length_s=world.match_length_s,
        robots=robots,
        goals=goals,
        ring_xy=world.ring_xy[k].copy(),
        ring_state=np.where(floor, RING_FLOOR, RING_HELD).astype(np.int8),
        ring_z=np.full(len(floor), world.ring_z),
        lineup=list(world.lineup),
        platforms={
            p.alliance: PlatformState(p.alliance, float(world.tilt[k, ALLIANCE_CODES[p.alliance]]))
            for p in world.field.platforms
        }
        if world.game
        else {},
    )


def _alliance(code: int) -> AllianceName | None:
    return None if code < 0 else ("red", "blue")[code]
