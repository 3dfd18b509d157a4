"""Which rings are worth the trip: a short open tour over the rings a robot knows about.

Shared by the planner (sim/baselines/planner.py), which drives it, and the observation's route slots
(ring_memory.py, `route_slots`), which show a policy the same choice. numpy only: the Jetson
builds the observation.

The tour: each of the `candidates` cheapest rings (distance plus a cost per radian the robot
must turn to face it) as the first stop, a nearest-neighbour tour through the other candidates
after it, improved by 2-opt with the first stop fixed; the cheapest such tour wins. With a
current target, the tour keeps it first unless a tour from elsewhere is cheaper by more than
`switch_margin_m`: without that margin two rings of nearly equal cost make the robot dither.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.geometry import field_to_robot

FloatArray = NDArray[np.float64]


@dataclass(frozen=True)
class TourConfig:
    candidates: int = 6  # rings the tour orders (the cheapest first stops)
    turn_cost_m_per_rad: float = 0.15  # distance a needed turn is worth
    switch_margin_m: float = 0.1  # a new first stop must be this much cheaper

    def __post_init__(self) -> None:
        if self.candidates < 1 or self.turn_cost_m_per_rad < 0 or self.switch_margin_m < 0:
            raise ValueError(
                "tour: candidates >= 1, turn_cost_m_per_rad >= 0 and switch_margin_m >= 0"
            )


def leg_costs(
    pos: tuple[float, float] | FloatArray, heading_deg: float, pts: FloatArray, turn_cost: float
) -> FloatArray:
    """Cost of driving from the pose to each point: distance + turn_cost x |bearing|."""
    local = field_to_robot(pts, pos, heading_deg)
    bearing = np.abs(np.arctan2(local[:, 0], local[:, 1]))
    return np.hypot(local[:, 0], local[:, 1]) + turn_cost * bearing


def tour(
    pos: tuple[float, float] | FloatArray,
    heading_deg: float,
    pts: FloatArray,
    stops: int,
    config: TourConfig | None = None,
    current: int | None = None,
) -> list[int]:
    """Indices into `pts` of the chosen tour's stops, first stop first (empty when no points).

    `stops` caps the tour's length (the planner: the room left in its intake); `current` is the
    index of the target the robot is already driving to, or None."""
    c = config or TourConfig()
    pts = np.asarray(pts, dtype=np.float64).reshape(-1, 2)
    if len(pts) == 0 or stops < 1:
        return []
    cost = leg_costs(pos, heading_deg, pts, c.turn_cost_m_per_rad)
    cand = np.argsort(cost, kind="stable")[: c.candidates]
    stops = min(stops, len(cand))
    sub = pts[cand]
    # Plain lists from here: the loops below index single numbers, which lists do several times
    # faster than numpy arrays (the same float64 values, so the same tours).
    pair = np.linalg.norm(sub[:, None, :] - sub[None, :, :], axis=2).tolist()
    start = cost[cand].tolist()
    best_cost, best = math.inf, [0]
    for first in range(len(cand)):
        total, order = _tour_from(first, start, pair, stops)
        if total < best_cost:
            best_cost, best = total, order
    if current is not None and current in cand and int(cand[best[0]]) != current:
        k = int(np.flatnonzero(cand == current)[0])
        total, order = _tour_from(k, start, pair, stops)
        if total <= best_cost + c.switch_margin_m:
            best = [k, *(j for j in best if j != k)]
    return [int(cand[j]) for j in best]


def _tour_from(
    first: int, start: list[float], pair: list[list[float]], stops: int
) -> tuple[float, list[int]]:
    order = [first]
    left = [j for j in range(len(pair)) if j != first]
    while left and len(order) < stops:
        row = pair[order[-1]]
        nxt = min(left, key=row.__getitem__)
        order.append(nxt)
        left.remove(nxt)
    order = two_opt(order, pair, fixed_first=True)
    return start[first] + sum(pair[a][b] for a, b in itertools.pairwise(order)), order


def two_opt(
    order: list[int], pair: FloatArray | list[list[float]], fixed_first: bool = False
) -> list[int]:
    """Reverse sub-paths of an open tour while that shortens it (the start leg is not counted,
    so the first stop is free to change unless fixed_first). `pair`: the distances between the
    points, as an array or as nested lists."""
    if isinstance(pair, np.ndarray):
        pair = pair.tolist()
    best = list(order)
    n = len(best)
    lo = 1 if fixed_first else 0
    improved = True
    while improved:
        improved = False
        for i in range(lo, n - 1):
            a = best[i - 1] if i > 0 else None
            row_a = pair[a] if a is not None else None
            for k in range(i + 1, n):
                b, cpt = best[i], best[k]
                d = best[k + 1] if k + 1 < n else None
                # The two legs the reversal replaces and the two it makes (a missing end: none).
                before = row_a[b] if row_a is not None else 0.0
                after = row_a[cpt] if row_a is not None else 0.0
                if d is not None:
                    before += pair[cpt][d]
                    after += pair[b][d]
                if after < before - 1e-9:
                    best[i : k + 1] = reversed(best[i : k + 1])
                    improved = True
    return best
