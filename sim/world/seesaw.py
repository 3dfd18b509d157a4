"""The platform as a see-saw (the whole game): which robots are on a board, what blocks the others,
and how the board tips. Numbers are the field file's [seesaw]; what counts as Balanced is a rule
(sim.world.rules.platform_balanced).

The torque-balance model: the board tips about a hinge along its long side (parallel to the
alliance wall). Each load on it (a robot that drove onto it, a goal it carries, a goal resting on
the board) pushes down with its weight at its distance d from the hinge toward the field (clipped
to the board: a robot half on the ramp bears on its edge). The hinge's flat surfaces hold the board
level while the loads' centre of mass, with the board's own weight at the hinge, lies within
`hinge_flat` of the hinge: |sum m d| <= hinge_flat (M_board + sum m). Beyond, the board swings at
`tilt_rate_deg_s` toward the heavier side until that edge reaches the floor. An empty board stays
where it was left.

A robot drives onto a board only over its field-side edge, and only while that edge is no higher
than `climb_edge` (the ramp side, the board tipped toward the field); anywhere else the board is
an obstacle it is pushed back from. A free goal meets the board the same way: pushed up the ramp
it rests on the board; pushed at a raised edge or at the board's ends it is stopped (its base
does not ride over an edge higher than a robot's wheels do). Both fidelities use this model;
high fidelity shows it on a hinged body (sim.world.physics).
"""

from __future__ import annotations

import math
from collections.abc import Iterable

from sim.field import PlatformSpec, SeesawSpec
from sim.world.state import GoalState, PlatformState, RobotState


def robot_box(r: RobotState) -> tuple[float, float, float, float]:
    """The robot's footprint's bounding box (x0, y0, x1, y1)."""
    h = math.radians(r.heading)
    ac, as_ = abs(math.cos(h)), abs(math.sin(h))
    hw, hl = r.config.width_m / 2, r.config.length_m / 2
    ex, ey = hw * ac + hl * as_, hw * as_ + hl * ac
    return r.x - ex, r.y - ey, r.x + ex, r.y + ey


def board_box(plat: PlatformSpec) -> tuple[float, float, float, float]:
    hx, hy = plat.size[0] / 2, plat.size[1] / 2
    return plat.center[0] - hx, plat.center[1] - hy, plat.center[0] + hx, plat.center[1] + hy


def overlap(
    a: tuple[float, float, float, float], b: tuple[float, float, float, float]
) -> tuple[float, float]:
    """How far two boxes overlap along x and y (either <= 0: apart)."""
    return min(a[2], b[2]) - max(a[0], b[0]), min(a[3], b[3]) - max(a[1], b[1])


def may_mount(
    plat: PlatformSpec, spec: SeesawSpec, state: PlatformState, before_xy: tuple[float, float]
) -> bool:
    """Whether a robot that was at before_xy (its centre, last step) drives onto the board now:
    it came over the field-side edge (its centre beyond that edge, within the board's length)
    while that edge is down to climb_edge."""
    x, y = before_xy
    return (
        plat.along(x) >= plat.size[0] / 2 - 1e-9
        and abs(y - plat.center[1]) <= plat.size[1] / 2
        and plat.edge_height(state.tilt) <= spec.climb_edge + 1e-9
    )


def goal_box(g: GoalState) -> tuple[float, float, float, float]:
    """The goal's base's bounding box (x0, y0, x1, y1)."""
    rad = g.spec.base_radius
    return g.x - rad, g.y - rad, g.x + rad, g.y + rad


def push_out(
    box: tuple[float, float, float, float], xy: tuple[float, float], plat: PlatformSpec
) -> tuple[float, float]:
    """The smallest move (dx, dy) that takes a box (a robot's or a goal's, its centre at xy)
    off the board."""
    ox, oy = overlap(box, board_box(plat))
    if ox <= oy:
        return (ox if xy[0] >= plat.center[0] else -ox), 0.0
    return 0.0, (oy if xy[1] >= plat.center[1] else -oy)


def loads(
    plat: PlatformSpec, robots: Iterable[RobotState], goals: list[GoalState]
) -> list[tuple[float, float]]:
    """(mass kg, lever arm m toward the field) of everything on the board."""
    half = plat.size[0] / 2
    out = []
    carried: set[int] = set()
    for r in robots:
        if r.on_platform != plat.alliance:
            continue
        out.append((r.config.mass_kg, min(max(plat.along(r.x), -half), half)))
        if r.carried_goal is not None:
            carried.add(r.carried_goal)
    for g in goals:
        if g.index in carried:
            out.append((g.spec.mass_kg, min(max(plat.along(g.x), -half), half)))
        elif g.carried_by is None and plat.contains_point(g.x, g.y):
            out.append((g.spec.mass_kg, plat.along(g.x)))
    return out


def target_tilt(
    plat: PlatformSpec, spec: SeesawSpec, state: PlatformState, on: list[tuple[float, float]]
) -> float:
    """Where the board settles under its loads (radians, + field-side edge down)."""
    if not on:
        return state.tilt
    torque = sum(m * d for m, d in on)
    weight = spec.board_mass_kg + sum(m for m, _ in on)
    band = spec.hinge_flat * weight
    if torque > band:
        return plat.max_tilt_rad
    if torque < -band:
        return -plat.max_tilt_rad
    return 0.0


def start_tilt(plat: PlatformSpec, spec: SeesawSpec) -> float:
    return {"field": plat.max_tilt_rad, "wall": -plat.max_tilt_rad, "level": 0.0}[spec.start_down]


def step_tilt(
    plat: PlatformSpec,
    spec: SeesawSpec,
    state: PlatformState,
    on: list[tuple[float, float]],
    dt: float,
) -> None:
    """Swing the board toward where its loads put it, at tilt_rate_deg_s."""
    target = target_tilt(plat, spec, state, on)
    rate = math.radians(spec.tilt_rate_deg_s) * dt
    state.tilt += min(max(target - state.tilt, -rate), rate)
