"""The traditional baseline: drive to rings in a good order with a pure-pursuit controller.

This is what the original report recommends instead of learning: keep a map of the rings the
robot knows about, pick an order to collect them in, and follow the path with pure pursuit.

Knowledge (what a real robot has): its GPS pose and the rings its camera sees right now, both via
MatchCore.view (the same sensors the learned policy gets, without the observation noise). With
`prior` the map starts from the field file's starting layout, as a team's autonomous routine
would; a remembered ring is forgotten once the camera looks at its place and finds nothing, and a
seen ring updates the remembered one nearby.

Order (`strategy`):
  nearest  the ring with the lowest distance + turning cost, with hysteresis;
  route    a tour heuristic over the known rings: for each of the `route_rings` cheapest
           candidates as the first stop, a nearest-neighbour tour through the rest, improved by
           2-opt, as long as the robot has room; the cheapest tour's first ring is the target
           (jetson/autonomy/route.py, which also gives the observation's route slots).

Control: pure pursuit (Coulter 1992) along the polyline robot -> target -> next stop: the point
`lookahead_m` along the path gives the curvature 2 x / d^2 of the arc through it; speed drops
only where the turn-rate limit demands. Targets far off the nose are turned to in place, rings
beside the bumper (where no arc reaches) are backed away from, a robot that stops moving backs
off, and a ring chased too long is left for a while. With `endgame`, the robot drives onto its
alliance platform (robot elevated) when the time left is what it needs to get there, or when its
intake is full.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np

from jetson.autonomy.geometry import field_to_robot, robot_to_field
from jetson.autonomy.route import TourConfig, leg_costs, tour
from jetson.autonomy.skills import Trail, arc_through, back_onto, pursuit_point, turn_first
from sim.match import MatchCore
from sim.visibility import camera_pose, in_frustum
from sim.world.physics import World
from sim.world.state import DriveCommand

Strategy = Literal["nearest", "route"]


@dataclass(frozen=True)
class PlannerConfig:
    strategy: Strategy = "route"
    prior: bool = True  # start from the field file's ring layout
    route_rings: int = 6  # candidates the tour heuristic orders
    lookahead_m: float = 0.3
    max_speed: float = 1.0  # fraction of the robot's top speed
    turn_gain: float = 4.0  # rad/s per rad of heading error when turning in place
    turn_in_place_rad: float = 1.1  # targets further off the nose are turned to first
    turn_cost_m_per_rad: float = 0.15  # distance a needed turn is worth when ordering
    switch_margin_m: float = 0.1  # a new first stop must be this much cheaper to switch
    merge_radius_m: float = 0.12  # a seen ring this close to a remembered one is that ring
    forget_margin_m: float = 0.25  # forget unseen rings this far inside the camera's range
    stuck_window_s: float = 1.2
    stuck_distance_m: float = 0.04
    backoff_s: float = 0.6
    give_up_s: float = 5.0  # leave a ring chased this long, for as long again
    fetch_goal: bool = True  # when the intake is full, back onto a goal so rings score
    endgame: bool = True
    endgame_margin_s: float = 2.5
    endgame_speed_fraction: float = 0.7  # average speed assumed when timing the drive home

    def __post_init__(self) -> None:
        if self.strategy not in ("nearest", "route"):
            raise ValueError(f"planner strategy must be 'nearest' or 'route': {self.strategy!r}")
        if self.route_rings < 1 or self.lookahead_m <= 0 or not 0 < self.max_speed <= 1:
            raise ValueError("planner: route_rings >= 1, lookahead_m > 0, max_speed in (0, 1]")


class Planner:
    """Drives one robot; create one per robot and call reset() at the start of every match."""

    def __init__(self, config: PlannerConfig | None = None) -> None:
        self.config = config or PlannerConfig()
        self.name = f"planner-{self.config.strategy}"
        self._tour = TourConfig(
            self.config.route_rings, self.config.turn_cost_m_per_rad, self.config.switch_margin_m
        )
        self.known = np.zeros((0, 2))
        self._ignored_until = np.zeros(0)
        self._target: np.ndarray | None = None
        self._target_since = 0.0
        self._trail = Trail(self.config.stuck_window_s, self.config.stuck_distance_m)
        self._backoff_until = -1.0
        self._backoff_turn = 1.0
        self._parked = False
        # What the last act() was doing, field frame: ("ring" | "goal" | "home", point) or
        # ("other", None) (backing off, searching). A skill policy's teacher reads it.
        self.intent: tuple[str, np.ndarray | None] = ("other", None)

    # --- the Player interface ----------------------------------------------------------------

    def reset(self, core: MatchCore, index: int, rng: np.random.Generator | None = None) -> None:
        world = core.world
        self.known = world.field.ring_positions.copy() if self.config.prior else np.zeros((0, 2))
        self._ignored_until = np.full(len(self.known), -1.0)
        self._target = None
        self._target_since = 0.0
        self._trail.clear()
        self._backoff_until = -1.0
        self._parked = False
        self.intent = ("other", None)

    def act(self, core: MatchCore, index: int, obs: np.ndarray | None = None) -> DriveCommand:
        view = core.view(index)
        world = core.world
        robot = world.robots[index]
        pose = (view.x, view.y, view.heading_deg)
        self._update_map(world, index, pose, view.rings_robot_xy)
        return self._drive(world, index, pose, robot.room)

    # --- the map ------------------------------------------------------------------------------

    def _update_map(
        self,
        world: World,
        index: int,
        pose: tuple[float, float, float],
        rings_robot_xy: np.ndarray,
    ) -> None:
        c = self.config
        x, y, h = pose
        seen = robot_to_field(np.asarray(rings_robot_xy).reshape(-1, 2), (x, y), h)
        known, until = self.known, self._ignored_until
        if len(known):
            cam = world.robots[index].config.camera
            z = np.full((len(known), 1), world.field.ring.thickness / 2)
            in_view, _, pc = in_frustum(np.hstack([known, z]), camera_pose((x, y), h, cam), cam)
            # Only well inside the range: at its edge a ring may flicker in and out of view.
            in_view &= np.linalg.norm(pc, axis=1) < cam.max_range_m - c.forget_margin_m
            matched = np.zeros(len(known), dtype=bool)
            if len(seen):
                d = np.linalg.norm(known[:, None, :] - seen[None, :, :], axis=2)
                matched = d.min(axis=1) <= c.merge_radius_m
            # A ring in the intake's path is being (or was just) collected.
            local = field_to_robot(known, (x, y), h)
            rc = world.robots[index].config
            front = rc.length_m / 2
            eaten = (np.abs(local[:, 0]) < rc.intake_width_m / 2) & (
                (local[:, 1] > front - 0.1) & (local[:, 1] < front + 0.06)
            )
            keep = ~((in_view & ~matched) | eaten)
            known, until = known[keep], until[keep]
        if len(seen):
            if len(known):
                d = np.linalg.norm(seen[:, None, :] - known[None, :, :], axis=2)
                nearest = d.argmin(axis=1)
                close = d[np.arange(len(seen)), nearest] <= c.merge_radius_m
                known = known.copy()
                known[nearest[close]] = seen[close]
                new = seen[~close]
            else:
                new = seen
            known = np.vstack([known, new])
            until = np.concatenate([until, np.full(len(new), -1.0)])
        self.known, self._ignored_until = known, until

    # --- ordering -----------------------------------------------------------------------------

    def _choose(
        self, pose: tuple[float, float, float], room: int, now: float
    ) -> tuple[np.ndarray, np.ndarray | None] | None:
        """(target, the stop after it or None), or None when no ring is known."""
        c = self.config
        free = np.flatnonzero(self._ignored_until <= now)
        if len(free) == 0:
            free = np.arange(len(self.known))
        if len(free) == 0:
            return None
        pts = self.known[free]
        cost = leg_costs(pose[:2], pose[2], pts, c.turn_cost_m_per_rad)
        current = None
        if self._target is not None:
            d = np.linalg.norm(pts - self._target, axis=1)
            if d.min() <= c.merge_radius_m:
                current = int(d.argmin())
        if c.strategy == "nearest" or room <= 1 or len(pts) == 1:
            best = int(cost.argmin())
            if current is not None and cost[current] <= cost[best] + c.switch_margin_m:
                best = current
            rest = np.delete(np.arange(len(pts)), best)
            after = None
            if len(rest) and room > 1:
                nxt = rest[np.linalg.norm(pts[rest] - pts[best], axis=1).argmin()]
                after = pts[nxt]
            return pts[best], after
        order = tour(pose[:2], pose[2], pts, room, self._tour, current)
        target = pts[order[0]]
        after = pts[order[1]] if len(order) > 1 else None
        return target, after

    # --- driving ------------------------------------------------------------------------------

    def _drive(
        self, world: World, index: int, pose: tuple[float, float, float], room: int
    ) -> DriveCommand:
        c = self.config
        robot = world.robots[index]
        rc = robot.config
        now = world.time_s
        x, y, _h = pose
        self._trail.push(now, x, y)
        self.intent = ("other", None)
        if now < self._backoff_until:
            return DriveCommand(
                -0.6 * rc.max_linear_mps, self._backoff_turn * 0.5 * rc.max_angular_rad_s
            )

        if c.fetch_goal and robot.carried_goal is None and room <= 0 and not self._parked:
            goal = self._free_goal(world, index, pose)
            if goal is not None:
                self.intent = ("goal", goal)
                return self._reverse_onto(world, index, pose, goal, now)

        if c.endgame and self._go_home(world, index, pose, room):
            plat = world.field.platform(robot.alliance)
            cx, cy = plat.center
            self.intent = ("home", np.array([cx, cy]))
            # Aim for the platform's middle; stop once well on it.
            inner = abs(x - cx) < plat.size[0] / 2 - 0.2 and abs(y - cy) < plat.size[1] / 2 - 0.2
            if inner or self._parked:
                self._parked = True
                return DriveCommand(0.0, 0.0)
            return self._pursue(world, index, pose, np.array([cx, cy]), None, now)

        choice = self._choose(pose, room, now)
        if choice is None:
            # Nothing left that we know of: wait on the platform, looking around on the way.
            if c.endgame:
                plat = world.field.platform(robot.alliance)
                if plat.contains_point(x, y):
                    return DriveCommand(0.0, 0.3 * rc.max_angular_rad_s)
                return self._pursue(world, index, pose, np.array(plat.center), None, now)
            return DriveCommand(0.0, 0.4 * rc.max_angular_rad_s)
        target, after = choice
        if self._target is None or np.linalg.norm(target - self._target) > c.merge_radius_m:
            self._target_since = now
        self._target = target
        if now - self._target_since > c.give_up_s:
            self._ignore(target, now + c.give_up_s)
            self._target = None
        self.intent = ("ring", target)
        return self._pursue(world, index, pose, target, after, now)

    def _free_goal(
        self, world: World, index: int, pose: tuple[float, float, float]
    ) -> np.ndarray | None:
        """The nearest goal nobody carries that scores for us: our alliance's first (its rings
        count wherever it is), else a neutral one."""
        robot = world.robots[index]
        best, best_key = None, (2, math.inf)
        for g in world.goals:
            if g.carried_by is not None or g.spec.alliance not in (None, robot.alliance):
                continue
            key = (
                0 if g.spec.alliance == robot.alliance else 1,
                math.hypot(g.x - pose[0], g.y - pose[1]),
            )
            if key < best_key:
                best, best_key = np.array([g.x, g.y]), key
        return best

    def _reverse_onto(
        self,
        world: World,
        index: int,
        pose: tuple[float, float, float],
        goal: np.ndarray,
        now: float,
    ) -> DriveCommand:
        """Drive near the goal, then turn the back to it and reverse until the clamp takes it."""
        rc = world.robots[index].config
        x, y, h = pose
        dist = math.hypot(goal[0] - x, goal[1] - y)
        if dist > 1.0:
            stage = goal + 0.5 * (np.array([x, y]) - goal) / dist
            return self._pursue(world, index, pose, stage, None, now)
        gx, gy = field_to_robot(goal[None, :], (x, y), h)[0]
        v, w = back_onto(
            float(gx), float(gy), rc.max_linear_mps, rc.max_angular_rad_s, self.config.turn_gain
        )
        if self._trail.stuck(now, abs(v)):
            self._backoff_until = now + self.config.backoff_s / 2
            self._backoff_turn = 1.0
            self._trail.clear()
            # Forward, not backward, to get clear of whatever blocks the reverse.
            return DriveCommand(0.5 * rc.max_linear_mps, 0.0)
        return DriveCommand(v, w)

    def _go_home(
        self, world: World, index: int, pose: tuple[float, float, float], room: int
    ) -> bool:
        if self._parked:
            return True
        c = self.config
        robot = world.robots[index]
        plat = world.field.platform(robot.alliance)
        dist = math.hypot(pose[0] - plat.center[0], pose[1] - plat.center[1])
        speed = c.endgame_speed_fraction * robot.config.max_linear_mps
        time_left = world.match_length_s - world.time_s
        full = room <= 0 and (robot.carried_goal is None or not c.fetch_goal)
        return full or time_left <= dist / speed + c.endgame_margin_s

    def _ignore(self, point: np.ndarray, until: float) -> None:
        if len(self.known):
            d = np.linalg.norm(self.known - point, axis=1)
            self._ignored_until[d <= self.config.merge_radius_m] = until

    def _pursue(
        self,
        world: World,
        index: int,
        pose: tuple[float, float, float],
        target: np.ndarray,
        after: np.ndarray | None,
        now: float,
    ) -> DriveCommand:
        c = self.config
        rc = world.robots[index].config
        x, y, h = pose
        path = [target] if after is None else [target, after]
        local = field_to_robot(np.array(path), (x, y), h)
        tx, ty = local[0]
        bearing = math.atan2(tx, ty)  # positive: to the right, a clockwise turn
        v_max = c.max_speed * rc.max_linear_mps
        w_max = rc.max_angular_rad_s
        turn = turn_first(
            float(tx), float(ty), rc.max_linear_mps, w_max, c.turn_gain, c.turn_in_place_rad,
            rc.length_m,
        )  # fmt: skip
        if turn is not None:
            return DriveCommand(*turn)
        px, py = pursuit_point(local, c.lookahead_m)
        v, w = arc_through(px, py, v_max, w_max)
        if self._trail.stuck(now, v):
            self._backoff_until = now + c.backoff_s
            self._backoff_turn = -1.0 if bearing > 0 else 1.0
            self._ignore(target, now + c.give_up_s)
            self._target = None
            self._trail.clear()
        return DriveCommand(v, w)
