"""The reward's shaping potentials as array functions: one match (MatchCore) or thousands at once
(sim.fast), from the same definitions.

Each takes arrays whose first axis is the match (B) and second the robot (R) and returns the
potential of every robot, (B, R), in metres; sim.config.RewardConfig says what each shaping
pays (weight x the potential's fall over a step).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

F64 = NDArray[np.float64]
Bool = NDArray[np.bool_]


def ring_potential(front: F64, room: NDArray[np.int64], ring_xy: F64, floor: Bool) -> F64:
    """Distance from each robot's front (front: (B, R, 2)) to the nearest ring on the floor
    (ring_xy (B, N, 2), floor (B, N)); 0 when its intake is full (room (B, R) <= 0) or no ring
    is left (the approach shaping)."""
    d2 = ((ring_xy[:, None, :, :] - front[:, :, None, :]) ** 2).sum(-1)  # (B, R, N)
    d2 = np.where(floor[:, None, :], d2, np.inf)
    best = d2.min(axis=-1) if d2.shape[-1] else np.full(front.shape[:2], np.inf)
    return np.where(
        (room > 0) & np.isfinite(best), np.sqrt(np.where(np.isfinite(best), best, 0.0)), 0.0
    )


def goal_potential(clamp_xy: F64, goal_xy: F64, eligible: Bool, holding: Bool) -> F64:
    """Distance from each robot's clamp point for each goal (clamp_xy (B, R, G, 2)) to that
    goal (goal_xy (B, G, 2)), the nearest of those it could score with that no robot holds
    (eligible (B, R, G)); 0 while it holds one (holding (B, R)) or none is free (the
    goal_approach shaping)."""
    d = np.hypot(
        clamp_xy[..., 0] - goal_xy[:, None, :, 0], clamp_xy[..., 1] - goal_xy[:, None, :, 1]
    )
    d = np.where(eligible, d, np.inf)
    best = d.min(axis=-1) if d.shape[-1] else np.full(holding.shape, np.inf)
    return np.where(holding | ~np.isfinite(best), 0.0, np.where(np.isfinite(best), best, 0.0))


def park_potential(xy: F64, centre: F64, half: F64, active: Bool) -> F64:
    """Distance from each robot (xy (B, R, 2)) to its platform (centre and half-sizes, shrunk
    by the park margin: (R, 2) or (B, R, 2)), where active (B, R): in the match's last
    park_from_s seconds and the robot has a platform; else 0 (the park shaping)."""
    dx = np.maximum(np.abs(xy[..., 0] - centre[..., 0]) - half[..., 0], 0.0)
    dy = np.maximum(np.abs(xy[..., 1] - centre[..., 1]) - half[..., 1], 0.0)
    return np.where(active, np.hypot(dx, dy), 0.0)
