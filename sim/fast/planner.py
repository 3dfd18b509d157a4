"""The planner (sim.baselines.planner.Planner) driving one robot of every match of a FastWorld.

    planner = FastPlanner(world)                    # PlannerConfig() unless given one
    planner.reset(rows, robot, config)              # matches `rows` start: robot robot[j] of each
    plan = planner.act(active, observer.seen_pose, observer.seen_rings)
    plan.linear, plan.angular                       # (B,): the DriveCommand of each active row
    plan.intent_of(k)                               # Planner.intent of match k

Planner keeps one robot's map of the rings (the field's layout, then what its camera shows it),
chooses a ring with hysteresis (nearest, or the first stop of route.tour), gives a ring up
after chasing it too long, backs off when stuck, backs onto a goal when its intake is full,
drives home for the endgame and pursues its target with jetson.autonomy.skills' pure pursuit:
one Python call per robot and step. This is the same planner for one robot of every match at
once, compiled (numba): the same state (the map, each ring's ignore time, the target and the
time it was chosen, the trail of GPS positions, the back-off, parked) and the same arithmetic,
fed what Planner reads through MatchCore.view (sim.fast.players.FastCore shows a fast match as
MatchCore does): the GPS reading and the floor rings the FastObserver built the frame from, the
world's robots, goals and clock. The tour is sim.fast.memory's compiled route.tour; skills'
turn_first, arc_through, pursuit_point and back_onto are compiled here and held to the originals
by tests/sim/fast/test_planner.py, which also holds the whole planner to Planner command for
command. Rows share one PlannerConfig except `endgame`, set per match (the teacher parks only
where parking pays: sim.training.rollout.teacher_for).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, replace

import numba as nb
import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import robot_to_camera_rotation
from sim.baselines.planner import PlannerConfig
from sim.fast.kernels import threads_for
from sim.fast.memory import compiled_tour, near_any, place_seen
from sim.fast.world import FastWorld

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
Bool = NDArray[np.bool_]

INTENTS = ("other", "ring", "goal", "home")  # Planner.intent's kinds, by PlannerCommands.intent
_OTHER, _RING, _GOAL, _HOME = 0, 1, 2, 3
_UNLIMITED = 1 << 30  # RobotState.room of an intake that never fills

# Columns of FastPlanner's per-row state (st).
_TX, _TY, _HAS_TARGET, _SINCE, _BACKOFF_UNTIL, _BACKOFF_TURN, _PARKED = range(7)
# Columns of the configuration vector (cfg): PlannerConfig's numbers.
(_ROUTE, _ROUTE_RINGS, _LOOKAHEAD, _MAX_SPEED, _TURN_GAIN, _TURN_IN_PLACE, _TURN_COST,
 _SWITCH, _MERGE, _FORGET, _WINDOW, _STUCK_M, _BACKOFF, _GIVE_UP, _FETCH, _END_MARGIN,
 _END_SPEED) = range(17)  # fmt: skip
# Columns of the robots' rows: the drive, the intake, the alliance, the camera (sim.visibility's
# camera_pose and in_frustum: mount, robot_to_camera_rotation row by row, intrinsics, range).
(_MAX_V, _MAX_W, _LENGTH, _INTAKE_W, _BLUE, _CAM_FWD, _CAM_RIGHT, _CAM_H, _ROT, _FX, _FY, _CX,
 _CY, _WIDTH, _HEIGHT, _NEAR, _RANGE) = (*range(8), 8, *range(17, 25))  # fmt: skip


@dataclass
class PlannerCommands:
    """What the planner does in each match this step (rows not active: zeros, intent other)."""

    linear: F64  # (B,) m/s
    angular: F64  # (B,) rad/s, clockwise
    intent: I64  # (B,) index into INTENTS
    point: F64  # (B, 2) the intent's point, field frame (NaN for "other")

    def intent_of(self, k: int) -> tuple[str, NDArray[np.float64] | None]:
        """Planner.intent of match k: (kind, point) or ("other", None)."""
        kind = INTENTS[int(self.intent[k])]
        return (kind, None) if kind == "other" else (kind, self.point[k].copy())


class FastPlanner:
    """Planner for one robot of every match of a FastWorld (module docstring)."""

    def __init__(self, world: FastWorld, config: PlannerConfig | None = None) -> None:
        self.world = world
        self.config = config or PlannerConfig()
        c = self.config
        self._cfg = np.array(
            [
                float(c.strategy == "route"), c.route_rings, c.lookahead_m, c.max_speed,
                c.turn_gain, c.turn_in_place_rad, c.turn_cost_m_per_rad, c.switch_margin_m,
                c.merge_radius_m, c.forget_margin_m, c.stuck_window_s, c.stuck_distance_m,
                c.backoff_s, c.give_up_s, float(c.fetch_goal), c.endgame_margin_s,
                c.endgame_speed_fraction,
            ],
            dtype=np.float64,
        )  # fmt: skip
        self._tour_cfg = np.array([c.route_rings, c.turn_cost_m_per_rad, c.switch_margin_m])
        self._robots = np.array([_robot_row(world, i) for i in range(world.n_robots)])
        field = world.field
        self._platforms = np.array(
            [[*field.platform(a).center, *field.platform(a).size] for a in ("red", "blue")],
            dtype=np.float64,
        )
        self._goal_side = np.array(
            [-1 if g.alliance is None else int(g.alliance == "blue") for g in field.goals],
            dtype=np.int64,
        ).reshape(-1)
        self._ring_z = field.ring.thickness / 2
        self._prior = field.ring_positions.copy() if c.prior else np.zeros((0, 2))
        n, n_ring = world.n, world.ring_xy.shape[1]
        # Room for the layout and two sightings of every ring (as the ring memory keeps).
        cap = len(self._prior) + 2 * n_ring + 8
        self.known = np.zeros((n, cap, 2))
        self.until = np.full((n, cap), -1.0)  # each known ring is ignored until then
        self.count = np.zeros(n, dtype=np.int64)
        # The trail (Trail): (time, x, y) rows, oldest first; a window's worth and some.
        rows = math.ceil(c.stuck_window_s / world.dt) + 8
        self.trail = np.zeros((n, rows, 3))
        self.trail_n = np.zeros(n, dtype=np.int64)
        self.state = np.zeros((n, 7))
        self.robot = np.zeros(n, dtype=np.int64)
        self.endgame = np.zeros(n, dtype=np.bool_)
        self.overflow = np.zeros(n, dtype=np.int64)  # map rows or trail rows dropped for room

    def reset(self, rows: I64, robot: I64, config: PlannerConfig | None = None) -> None:
        """Matches `rows` start, the planner driving robot robot[j] of match rows[j] (Planner.
        reset), with `config` (this planner's, or one that differs from it only in endgame)."""
        cfg = config or self.config
        if replace(cfg, endgame=self.config.endgame) != self.config:
            raise ValueError("FastPlanner: rows differ from its config only in endgame")
        rows = np.asarray(rows, dtype=np.int64)
        p = len(self._prior)
        self.known[rows, :p] = self._prior
        self.until[rows] = -1.0
        self.count[rows] = p
        self.trail_n[rows] = 0
        self.state[rows] = 0.0
        self.state[rows, _BACKOFF_UNTIL] = -1.0
        self.state[rows, _BACKOFF_TURN] = 1.0
        self.robot[rows] = robot
        self.endgame[rows] = cfg.endgame
        self.overflow[rows] = 0

    def act(self, active: Bool, pose: F64, seen: Bool) -> PlannerCommands:
        """Planner.act for the rows where `active` (B,): pose (B, R, 3) every robot's GPS
        reading this step, seen (B, R, N) the floor rings each robot's camera saw."""
        w = self.world
        # RobotState.room as match_view's robots have it: an uncapped match's never fills.
        unlimited = (w.room_cap != w.capacity) | (w.capacity >= _UNLIMITED)
        room = np.where(unlimited, _UNLIMITED, np.maximum(0, w.room_cap - w.held))
        with threads_for(w.n):
            lin, ang, intent, point = _plan(
                np.asarray(active, dtype=np.bool_), self.robot, self.endgame, self.known,
                self.until, self.count, self.trail, self.trail_n, self.state, self.overflow,
                w.x, w.y, w.heading, np.asarray(pose, dtype=np.float64), w.ring_xy,
                np.asarray(seen, dtype=np.bool_), room.astype(np.int64), w.carried, w.carrier,
                w.gx, w.gy, w.time_s, w.match_length_s, self._robots, self._goal_side,
                self._platforms, self._ring_z, self._cfg, self._tour_cfg,
            )  # fmt: skip
        return PlannerCommands(lin, ang, intent, point)


def _robot_row(world: FastWorld, i: int) -> list[float]:
    """Robot i as _plan reads it (the column constants above)."""
    rc = world.robot_configs[i]
    cam = rc.camera
    rot = robot_to_camera_rotation(cam.tilt_deg).reshape(-1).tolist()
    return [
        rc.max_linear_mps, rc.max_angular_rad_s, rc.length_m, rc.intake_width_m,
        float(world.alliances[i] == "blue"), cam.forward_m, cam.right_m, cam.height_m, *rot,
        cam.fx, cam.fy, cam.cx, cam.cy, float(cam.width), float(cam.height), cam.near_m,
        cam.max_range_m,
    ]  # fmt: skip


# --- jetson.autonomy.skills' controller, compiled ------------------------------------------------


@nb.njit(cache=True)
def turn_first(tx, ty, max_linear_mps, max_angular_rad_s, turn_gain, turn_in_place_rad, length):
    """skills.turn_first: (True, v, w) for a target no arc reaches yet, (False, 0, 0) when an
    arc will do."""
    bearing = math.atan2(tx, ty)
    if abs(bearing) > math.radians(60) and math.hypot(tx, ty) < length * 0.9:
        return True, -0.4 * max_linear_mps, math.copysign(0.6 * max_angular_rad_s, bearing)
    if abs(bearing) > turn_in_place_rad:
        w = min(max(turn_gain * bearing, -max_angular_rad_s), max_angular_rad_s)
        return True, 0.0, w
    return False, 0.0, 0.0


@nb.njit(cache=True)
def arc_through(px, py, speed, max_angular_rad_s):
    """skills.arc_through: pure pursuit's (v, w) through the lookahead point."""
    d2 = px * px + py * py
    curvature = 2.0 * px / d2 if d2 > 1e-9 else 0.0
    v = speed
    if abs(curvature) * v > max_angular_rad_s:
        v = max_angular_rad_s / abs(curvature)
    return v, v * curvature


@nb.njit(cache=True)
def pursuit_point(path, lookahead):
    """skills.pursuit_point: where the polyline origin -> path[0] -> path[1] ... (m, 2), robot
    frame, first leaves the circle of radius `lookahead`; its end when it never does."""
    prev0, prev1 = 0.0, 0.0
    for j in range(path.shape[0]):
        q0, q1 = path[j, 0], path[j, 1]
        if math.hypot(q0, q1) >= lookahead:
            d0, d1 = q0 - prev0, q1 - prev1
            a = d0 * d0 + d1 * d1
            b = 2.0 * (prev0 * d0 + prev1 * d1)
            cc = (prev0 * prev0 + prev1 * prev1) - lookahead * lookahead
            disc = b * b - 4 * a * cc
            if a > 1e-12 and disc >= 0:
                t = (-b + math.sqrt(disc)) / (2 * a)
                t = min(max(t, 0.0), 1.0)
                return prev0 + t * d0, prev1 + t * d1
            return q0, q1
        prev0, prev1 = q0, q1
    return prev0, prev1


@nb.njit(cache=True)
def back_onto(gx, gy, max_linear_mps, max_angular_rad_s, turn_gain):
    """skills.back_onto: (v, w) that turns the back to a goal (robot frame) and reverses."""
    back = math.atan2(-gx, -gy)
    w = min(max(turn_gain * back, -max_angular_rad_s), max_angular_rad_s)
    return -0.7 * max_linear_mps * math.pow(max(0.0, math.cos(back)), 3.0), w


# --- the trail (skills.Trail) ------------------------------------------------------------------


@nb.njit(cache=True)
def trail_push(trail, trail_n, overflow, b, now, x, y, window):
    """Trail.push: append (now, x, y), drop the rows older than the window."""
    n = trail_n[b]
    if n == trail.shape[1]:  # no room: the oldest goes (counted; a window never fills it)
        trail[b, : n - 1] = trail[b, 1:n].copy()
        n -= 1
        overflow[b] += 1
    trail[b, n, 0] = now
    trail[b, n, 1] = x
    trail[b, n, 2] = y
    n += 1
    drop = 0
    while drop < n and trail[b, drop, 0] < now - window:
        drop += 1
    if drop:
        trail[b, : n - drop] = trail[b, drop:n].copy()
    trail_n[b] = n - drop


@nb.njit(cache=True)
def trail_stuck(trail, trail_n, b, now, speed, window, min_distance):
    """Trail.stuck: commanded to drive (speed >= 0.2) for a whole window without moving."""
    n = trail_n[b]
    if speed < 0.2 or n < 2 or now - trail[b, 0, 0] < window * 0.95:
        return False
    return math.hypot(trail[b, n - 1, 1] - trail[b, 0, 1], trail[b, n - 1, 2] - trail[b, 0, 2]) < (
        min_distance
    )


# --- the planner, one row ----------------------------------------------------------------------


@nb.njit(cache=True, parallel=True)
def _plan(
    active, robot, endgame, known, until, count, trail, trail_n, st, overflow, x, y, heading,
    gps, ring_xy, seen, room, carried, carrier, gx, gy, time_s, match_length, robots, goal_side,
    platforms, ring_z, cfg, tour_cfg,
):  # fmt: skip
    """Planner.act for robot robot[b] of every active match b: (linear, angular, intent,
    intent point), the planners' state updated in place."""
    n_match = active.shape[0]
    lin = np.zeros(n_match)
    ang = np.zeros(n_match)
    intent = np.zeros(n_match, dtype=np.int64)
    point = np.full((n_match, 2), np.nan)
    for b in nb.prange(n_match):
        if not active[b]:
            continue
        i = robot[b]
        px, py, ph = gps[b, i, 0], gps[b, i, 1], gps[b, i, 2]
        _update_map(
            b, i, px, py, ph, known, until, count, overflow, x, y, heading, ring_xy, seen,
            robots, ring_z, cfg,
        )  # fmt: skip
        v, w, kind, qx, qy = _drive(
            b, i, px, py, ph, known, until, count, trail, trail_n, st, overflow, room[b, i],
            carried[b, i], carrier, gx, gy, time_s[b], match_length, robots, goal_side,
            platforms, endgame[b], cfg, tour_cfg,
        )  # fmt: skip
        lin[b], ang[b], intent[b] = v, w, kind
        if kind != _OTHER:
            point[b, 0], point[b, 1] = qx, qy
    return lin, ang, intent, point


@nb.njit(cache=True)
def _in_view(rob, px, py, s, c, kx, ky, ring_z, forget_margin):
    """Planner._update_map's in_view for a ring at (kx, ky): inside the camera's picture
    (sim.visibility.in_frustum from camera_pose) and well inside its range."""
    cam_x = px + rob[_CAM_FWD] * s + rob[_CAM_RIGHT] * c
    cam_y = py + rob[_CAM_FWD] * c + rob[_CAM_RIGHT] * -s
    d0, d1, d2 = kx - cam_x, ky - cam_y, ring_z - rob[_CAM_H]
    # The camera's rotation: robot_to_camera_rotation @ (field -> robot: rows right, forward,
    # up), applied to the offset.
    o = np.empty(3)
    for j in range(3):
        p0, p1, p2 = rob[_ROT + 3 * j], rob[_ROT + 3 * j + 1], rob[_ROT + 3 * j + 2]
        r0 = p0 * c + p1 * s
        r1 = p0 * -s + p1 * c
        o[j] = d0 * r0 + d1 * r1 + d2 * p2
    if not o[2] > rob[_NEAR]:
        return False
    dist = math.sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2])
    u = rob[_FX] * o[0] / o[2] + rob[_CX]
    v = rob[_FY] * o[1] / o[2] + rob[_CY]
    inside = u >= 0 and u < rob[_WIDTH] and v >= 0 and v < rob[_HEIGHT]
    return inside and dist <= rob[_RANGE] and dist < rob[_RANGE] - forget_margin


