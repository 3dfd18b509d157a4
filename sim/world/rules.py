"""The game's rules: what scores, which alliance a goal counts for, when a robot is elevated, when
a pin is called. Tipping Point (VEX 2021-22), as the manual counts it.

Functions over the world's state (sim.world.state.WorldState); the physics (sim.world.physics)
calls them and knows nothing of points. A different game changes this file.
"""

from __future__ import annotations

from collections.abc import Callable

from jetson.autonomy.geometry import AllianceName
from sim.world.state import AllianceScore, GoalState, RobotState, StepEvents, WorldState


def robot_elevated(world: WorldState, r: RobotState) -> bool:
    """A robot is elevated while it stands on its alliance's platform."""
    try:
        plat = world.field.platform(r.alliance)
    except ValueError:
        return False
    return plat.contains_point(r.x, r.y)


def goal_owner(world: WorldState, g: GoalState) -> tuple[AllianceName | None, bool]:
    """Which alliance a goal scores for right now, and whether it is elevated."""
    if g.carried_by is not None:
        carrier = world.robots[g.carried_by]
        if robot_elevated(world, carrier) and g.spec.alliance in (None, carrier.alliance):
            return carrier.alliance, True
    for alliance, zone in world.field.home_zones.items():
        inside = zone.contains_point(g.x, g.y, margin=g.spec.base_radius)
        if inside and g.spec.alliance in (None, alliance):
            return alliance, False  # type: ignore[return-value]
    return None, False


def score(world: WorldState) -> dict[str, AllianceScore]:
    """The match score for the current state.

    Rings on an alliance goal count for its alliance wherever it is; rings on a neutral goal
    count only while it is in a home zone (or elevated). Every ring counts as on a branch.
    """
    sc = world.field.scoring
    out = {}
    for alliance in ("red", "blue"):
        rings = in_zone = elevated_goals = 0
        for g in world.goals:
            owner, elevated = goal_owner(world, g)
            if g.spec.alliance == alliance or (g.spec.alliance is None and owner == alliance):
                rings += g.rings
            if owner == alliance:
                if elevated:
                    elevated_goals += 1
                else:
                    in_zone += 1
        robots_up = sum(
            1 for r in world.robots if r.alliance == alliance and robot_elevated(world, r)
        )
        total = (
            rings * sc.ring_branch
            + in_zone * sc.goal_in_home_zone
            + elevated_goals * sc.goal_elevated
            + robots_up * sc.robot_elevated
        )
        out[alliance] = AllianceScore(rings, in_zone, elevated_goals, robots_up, total)
    return out


def update_pins(
    world: WorldState,
    touching: Callable[[RobotState, RobotState], bool],
    events: StepEvents,
    dt: float,
) -> None:
    """One step of the pin rule: a red and a blue robot in contact for pin_time_s is a pin
    (events.pins), and their timer starts again; apart, it is zero."""
    timers = world.pin_timers
    for a in world.robots:
        if a.alliance != "red":
            continue
        for b in world.robots:
            if b.alliance != "blue":
                continue
            key = (a.index, b.index)
            if touching(a, b):
                timers[key] = timers.get(key, 0.0) + dt
                if timers[key] >= world.pin_time_s - 1e-9:
                    events.pins.append(key)
                    timers[key] = 0.0
            else:
                timers[key] = 0.0


def pin_timer(world: WorldState, red_index: int, blue_index: int) -> float:
    """How long the two robots have been in contact, s (0 when apart or just pinned)."""
    return world.pin_timers.get((red_index, blue_index), 0.0)
