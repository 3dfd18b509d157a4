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
does not ride over an edge higher than a robot's wheels do). Both fidelities and the batched
backend (sim.fast) use this model, compiled over a batch of matches (sim.world.batch; World is
a batch of one); high fidelity shows it on a hinged body (sim.world.physics).
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from sim.field import PlatformSpec, SeesawSpec
from sim.world.batch import GameBatch, GameConsts
from sim.world.state import PlatformState, RobotState


def robot_box(r: RobotState) -> tuple[float, float, float, float]:
    """The robot's footprint's bounding box (x0, y0, x1, y1)."""
    h = math.radians(r.heading)
    ac, as_ = abs(math.cos(h)), abs(math.sin(h))
    hw, hl = r.config.width_m / 2, r.config.length_m / 2
    ex, ey = hw * ac + hl * as_, hw * as_ + hl * ac
    return r.x - ex, r.y - ey, r.x + ex, r.y + ey


def start_tilt(plat: PlatformSpec, spec: SeesawSpec) -> float:
    return {"field": plat.max_tilt_rad, "wall": -plat.max_tilt_rad, "level": 0.0}[spec.start_down]


@nb.njit(cache=True)
def settle(
    tilt: float, loads: int, torque: float, mass: float, board_mass: float, band: float, most: float
) -> float:
    """Where a board settles (radians, + field-side edge down) under `loads` loads of total
    `mass` and `torque` (sum of mass x lever arm toward the field) with its own mass at the
    hinge: level while the loads' centre of mass is within the hinge's flats (`band`, its
    half-width), else down to the floor (`most`) on the heavier side. An empty board stays."""
    if loads == 0:
        return tilt
    limit = band * (board_mass + mass)
    if torque > limit:
        return most
    if torque < -limit:
        return -most
    return 0.0


def target_tilt(
    plat: PlatformSpec, spec: SeesawSpec, state: PlatformState, on: list[tuple[float, float]]
) -> float:
    """Where the board settles under loads (mass kg, lever arm m toward the field)."""
    torque = sum(m * d for m, d in on)
    mass = sum(m for m, _ in on)
    return settle(
        state.tilt, len(on), torque, mass, spec.board_mass_kg, spec.hinge_flat, plat.max_tilt_rad
    )


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


@nb.njit(cache=True)
def _along(c: GameConsts, a: int, x: float) -> float:
    """A point's distance from a's hinge toward the field (the lever arm of a load)."""
    return (x - c.plat[a, 0]) * c.field_side[a]


@nb.njit(cache=True)
def step_tilts(
    c: GameConsts, s: GameBatch, carried: NDArray[np.int64], dt: float, live: NDArray[np.bool_]
) -> None:
    """One step of every live match's boards (s.tilt, in place): each swings at tilt_rate
    toward where its loads put it (settle). The loads: each robot that drove onto it (its arm
    clipped to the board: a robot half on the ramp bears on its edge) and the goal it holds
    (carried (B, R), clipped too), and each free goal whose centre is over the board."""
    n, r = s.x.shape
    n_goal = s.gx.shape[1]
    rate = c.tilt_rate * dt
    tilt = s.tilt  # written in place
    for b in range(n):
        if not live[b]:
            continue
        for a in range(2):
            if not c.plat_has[a]:
                continue
            half = c.plat[a, 2]
            on_goal = np.zeros(n_goal, dtype=np.bool_)
            loads = 0
            torque = mass = 0.0
            for i in range(r):
                if s.on_platform[b, i] != a:
                    continue
                loads += 1
                torque += c.mass[i] * min(max(_along(c, a, s.x[b, i]), -half), half)
                mass += c.mass[i]
                if carried[b, i] >= 0:
                    on_goal[carried[b, i]] = True
            for g in range(n_goal):
                if on_goal[g]:
                    arm = min(max(_along(c, a, s.gx[b, g]), -half), half)
                elif s.carrier[b, g] < 0 and (
                    abs(s.gx[b, g] - c.plat[a, 0]) <= half
                    and abs(s.gy[b, g] - c.plat[a, 1]) <= c.plat[a, 3]
                ):
                    arm = _along(c, a, s.gx[b, g])
                else:
                    continue
                loads += 1
                torque += c.goal_mass[g] * arm
                mass += c.goal_mass[g]
            target = settle(
                tilt[b, a], loads, torque, mass, c.board_mass, c.hinge_flat, c.max_tilt[a]
            )
            tilt[b, a] += min(max(target - tilt[b, a], -rate), rate)


@nb.njit(cache=True)
def robot_extents(c: GameConsts, i: int, heading: float) -> tuple[float, float]:
    """Half the x and y extents of robot i's footprint's bounding box at a heading (deg)."""
    h = math.radians(heading)
    ac, as_ = abs(math.cos(h)), abs(math.sin(h))
    return c.half_w[i] * ac + c.half_l[i] * as_, c.half_w[i] * as_ + c.half_l[i] * ac