@nb.njit(cache=True)
def _compact(known, until, b, k_n, gone):
    """Drop the known rings marked gone (and their ignore times), keeping the order."""
    m = 0
    for k in range(k_n):
        if not gone[k]:
            known[b, m, 0] = known[b, k, 0]
            known[b, m, 1] = known[b, k, 1]
            until[b, m] = until[b, k]
            m += 1
    return m


@nb.njit(cache=True)
def _update_map(
    b, i, px, py, ph, known, until, count, overflow, x, y, heading, ring_xy, seen, robots,
    ring_z, cfg,
):  # fmt: skip
    """Planner._update_map: forget the rings the camera looks at and misses and those in the
    intake's path, move the ones seen again, add the new ones."""
    rob = robots[i]
    merge = cfg[_MERGE]
    n_ring = ring_xy.shape[1]
    fs = np.empty((n_ring, 2))  # the rings seen, placed from the GPS pose
    h = math.radians(ph)
    s, c = math.sin(h), math.cos(h)
    ns = place_seen(b, i, x, y, heading, ring_xy, seen, px, py, s, c, np.empty((n_ring, 2)), fs)
    k_n = count[b]
    if k_n > 0:
        # The camera's pose from the GPS heading as numpy computes it (heading_vector).
        cs, cc = np.sin(np.radians(ph)), np.cos(np.radians(ph))
        front = rob[_LENGTH] / 2
        gone = np.empty(k_n, dtype=np.bool_)
        for k in range(k_n):
            kx, ky = known[b, k, 0], known[b, k, 1]
            in_view = _in_view(rob, px, py, cs, cc, kx, ky, ring_z, cfg[_FORGET])
            matched = near_any(kx, ky, fs, ns, merge)
            dx, dy = kx - px, ky - py
            lx = dx * c - dy * s
            ly = dx * s + dy * c
            eaten = abs(lx) < rob[_INTAKE_W] / 2 and ly > front - 0.1 and ly < front + 0.06
            gone[k] = (in_view and not matched) or eaten
        k_n = _compact(known, until, b, k_n, gone)
    if ns > 0:
        # Each sighting's nearest known ring (before any moves), then the moves, then the new.
        nearest = np.full(ns, -1, dtype=np.int64)
        for j in range(ns):
            best, best_d = -1, np.inf
            for k in range(k_n):
                ex, ey = fs[j, 0] - known[b, k, 0], fs[j, 1] - known[b, k, 1]
                d = math.sqrt(ex * ex + ey * ey)
                if d < best_d:
                    best, best_d = k, d
            if best >= 0 and best_d <= merge:
                nearest[j] = best
        for j in range(ns):
            if nearest[j] >= 0:
                known[b, nearest[j], 0] = fs[j, 0]
                known[b, nearest[j], 1] = fs[j, 1]
        for j in range(ns):
            if nearest[j] < 0:
                if k_n < known.shape[1]:
                    known[b, k_n, 0] = fs[j, 0]
                    known[b, k_n, 1] = fs[j, 1]
                    until[b, k_n] = -1.0
                    k_n += 1
                else:
                    overflow[b] += 1
    count[b] = k_n


