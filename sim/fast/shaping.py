"""The shaping potentials of sim.rewards for one robot of every match, compiled.

    approach, goal, park = learner_potentials(...)   # (B,) each: sim.rewards' three potentials

FastMatches pays each match's learner MatchCore's potential-based shapings: the distance from
its front to the nearest ring on the floor (ring_potential), from its clamp point to the
nearest free goal it could score with (goal_potential) and from its platform (park_potential).
sim.rewards writes them as numpy over (B, R, ...) batches; for a batch of a few dozen matches
and one robot each, numpy's per-operation cost is most of the step's reward, so this is the
same arithmetic as one loop over the matches. tests/sim/fast/test_shaping.py holds it to
sim.rewards value for value.
"""

from __future__ import annotations

import math

import numba as nb
import numpy as np
from numpy.typing import NDArray

from sim.fast.kernels import threads_for

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
Bool = NDArray[np.bool_]


def learner_potentials(
    x: F64,
    y: F64,
    heading_sin: F64,
    heading_cos: F64,
    half_length: F64,
    room: I64,
    ring_xy: F64,
    floor: Bool,
    clamp_offsets: F64,
    goal_xy: F64,
    eligible: Bool,
    holding: Bool,
    platform: F64,
    approach: Bool,
    goal: Bool,
    park: Bool,
) -> F64:
    """sim.rewards' potentials of one robot of every match b, (B, 3): approach (ring_potential
    from its front, half_length ahead along the heading), goal_approach (goal_potential from its
    clamp points, clamp_offsets (B, G) along the heading) and park (park_potential to platform
    (B, 4): centre x, y and half-sizes less the margin); each 0 where its flag (B,) is off.
    x, y, heading_sin, heading_cos, half_length, room, holding: (B,), the robot's; ring_xy (B, N,
    2), floor (B, N); goal_xy (B, G, 2), eligible (B, G)."""
    with threads_for(len(x)):
        return _potentials(
            x, y, heading_sin, heading_cos, half_length, room, ring_xy, floor, clamp_offsets,
            goal_xy, eligible, holding, platform, approach, goal, park,
        )  # fmt: skip


@nb.njit(cache=True)
def ring_potential(fx, fy, room, ring_xy, floor):
    """sim.rewards.ring_potential of one robot: from its front (fx, fy) to the nearest ring on
    the floor (ring_xy (N, 2), floor (N,)); 0 when its intake is full or no ring is left."""
    best = np.inf
    for n in range(ring_xy.shape[0]):
        if floor[n]:
            dx, dy = ring_xy[n, 0] - fx, ring_xy[n, 1] - fy
            d2 = dx * dx + dy * dy
            if d2 < best:
                best = d2
    return math.sqrt(best) if room > 0 and best < np.inf else 0.0


@nb.njit(cache=True)
def goal_potential(cx, cy, goal_xy, eligible, holding):
    """sim.rewards.goal_potential of one robot: from its clamp point for each goal (cx, cy:
    (G,)) to that goal (goal_xy (G, 2)), the nearest eligible one; 0 while it holds one or none
    is free."""
    best = np.inf
    for g in range(goal_xy.shape[0]):
        if eligible[g]:
            d = math.hypot(cx[g] - goal_xy[g, 0], cy[g] - goal_xy[g, 1])
            if d < best:
                best = d
    return 0.0 if holding or not best < np.inf else best


@nb.njit(cache=True)
def park_potential(x, y, cx, cy, hx, hy, active):
    """sim.rewards.park_potential of one robot: from (x, y) to the box of centre (cx, cy) and
    half-sizes (hx, hy) while active, else 0."""
    if not active:
        return 0.0
    dx = max(abs(x - cx) - hx, 0.0)
    dy = max(abs(y - cy) - hy, 0.0)
    return math.hypot(dx, dy)


@nb.njit(cache=True, parallel=True)
def _potentials(
    x, y, s, c, length, room, ring_xy, floor, offsets, goal_xy, eligible, holding, platform,
    approach, goal, park,
):  # fmt: skip
    """learner_potentials' loop over the matches."""
    n_match = x.shape[0]
    n_goal = goal_xy.shape[1]
    out = np.zeros((n_match, 3))
    for b in nb.prange(n_match):
        if approach[b]:
            fx, fy = x[b] + length[b] * s[b], y[b] + length[b] * c[b]
            out[b, 0] = ring_potential(fx, fy, room[b], ring_xy[b], floor[b])
        if goal[b] and n_goal:
            cx = np.empty(n_goal)
            cy = np.empty(n_goal)
            for g in range(n_goal):
                cx[g] = x[b] + offsets[b, g] * s[b]
                cy[g] = y[b] + offsets[b, g] * c[b]
            out[b, 1] = goal_potential(cx, cy, goal_xy[b], eligible[b], holding[b])
        p = platform[b]
        out[b, 2] = park_potential(x[b], y[b], p[0], p[1], p[2], p[3], park[b])
    return out