@nb.njit(cache=True)
def _may_mount(c: GameConsts, a: int, tilt: float, x0: float, y0: float) -> bool:
    """Whether a body whose centre was at (x0, y0) last step comes onto a's board now: it came
    over the field-side edge (its centre beyond that edge, within the board's length) while that
    edge is down to climb_edge."""
    edge = max(0.0, c.plat[a, 4] - c.plat[a, 2] * math.sin(tilt))
    return (
        _along(c, a, x0) >= c.plat[a, 2] - 1e-9
        and abs(y0 - c.plat[a, 1]) <= c.plat[a, 3]
        and edge <= c.climb_edge + 1e-9
    )


@nb.njit(cache=True)
def _push_out(
    c: GameConsts, a: int, x: float, y: float, ex: float, ey: float
) -> tuple[float, float, bool]:
    """The smallest move (dx, dy) that takes a box (centre x, y, half extents ex, ey) off a's
    board, and whether the two overlap at all."""
    cx, cy, hx, hy = c.plat[a, 0], c.plat[a, 1], c.plat[a, 2], c.plat[a, 3]
    ox = min(x + ex, cx + hx) - max(x - ex, cx - hx)
    oy = min(y + ey, cy + hy) - max(y - ey, cy - hy)
    if ox <= 0 or oy <= 0:
        return 0.0, 0.0, False
    if ox <= oy:
        return (ox if x >= cx else -ox), 0.0, True
    return 0.0, (oy if y >= cy else -oy), True


@nb.njit(cache=True)
def board_under(c: GameConsts, x: float, y: float, ex: float, ey: float) -> int:
    """The board a box (centre x, y, half extents ex, ey) set down by hand overlaps: its
    alliance code (the last in the field file's order), or -1 for none."""
    code = -1
    for a in c.plat_order:
        if _push_out(c, a, x, y, ex, ey)[2]:
            code = a
    return code


@nb.njit(cache=True)
def board_contacts(
    c: GameConsts,
    s: GameBatch,
    x0: NDArray[np.float64],
    y0: NDArray[np.float64],
    live: NDArray[np.bool_],
) -> NDArray[np.bool_]:
    """Robots and the boards, after a step's motion (from x0, y0, (B, R), the centres before):
    a robot drives onto a board over its lowered field-side edge (_may_mount), leaves it when
    its footprint's bounding box is off it, and anywhere else is pushed back off it. Updates
    s.x, s.y and s.on_platform in place; returns which robots were pushed (B, R)."""
    n, r = s.x.shape
    moved = np.zeros((n, r), dtype=np.bool_)
    x, y, on = s.x, s.y, s.on_platform  # written in place
    for b in range(n):
        if not live[b]:
            continue
        for i in range(r):
            ex, ey = robot_extents(c, i, s.heading[b, i])
            for a in c.plat_order:
                dx, dy, over = _push_out(c, a, x[b, i], y[b, i], ex, ey)
                if not over:
                    if on[b, i] == a:
                        on[b, i] = -1
                    continue
                if on[b, i] == a:
                    continue
                if on[b, i] < 0 and _may_mount(c, a, s.tilt[b, a], x0[b, i], y0[b, i]):
                    on[b, i] = a
                    continue
                x[b, i] += dx
                y[b, i] += dy
                moved[b, i] = True
    return moved


@nb.njit(cache=True)
def goal_board_contacts(
    c: GameConsts,
    s: GameBatch,
    gx0: NDArray[np.float64],
    gy0: NDArray[np.float64],
    live: NDArray[np.bool_],
) -> NDArray[np.bool_]:
    """Free goals and the boards (from gx0, gy0, (B, G), the centres before the step): a goal
    goes onto a board only up its lowered field-side edge, as a robot mounts; one already
    resting on the board stays; anywhere else the board stops it (pushed back off). Goals a
    robot holds move with it (the robot meets the board). Updates s.gx and s.gy in place;
    returns which goals were pushed (B, G)."""
    n, n_goal = s.gx.shape
    moved = np.zeros((n, n_goal), dtype=np.bool_)
    gx, gy = s.gx, s.gy  # written in place
    for b in range(n):
        if not live[b]:
            continue
        for g in range(n_goal):
            if s.carrier[b, g] >= 0:
                continue
            rad = c.goal_radius[g]
            for a in c.plat_order:
                dx, dy, over = _push_out(c, a, gx[b, g], gy[b, g], rad, rad)
                x0, y0 = gx0[b, g], gy0[b, g]
                on_before = (
                    abs(x0 - c.plat[a, 0]) <= c.plat[a, 2]
                    and abs(y0 - c.plat[a, 1]) <= c.plat[a, 3]
                )
                if not over or on_before or _may_mount(c, a, s.tilt[b, a], x0, y0):
                    continue
                gx[b, g] += dx
                gy[b, g] += dy
                moved[b, g] = True
    return moved