@nb.njit(cache=True)
def _ignore(known, until, count, b, qx, qy, t, merge):
    """Planner._ignore: the known rings within the merge radius of (qx, qy) until t."""
    for k in range(count[b]):
        ex, ey = known[b, k, 0] - qx, known[b, k, 1] - qy
        if math.sqrt(ex * ex + ey * ey) <= merge:
            until[b, k] = t


@nb.njit(cache=True)
def to_robot(qx, qy, px, py, s, c):
    """geometry.field_to_robot of one point (s, c: the heading's sine and cosine)."""
    dx, dy = qx - px, qy - py
    return dx * c - dy * s, dx * s + dy * c


@nb.njit(cache=True)
def _pursue(
    b, px, py, s, c, tx, ty, has_after, ax, ay, now, known, until, count, trail, trail_n, st,
    rob, cfg,
):  # fmt: skip
    """Planner._pursue: turn first, or the pure-pursuit arc along target -> after; a robot
    stuck while driving backs off and leaves its target for a while."""
    path = np.empty((2 if has_after else 1, 2))
    path[0, 0], path[0, 1] = to_robot(tx, ty, px, py, s, c)
    if has_after:
        path[1, 0], path[1, 1] = to_robot(ax, ay, px, py, s, c)
    lx, ly = path[0, 0], path[0, 1]
    bearing = math.atan2(lx, ly)
    v_max = cfg[_MAX_SPEED] * rob[_MAX_V]
    w_max = rob[_MAX_W]
    turns, v, w = turn_first(
        lx, ly, rob[_MAX_V], w_max, cfg[_TURN_GAIN], cfg[_TURN_IN_PLACE], rob[_LENGTH]
    )
    if turns:
        return v, w
    qx, qy = pursuit_point(path, cfg[_LOOKAHEAD])
    v, w = arc_through(qx, qy, v_max, w_max)
    if trail_stuck(trail, trail_n, b, now, v, cfg[_WINDOW], cfg[_STUCK_M]):
        st[b, _BACKOFF_UNTIL] = now + cfg[_BACKOFF]
        st[b, _BACKOFF_TURN] = -1.0 if bearing > 0 else 1.0
        _ignore(known, until, count, b, tx, ty, now + cfg[_GIVE_UP], cfg[_MERGE])
        st[b, _HAS_TARGET] = 0.0
        trail_n[b] = 0
    return v, w


