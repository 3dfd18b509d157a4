"""Scripted robots: a greedy ring-chaser, the opponent a policy meets when none is trained yet.

It knows where every ring on the floor is (ground truth, not its camera), drives to the one that
is cheapest to reach (distance plus a turning penalty), backs off when stuck, and heads for its
alliance's home zone in the last seconds when carrying a goal. It is deliberately simple: the
planner that routes over known rings with pure pursuit is sim.baselines.planner.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np

from jetson.autonomy.skills import Trail
from sim.world.physics import World
from sim.world.state import RING_FLOOR, DriveCommand


@dataclass
class GreedyChaserConfig:
    turn_gain: float = 3.0  # rad/s of turn per rad of heading error
    turn_cost_m_per_rad: float = 0.25  # how much a needed turn adds to a ring's distance
    switch_margin_m: float = 0.15  # a new target must be this much cheaper to switch
    stuck_window_s: float = 1.5
    stuck_distance_m: float = 0.04
    backoff_s: float = 0.8
    home_time_left_s: float = 8.0  # head home this long before the end when carrying a goal
    give_up_s: float = 6.0  # drop a target not collected in this long, for as long again


class GreedyChaser:
    """Drives robot `index` of a World towards rings. Deterministic given the world."""

    def __init__(self, index: int, config: GreedyChaserConfig | None = None) -> None:
        self.index = index
        self.config = config or GreedyChaserConfig()
        self.reset()

    def reset(self) -> None:
        self._target: int | None = None
        self._trail = Trail(self.config.stuck_window_s, self.config.stuck_distance_m)
        self._backoff_until = -1.0
        self._backoff_dir = 1.0
        self._target_since = 0.0
        self._ignored: dict[int, float] = {}
        self._goal: int | None = None

    def act(self, world: World) -> DriveCommand:
        c = self.config
        r = world.robots[self.index]
        rc = r.config
        t = world.time_s
        self._trail.push(t, r.x, r.y)
        if t < self._backoff_until:
            return DriveCommand(
                -0.6 * rc.max_linear_mps, self._backoff_dir * 0.5 * rc.max_angular_rad_s
            )
        goal_xy = self._destination(world)
        if goal_xy is None:
            return DriveCommand(0.0, 0.0)
        dx, dy = goal_xy[0] - r.x, goal_xy[1] - r.y
        h = math.radians(r.heading)
        if self._goal is not None and r.carried_goal is None and r.room <= 0:
            # Reverse onto the goal: steer the robot's back at it.
            back = math.atan2(
                -(dx * math.cos(h) - dy * math.sin(h)), -(dx * math.sin(h) + dy * math.cos(h))
            )
            w = max(-rc.max_angular_rad_s, min(rc.max_angular_rad_s, c.turn_gain * back))
            v = -0.6 * rc.max_linear_mps * max(0.0, math.cos(back)) ** 3
            if self._trail.stuck(t, abs(v)):
                self._backoff_until = t + c.backoff_s / 2
                self._backoff_dir = 1.0
                self._trail.clear()
            return DriveCommand(v, w)
        self._goal = None
        # Heading error: positive when the target is to the right, i.e. a clockwise turn.
        err = math.atan2(dx * math.cos(h) - dy * math.sin(h), dx * math.sin(h) + dy * math.cos(h))
        w = max(-rc.max_angular_rad_s, min(rc.max_angular_rad_s, c.turn_gain * err))
        v = rc.max_linear_mps * max(0.0, math.cos(err)) ** 3
        if abs(err) > math.radians(60) and math.hypot(dx, dy) < rc.length_m:
            # The target is beside or under the robot, where turning in place never brings it
            # in front of the intake: back away while turning.
            v = -0.4 * rc.max_linear_mps
        if t - self._target_since > c.give_up_s:
            # Chasing one ring this long means it cannot be reached (wedged against a goal or
            # a wall): leave it for a while.
            if self._target is not None:
                self._ignored[self._target] = t + c.give_up_s
            self._target = None
            self._target_since = t
        if self._trail.stuck(t, v):
            self._backoff_until = t + c.backoff_s
            self._backoff_dir = -1.0 if err > 0 else 1.0
            self._target = None
            self._trail.clear()
        return DriveCommand(v, w)

    def _fetch_goal(self, world: World) -> tuple[float, float] | None:
        """A point in front of the nearest free goal of ours (or a neutral one): from there the
        robot backs onto it (act() reverses when the goal is behind and close)."""
        r = world.robots[self.index]
        best, best_d = None, math.inf
        for g in world.goals:
            if g.carried_by is not None or g.spec.alliance not in (None, r.alliance):
                continue
            d = math.hypot(g.x - r.x, g.y - r.y)
            if d < best_d:
                best, best_d = g, d
        if best is None:
            return None
        self._goal = best.index
        return (best.x, best.y)

    def _destination(self, world: World) -> tuple[float, float] | None:
        c = self.config
        r = world.robots[self.index]
        time_left = world.match_length_s - world.time_s
        if r.carried_goal is not None and time_left < c.home_time_left_s:
            zone = world.field.home_zones[r.alliance]
            return ((zone.x0 + zone.x1) / 2, (zone.y0 + zone.y1) / 2)
        if r.room <= 0:
            if r.carried_goal is None and self._fetch_goal(world) is not None:
                return self._fetch_goal(world)
            zone = world.field.home_zones[r.alliance]
            return ((zone.x0 + zone.x1) / 2, (zone.y0 + zone.y1) / 2)
        floor = np.flatnonzero(world.ring_state == RING_FLOOR)
        now = world.time_s
        if self._ignored:
            self._ignored = {i: until for i, until in self._ignored.items() if until > now}
            keep = [i for i in floor if int(i) not in self._ignored]
            floor = np.asarray(keep if keep else floor, dtype=np.int64)
        if len(floor) == 0:
            return None
        d = world.ring_xy[floor] - (r.x, r.y)
        dist = np.hypot(d[:, 0], d[:, 1])
        h = math.radians(r.heading)
        fwd = d[:, 0] * math.sin(h) + d[:, 1] * math.cos(h)
        right = d[:, 0] * math.cos(h) - d[:, 1] * math.sin(h)
        cost = dist + c.turn_cost_m_per_rad * np.abs(np.arctan2(right, fwd))
        best = int(np.argmin(cost))
        if self._target is not None and self._target in floor:
            k = int(np.flatnonzero(floor == self._target)[0])
            if cost[k] <= cost[best] + c.switch_margin_m:
                best = k
        if self._target != int(floor[best]):
            self._target = int(floor[best])
            self._target_since = now
        return (float(world.ring_xy[self._target, 0]), float(world.ring_xy[self._target, 1]))