@nb.njit(cache=True)
def _free_goal(px, py, side, carrier, gx, gy, b, goal_side):
    """Planner._free_goal: the nearest goal nobody carries that scores for alliance `side`,
    its own first; (found, x, y)."""
    found, best_x, best_y = False, 0.0, 0.0
    best_rank, best_d = 2, np.inf
    for g in range(gx.shape[1]):
        if carrier[b, g] >= 0 or (goal_side[g] >= 0 and goal_side[g] != side):
            continue
        rank = 0 if goal_side[g] == side else 1
        d = math.hypot(gx[b, g] - px, gy[b, g] - py)
        if rank < best_rank or (rank == best_rank and d < best_d):
            found, best_x, best_y, best_rank, best_d = True, gx[b, g], gy[b, g], rank, d
    return found, best_x, best_y


@nb.njit(cache=True)
def _reverse_onto(
    b, px, py, s, c, goal_x, goal_y, now, known, until, count, trail, trail_n, st, rob, cfg
):  # fmt: skip
    """Planner._reverse_onto: drive near the goal, then back onto it; forward when stuck."""
    ex, ey = goal_x - px, goal_y - py
    dist = math.hypot(ex, ey)
    if dist > 1.0:
        sx = goal_x + 0.5 * (px - goal_x) / dist
        sy = goal_y + 0.5 * (py - goal_y) / dist
        return _pursue(
            b, px, py, s, c, sx, sy, False, 0.0, 0.0, now, known, until, count, trail, trail_n,
            st, rob, cfg,
        )  # fmt: skip
    lx, ly = to_robot(goal_x, goal_y, px, py, s, c)
    v, w = back_onto(lx, ly, rob[_MAX_V], rob[_MAX_W], cfg[_TURN_GAIN])
    if trail_stuck(trail, trail_n, b, now, abs(v), cfg[_WINDOW], cfg[_STUCK_M]):
        st[b, _BACKOFF_UNTIL] = now + cfg[_BACKOFF] / 2
        st[b, _BACKOFF_TURN] = 1.0
        trail_n[b] = 0
        return 0.5 * rob[_MAX_V], 0.0
    return v, w


@nb.njit(cache=True)
def _go_home(px, py, st, b, room, carried, now, match_length, plat, rob, cfg):
    """Planner._go_home: parked, full with nowhere to put the rings, or just time to get home."""
    if st[b, _PARKED] > 0.5:
        return True
    dist = math.hypot(px - plat[0], py - plat[1])
    speed = cfg[_END_SPEED] * rob[_MAX_V]
    time_left = match_length - now
    full = room <= 0 and (carried < 0 or not cfg[_FETCH] > 0.5)
    return full or time_left <= dist / speed + cfg[_END_MARGIN]


@nb.njit(cache=True)
def _choose(b, px, py, s, c, known, until, count, st, room, now, cfg, tour_cfg):
    """Planner._choose: (found, target x, y, has_after, after x, y)."""
    k_all = count[b]
    free = 0
    for k in range(k_all):
        if until[b, k] <= now:
            free += 1
    pts = np.empty((k_all if free == 0 else free, 2))
    m = 0
    for k in range(k_all):
        if free == 0 or until[b, k] <= now:
            pts[m, 0], pts[m, 1] = known[b, k, 0], known[b, k, 1]
            m += 1
    if m == 0:
        return False, 0.0, 0.0, False, 0.0, 0.0
    current = -1
    if st[b, _HAS_TARGET] > 0.5:
        best_d = np.inf
        for k in range(m):
            ex, ey = pts[k, 0] - st[b, _TX], pts[k, 1] - st[b, _TY]
            d = math.sqrt(ex * ex + ey * ey)
            if d < best_d:
                best_d, current = d, k
        if not best_d <= cfg[_MERGE]:
            current = -1
    if cfg[_ROUTE] < 0.5 or room <= 1 or m == 1:
        best = _nearest_choice(pts, m, px, py, s, c, current, cfg)
        nxt = -1
        if room > 1:
            best_d = np.inf
            for k in range(m):
                if k != best:
                    ex, ey = pts[k, 0] - pts[best, 0], pts[k, 1] - pts[best, 1]
                    d = math.sqrt(ex * ex + ey * ey)
                    if d < best_d:
                        best_d, nxt = d, k
        if nxt < 0:
            return True, pts[best, 0], pts[best, 1], False, 0.0, 0.0
        return True, pts[best, 0], pts[best, 1], True, pts[nxt, 0], pts[nxt, 1]
    order = compiled_tour(pts, m, px, py, s, c, room, tour_cfg, current)
    t = order[0]
    if len(order) > 1:
        return True, pts[t, 0], pts[t, 1], True, pts[order[1], 0], pts[order[1], 1]
    return True, pts[t, 0], pts[t, 1], False, 0.0, 0.0


@nb.njit(cache=True)
def _nearest_choice(pts, m, px, py, s, c, current, cfg):
    """The "nearest" strategy's pick: the cheapest leg (route.leg_costs), the current target
    kept unless another is cheaper by the switch margin."""
    cost = np.empty(m)
    for k in range(m):
        lx, ly = to_robot(pts[k, 0], pts[k, 1], px, py, s, c)
        cost[k] = math.hypot(lx, ly) + cfg[_TURN_COST] * abs(math.atan2(lx, ly))
    best = int(np.argmin(cost))
    if current >= 0 and cost[current] <= cost[best] + cfg[_SWITCH]:
        best = current
    return best


@nb.njit(cache=True)
def _drive(
    b, i, px, py, ph, known, until, count, trail, trail_n, st, overflow, room, carried, carrier,
    gx, gy, now, match_length, robots, goal_side, platforms, endgame, cfg, tour_cfg,
):  # fmt: skip
    """Planner._drive: (v, w, intent, intent x, y)."""
    rob = robots[i]
    h = math.radians(ph)
    s, c = math.sin(h), math.cos(h)
    trail_push(trail, trail_n, overflow, b, now, px, py, cfg[_WINDOW])
    if now < st[b, _BACKOFF_UNTIL]:
        return -0.6 * rob[_MAX_V], st[b, _BACKOFF_TURN] * 0.5 * rob[_MAX_W], _OTHER, 0.0, 0.0
    side = int(rob[_BLUE])
    if cfg[_FETCH] > 0.5 and carried < 0 and room <= 0 and not st[b, _PARKED] > 0.5:
        found, qx, qy = _free_goal(px, py, side, carrier, gx, gy, b, goal_side)
        if found:
            v, w = _reverse_onto(
                b, px, py, s, c, qx, qy, now, known, until, count, trail, trail_n, st, rob, cfg
            )
            return v, w, _GOAL, qx, qy
    plat = platforms[side]
    cx, cy = plat[0], plat[1]
    if endgame and _go_home(px, py, st, b, room, carried, now, match_length, plat, rob, cfg):
        inner = abs(px - cx) < plat[2] / 2 - 0.2 and abs(py - cy) < plat[3] / 2 - 0.2
        if inner or st[b, _PARKED] > 0.5:
            st[b, _PARKED] = 1.0
            return 0.0, 0.0, _HOME, cx, cy
        v, w = _pursue(
            b, px, py, s, c, cx, cy, False, 0.0, 0.0, now, known, until, count, trail, trail_n,
            st, rob, cfg,
        )  # fmt: skip
        return v, w, _HOME, cx, cy
    found, tx, ty, has_after, ax, ay = _choose(
        b, px, py, s, c, known, until, count, st, room, now, cfg, tour_cfg
    )
    if not found:
        # Nothing left that it knows of: wait on the platform, looking around on the way.
        if not endgame:
            return 0.0, 0.4 * rob[_MAX_W], _OTHER, 0.0, 0.0
        if abs(px - cx) <= plat[2] / 2 and abs(py - cy) <= plat[3] / 2:
            return 0.0, 0.3 * rob[_MAX_W], _OTHER, 0.0, 0.0
        v, w = _pursue(
            b, px, py, s, c, cx, cy, False, 0.0, 0.0, now, known, until, count, trail, trail_n,
            st, rob, cfg,
        )  # fmt: skip
        return v, w, _OTHER, 0.0, 0.0
    ex, ey = tx - st[b, _TX], ty - st[b, _TY]
    if not st[b, _HAS_TARGET] > 0.5 or math.sqrt(ex * ex + ey * ey) > cfg[_MERGE]:
        st[b, _SINCE] = now
    st[b, _TX], st[b, _TY], st[b, _HAS_TARGET] = tx, ty, 1.0
    if now - st[b, _SINCE] > cfg[_GIVE_UP]:
        _ignore(known, until, count, b, tx, ty, now + cfg[_GIVE_UP], cfg[_MERGE])
        st[b, _HAS_TARGET] = 0.0
    v, w = _pursue(
        b, px, py, s, c, tx, ty, has_after, ax, ay, now, known, until, count, trail, trail_n, st,
        rob, cfg,
    )  # fmt: skip
    return v, w, _RING, tx, ty
