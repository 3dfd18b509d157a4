"""Every robot's ring memory and route slots in a FastWorld, batched.

    memory = FastRingMemory(world, spec)
    memory.reset(rows)                          # matches `rows` start from the prior layout
    slots = memory.observe(active, pose, visible)

jetson.autonomy.ring_memory.RingMemory is the robot's memory: the simulator and the Jetson keep
one per robot. This is the same memory for thousands of robots at once, compiled (numba): each
step it places the rings the camera sees from the robot's GPS pose, forgets a remembered ring
whose place the camera looks at without seeing it (memory_view "cone" or "camera") or that
the robot stands on, merges fresh sightings with what it knew, plans the route (the tour of
jetson.autonomy.route: the cheapest first stops, a nearest-neighbour tour, 2-opt with the first
stop fixed, the current target kept unless another tour is cheaper by switch_margin_m) and
returns the frame's ring slots (seen and remembered, nearest first) and route slots. It is the
same arithmetic step for step, so a frame built from it equals build_frame's on RingMemory's
view value for value (tests/sim/fast/test_memory.py); the tests are what keep the two equal.
Not batched yet: memory_forget_intake and memory_push (ConfigError names them).

FastGoalMemory is jetson.autonomy.goal_memory.GoalMemory batched the same way: dead reckoning
of the goals from the prior layout and the clamp (the goal nearest the clamp point leaves the
slots when the clamp closes, comes back at the clamp point when it opens, and a goal whose
place the robot drives over is forgotten).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numba as nb
import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import MemoryCamera, robot_to_camera_rotation
from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES
from jetson.autonomy.spec import REMEMBERED, SEEN, ObservationSpec
from sim.errors import ConfigError
from sim.fast.kernels import insert_nearest, threads_for
from sim.fast.world import FastWorld

F64 = NDArray[np.float64]
Bool = NDArray[np.bool_]


def unsupported_memory(spec: ObservationSpec) -> list[str]:
    """What of `spec`'s memories the batched memories do not keep (empty: all of it)."""
    if not spec.ring_memory:
        return []
    return [n for n in ("memory_forget_intake", "memory_push") if getattr(spec, n)]


@dataclass
class MemorySlots:
    """What the memory adds to every robot's frame: the ring slots (seen first, then
    remembered, nearest first; ok: SEEN, REMEMBERED or 0 for an empty slot) and the route's
    first stops in tour order, all in each robot's frame."""

    rings: F64  # (B, R, n_rings, 2)
    ring_ok: F64  # (B, R, n_rings)
    route: F64  # (B, R, route_slots, 2)
    route_count: NDArray[np.int64]  # (B, R)


class _Known:
    """What both memories keep per robot: the places they know (alliance frame, up to
    `capacity` of them, the first `count` in use), starting from `prior`."""

    def __init__(self, world: FastWorld, prior: F64, capacity: int) -> None:
        self.world = world
        self.prior = prior
        self.capacity = capacity
        shape = (world.n, world.n_robots)
        self.known = np.zeros((*shape, capacity, 2))
        self.count = np.zeros(shape, dtype=np.int64)
        self.overflow = np.zeros(shape, dtype=np.int64)  # places dropped for want of room
        self._blue = np.array([a == "blue" for a in world.alliances])

    def reset(self, rows: NDArray[np.int64] | None = None) -> None:
        """Matches `rows` (default all) back to the field's starting layout: new matches."""
        rows = np.arange(self.world.n) if rows is None else np.asarray(rows)
        p = len(self.prior)
        self.known[rows, :, :p] = self.prior
        self.count[rows] = p
        self.overflow[rows] = 0
        self._restart(rows)

    def _restart(self, rows: NDArray[np.int64]) -> None:
        """The rest of a memory's state back to a match's start."""


class FastRingMemory(_Known):
    """The ring memory of every robot of every match (module docstring)."""

    def __init__(
        self, world: FastWorld, spec: ObservationSpec, cameras: list[MemoryCamera] | None = None
    ) -> None:
        missing = unsupported_memory(spec)
        if missing:
            raise ConfigError(
                "the fast backend's ring memory does not keep these yet: " + ", ".join(missing)
            )
        if not spec.prior_rings:
            raise ConfigError("the ring memory needs spec.prior_rings (sim.match.with_prior)")
        use_camera = spec.memory_view == "camera"
        if use_camera and (cameras is None or len(cameras) != world.n_robots):
            raise ConfigError("memory_view 'camera' needs one MemoryCamera per robot")
        self.spec = spec
        prior = np.asarray(spec.prior_rings, dtype=np.float64).reshape(-1, 2)
        # Room for the prior and two sightings of every ring: a ring seen away from where it is
        # remembered is known twice only until its old place is looked at.
        super().__init__(world, prior, len(prior) + 2 * world.ring_xy.shape[1] + 8)
        shape = (world.n, world.n_robots)
        self.target = np.zeros((*shape, 2))  # the route's first stop
        self.has_target = np.zeros(shape, dtype=bool)
        self._view = np.array(
            [
                1.0 if use_camera else 0.0,
                spec.memory_fov_deg,
                spec.memory_near_m,
                spec.memory_far_m,
                spec.memory_merge_m,
                spec.memory_forget_m,
            ]
        )
        cams = cameras if use_camera and cameras is not None else []
        self._cam = np.array([_camera_row(c) for c in cams]).reshape(len(cams), 19)
        if not use_camera:
            self._cam = np.zeros((world.n_robots, 19))
        t = spec.tour
        self._tour_cfg = np.array([t.candidates, t.turn_cost_m_per_rad, t.switch_margin_m])
        self.reset()

    def _restart(self, rows: NDArray[np.int64]) -> None:
        self.has_target[rows] = False

    def observe(self, active: Bool, pose: F64, visible: Bool) -> MemorySlots:
        """Feed the matches where `active` (B,) with what each robot's camera sees now
        (visible (B, R, N) floor rings; pose (B, R, 3): the GPS field-frame pose the memory
        places them from) and return every robot's slots (rows not active: zeros)."""
        w = self.world
        s = self.spec
        fills = w.room_cap < (1 << 30)
        with threads_for(w.n):
            rings, ok, route, n_route = _memory_step(
                self.known, self.count, self.target, self.has_target, self.overflow,
                np.asarray(active, dtype=np.bool_), w.x, w.y, w.heading, pose, self._blue,
                w.ring_xy, visible, w.held, fills, self._view, self._cam, self._tour_cfg,
                s.n_rings, s.route_slots, s.ring_capacity_norm, SEEN, REMEMBERED,
            )  # fmt: skip
        return MemorySlots(rings, ok, route, n_route)


class FastGoalMemory(_Known):
    """The goal memory of every robot of every match (module docstring)."""

    def __init__(self, world: FastWorld, spec: ObservationSpec) -> None:
        if not spec.prior_goals or spec.goal_clamp_offset_m <= 0:
            raise ConfigError(
                "the goal memory needs spec.prior_goals and goal_clamp_offset_m "
                "(sim.match.with_prior)"
            )
        self.spec = spec
        prior = np.asarray(spec.prior_goals, dtype=np.float64).reshape(-1, 2)
        # Room for the prior and a goal put down after every one clamped: far more than a match
        # makes before the robot drives over (and so forgets) the old places.
        super().__init__(world, prior, len(prior) + 16)
        self.holding = np.zeros((world.n, world.n_robots), dtype=bool)
        # (R, G): the goals of each robot's colours (yellow and its alliance's), goal_sight's.
        colours = [GOAL_COLOUR_CODES[g.alliance or "yellow"] for g in world.field.goals]
        self._ours = np.array(
            [[c in (GOAL_COLOUR_CODES["yellow"], GOAL_COLOUR_CODES[a]) for c in colours]
             for a in world.alliances],
            dtype=bool,
        ).reshape(world.n_robots, -1)  # fmt: skip
        self.reset()

    def _restart(self, rows: NDArray[np.int64]) -> None:
        self.holding[rows] = False

    def observe(
        self, active: Bool, pose: F64, goals_seen: Bool | None = None
    ) -> tuple[F64, NDArray[np.int64]]:
        """Feed the matches where `active` with each robot's clamp and GPS pose (and with
        spec.goal_sight the goals each robot's camera sees, (B, R, G): FastObserver.
        goals_in_view); returns the nearest spec.n_goals remembered goals in each robot's frame,
        nearest first (B, R, n_goals, 2), and how many slots are filled (B, R)."""
        s = self.spec
        w = self.world
        clamped = w.carried >= 0
        goal_xy = np.stack([w.gx, w.gy], -1)
        seen = np.zeros((w.n, w.n_robots, w.n_goals), dtype=bool)
        if s.goal_sight:
            if goals_seen is None:
                raise ValueError("a goal memory corrected by sight needs the goals seen")
            seen = np.asarray(goals_seen, dtype=np.bool_) & self._ours[None]
        sight = np.array(
            [float(s.goal_sight), s.goal_sight_merge_m, s.goal_sight_fov_deg,
             s.goal_sight_near_m, s.goal_sight_far_m],
        )  # fmt: skip
        with threads_for(w.n):
            return _goal_step(
                self.known, self.count, self.holding, self.overflow,
                np.asarray(active, dtype=np.bool_), pose, self._blue, clamped,
                s.goal_clamp_offset_m, s.goal_forget_m, s.n_goals,
                sight, w.x, w.y, w.heading, goal_xy, seen,
            )  # fmt: skip


def _camera_row(cam: MemoryCamera) -> list[float]:
    """A MemoryCamera as _memory_step reads it: mount, ring height, rotation, intrinsics."""
    rot = robot_to_camera_rotation(cam.tilt_deg).reshape(-1).tolist()
    return [
        cam.right_m, cam.forward_m, cam.ring_z_m - cam.height_m, *rot,
        cam.fx, cam.fy, cam.cx, cam.cy, float(cam.width), float(cam.height), cam.near_m,
    ]  # fmt: skip


# --- the compiled step -----------------------------------------------------------------------
# RingMemory.observe, _with_route and _with_remembered, route.tour and two_opt, and build_frame's
# slot order, for one robot at a time, every match in parallel. Each expression is written as
# the numpy one it stands for evaluates it (the same operations in the same order), so the
# floats come out the same.


@nb.njit(cache=True, parallel=True)
def _memory_step(
    known, count, target, has_target, overflow, active, x, y, heading, gps, blue, ring_xy,
    seen, held, fills, view, cam, tour_cfg, ring_slots, route_slots, cap_norm, seen_ok,
    remembered_ok,
):  # fmt: skip
    n_match, n_robot = x.shape
    n_ring = ring_xy.shape[1]
    cap = known.shape[2]
    rings_out = np.zeros((n_match, n_robot, ring_slots, 2))
    ok_out = np.zeros((n_match, n_robot, ring_slots))
    route_out = np.zeros((n_match, n_robot, route_slots, 2))
    route_n = np.zeros((n_match, n_robot), dtype=np.int64)
    merge = view[4]
    for b in nb.prange(n_match):
        if not active[b]:
            continue
        local_seen = np.empty((n_ring, 2))
        field_seen = np.empty((n_ring, 2))
        gone = np.empty(cap, dtype=np.bool_)
        for i in range(n_robot):
            px, py, s, c = _alliance_pose(gps, blue, b, i)
            ns = place_seen(
                b, i, x, y, heading, ring_xy, seen, px, py, s, c, local_seen, field_seen
            )
            k_n = count[b, i]
            kn = known[b, i]
            if k_n > 0:
                for k in range(k_n):
                    dx = kn[k, 0] - px
                    dy = kn[k, 1] - py
                    lx = dx * c - dy * s
                    ly = dx * s + dy * c
                    taken = math.hypot(lx, ly) <= view[5]
                    if view[0] > 0.5:
                        in_view = _in_picture(cam, i, lx, ly, view[3])
                    else:
                        dist = math.hypot(lx, ly)
                        bearing = math.degrees(abs(math.atan2(lx, ly)))
                        in_view = bearing <= view[1] / 2 and dist >= view[2] and dist <= view[3]
                    matched = near_any(kn[k, 0], kn[k, 1], field_seen, ns, merge)
                    gone[k] = (in_view and not matched) or taken
                k_n = _compact(kn, k_n, gone)
            added = 0
            if ns > 0:
                if k_n > 0:
                    for k in range(k_n):  # replaced by their fresh sighting
                        gone[k] = near_any(kn[k, 0], kn[k, 1], field_seen, ns, merge)
                    k_n = _compact(kn, k_n, gone)
                for j in range(ns):
                    if k_n < cap:
                        kn[k_n, 0] = field_seen[j, 0]
                        kn[k_n, 1] = field_seen[j, 1]
                        k_n += 1
                        added += 1
                    else:
                        overflow[b, i] += 1
            count[b, i] = k_n
            if route_slots > 0:
                room = max(1, cap_norm - held[b, i] * (1 if fills[b, i] else 0))
                order = _route(
                    kn, k_n, target, has_target, b, i, px, py, s, c, room, tour_cfg, merge
                )
                m = min(route_slots, len(order))
                for j in range(m):
                    dx = kn[order[j], 0] - px
                    dy = kn[order[j], 1] - py
                    route_out[b, i, j, 0] = dx * c - dy * s
                    route_out[b, i, j, 1] = dx * s + dy * c
                route_n[b, i] = m
            # build_frame's ring slots: the seen rings, then the remembered ones (known but
            # not this step's sightings), nearest first, equal distances in that order.
            d2 = np.empty(ring_slots)
            filled = 0
            for q in range(ns + k_n - added):
                if q < ns:
                    lx, ly, okv = local_seen[q, 0], local_seen[q, 1], seen_ok
                else:
                    k = q - ns
                    dx = kn[k, 0] - px
                    dy = kn[k, 1] - py
                    lx, ly, okv = dx * c - dy * s, dx * s + dy * c, remembered_ok
                filled = insert_nearest(
                    d2, rings_out[b, i], ok_out[b, i], filled, lx * lx + ly * ly, lx, ly, okv
                )
    return rings_out, ok_out, route_out, route_n


@nb.njit(cache=True)
def place_seen(b, i, x, y, heading, ring_xy, seen, px, py, s, c, local, field):
    """The rings robot i of match b sees (seen (B, R, N)): in its frame from its true pose
    (sensors.rings_in_robot_frame) into local, and placed on the field from its GPS pose (px,
    py; the GPS heading's sine and cosine s, c: robot_to_field) into field. Returns how many."""
    th = math.radians(heading[b, i])
    ts, tc = math.sin(th), math.cos(th)
    ns = 0
    for n in range(ring_xy.shape[1]):
        if seen[b, i, n]:
            dx = ring_xy[b, n, 0] - x[b, i]
            dy = ring_xy[b, n, 1] - y[b, i]
            lx = dx * tc - dy * ts
            ly = dx * ts + dy * tc
            local[ns, 0] = lx
            local[ns, 1] = ly
            field[ns, 0] = (lx * c + ly * s) + px
            field[ns, 1] = (-lx * s + ly * c) + py
            ns += 1
    return ns


@nb.njit(cache=True, inline="always")
def near_any(x, y, pts, n, radius):
    """Whether any of pts[:n] lies within `radius` of (x, y) (RingMemory's norm <= merge)."""
    for j in range(n):
        ex = x - pts[j, 0]
        ey = y - pts[j, 1]
        if math.sqrt(ex * ex + ey * ey) <= radius:
            return True
    return False


@nb.njit(cache=True, inline="always")
def _alliance_pose(gps, blue, b, i):
    """Robot i of match b's GPS pose in its alliance frame (to_alliance_frame: blue sees the
    field turned 180 degrees): x, y and the heading's sine and cosine."""
    px, py, ph = gps[b, i, 0], gps[b, i, 1], gps[b, i, 2]
    if blue[i]:
        px, py = -px, -py
        ph = (ph + 180.0) % 360.0
        if ph >= 360.0:
            ph = 0.0
    hr = math.radians(ph)
    return px, py, math.sin(hr), math.cos(hr)


@nb.njit(cache=True, inline="always")
def _in_picture(cam, i, lx, ly, far):
    """MemoryCamera.locate for one ring at robot-frame (lx, ly), and within `far` of the lens."""
    r0 = lx - cam[i, 0]
    r1 = ly - cam[i, 1]
    r2 = cam[i, 2]
    o0 = cam[i, 3] * r0 + cam[i, 4] * r1 + cam[i, 5] * r2
    o1 = cam[i, 6] * r0 + cam[i, 7] * r1 + cam[i, 8] * r2
    z = cam[i, 9] * r0 + cam[i, 10] * r1 + cam[i, 11] * r2
    if not z > cam[i, 18]:
        return False
    u = cam[i, 12] * o0 / z + cam[i, 14]
    v = cam[i, 13] * o1 / z + cam[i, 15]
    inside = u >= 0 and u < cam[i, 16] and v >= 0 and v < cam[i, 17]
    return inside and math.sqrt(r0 * r0 + r1 * r1 + r2 * r2) <= far


@nb.njit(cache=True, inline="always")
def _compact(kn, k_n, gone):
    """Drop the rows of kn[:k_n] marked gone, keeping the others' order; the new count."""
    m = 0
    for k in range(k_n):
        if not gone[k]:
            kn[m, 0] = kn[k, 0]
            kn[m, 1] = kn[k, 1]
            m += 1
    return m


@nb.njit(cache=True)
def _route(kn, k_n, target, has_target, b, i, px, py, s, c, room, tour_cfg, merge):
    """RingMemory._with_route for one robot: the tour's stops (indices into kn), first stop
    first, and the robot's target updated to the first stop."""
    current = -1
    if has_target[b, i] and k_n > 0:
        best_d = np.inf
        for k in range(k_n):
            ex = kn[k, 0] - target[b, i, 0]
            ey = kn[k, 1] - target[b, i, 1]
            d = math.sqrt(ex * ex + ey * ey)
            if d < best_d:
                best_d, current = d, k
        if not best_d <= merge:
            current = -1
    order = compiled_tour(kn, k_n, px, py, s, c, room, tour_cfg, current)
    if len(order):
        target[b, i, 0] = kn[order[0], 0]
        target[b, i, 1] = kn[order[0], 1]
        has_target[b, i] = True
    else:
        has_target[b, i] = False
    return order


@nb.njit(cache=True)
def compiled_tour(kn, k_n, px, py, s, c, stops, tour_cfg, current):
    """jetson.autonomy.route.tour over kn[:k_n] from the pose (px, py; heading's sin, cos)."""
    if k_n == 0 or stops < 1:
        return np.zeros(0, dtype=np.int64)
    cost = np.empty(k_n)
    for k in range(k_n):
        dx = kn[k, 0] - px
        dy = kn[k, 1] - py
        lx = dx * c - dy * s
        ly = dx * s + dy * c
        cost[k] = math.hypot(lx, ly) + tour_cfg[1] * abs(math.atan2(lx, ly))
    n_cand = min(int(tour_cfg[0]), k_n)
    cand = np.argsort(cost, kind="mergesort")[:n_cand]
    stops = min(stops, n_cand)
    pair = np.empty((n_cand, n_cand))
    for a in range(n_cand):
        for d in range(n_cand):
            ex = kn[cand[a], 0] - kn[cand[d], 0]
            ey = kn[cand[a], 1] - kn[cand[d], 1]
            pair[a, d] = math.sqrt(ex * ex + ey * ey)
    start = cost[cand]
    best_cost = np.inf
    best = np.zeros(1, dtype=np.int64)
    for first in range(n_cand):
        total, order = _tour_from(first, start, pair, stops)
        if total < best_cost:
            best_cost, best = total, order
    if current >= 0 and cand[best[0]] != current:
        k = -1
        for j in range(n_cand):
            if cand[j] == current:
                k = j
                break
        if k >= 0:
            total, order = _tour_from(k, start, pair, stops)
            if total <= best_cost + tour_cfg[2]:
                # The current target first, then the best tour's stops (it may not be one).
                moved = np.empty(len(best) + 1, dtype=np.int64)
                moved[0] = k
                m = 1
                for j in best:
                    if j != k:
                        moved[m] = j
                        m += 1
                best = moved[:m]
    out = np.empty(len(best), dtype=np.int64)
    for j in range(len(best)):
        out[j] = cand[best[j]]
    return out


@nb.njit(cache=True)
def _tour_from(first, start, pair, stops):
    """route._tour_from: a nearest-neighbour tour from `first`, 2-opt with it fixed; its cost."""
    n = pair.shape[0]
    used = np.zeros(n, dtype=np.bool_)
    order = np.empty(stops, dtype=np.int64)
    order[0] = first
    used[first] = True
    m = 1
    while m < stops:
        nxt, low = -1, np.inf
        for j in range(n):
            if not used[j] and pair[order[m - 1], j] < low:
                nxt, low = j, pair[order[m - 1], j]
        if nxt < 0:
            break
        order[m] = nxt
        used[nxt] = True
        m += 1
    order = _two_opt(order[:m], pair)
    legs = 0.0
    for j in range(m - 1):
        legs += pair[order[j], order[j + 1]]
    return start[first] + legs, order


@nb.njit(cache=True)
def _two_opt(order, pair):
    """route.two_opt with the first stop fixed."""
    best = order.copy()
    n = len(best)
    improved = True
    while improved:
        improved = False
        for i in range(1, n - 1):
            a = best[i - 1]
            for k in range(i + 1, n):
                b, cpt = best[i], best[k]
                before = pair[a, b]
                after = pair[a, cpt]
                if k + 1 < n:
                    d = best[k + 1]
                    before += pair[cpt, d]
                    after += pair[b, d]
                if after < before - 1e-9:
                    best[i : k + 1] = best[i : k + 1][::-1].copy()
                    improved = True
    return best


@nb.njit(cache=True, inline="always")
def _by_sight(
    kn, k_n, keep, b, i, px, py, s, c, x, y, heading, goal_xy, goal_seen, local, found, sight
):  # fmt: skip
    """GoalMemory._by_sight for robot i of match b (GPS pose px, py, s, c in its alliance
    frame): remembered goals matched by a sighting or in the detector's reach go, the
    sightings join. Returns the new count (more than kn holds: the caller counts overflow)."""
    nf = place_seen(b, i, x, y, heading, goal_xy, goal_seen, px, py, s, c, local, found)
    for k in range(k_n):
        dx = kn[k, 0] - px
        dy = kn[k, 1] - py
        lx = dx * c - dy * s
        ly = dx * s + dy * c
        dist = math.hypot(lx, ly)
        bearing = math.degrees(abs(math.atan2(lx, ly)))
        reach = bearing <= sight[2] / 2 and dist >= sight[3] and dist <= sight[4]
        keep[k] = not (reach or near_any(kn[k, 0], kn[k, 1], found, nf, sight[1]))
    k_n = _compact(kn, k_n, ~keep)
    total = k_n + nf
    for j in range(nf):
        if k_n + j < kn.shape[0]:
            kn[k_n + j, 0] = found[j, 0]
            kn[k_n + j, 1] = found[j, 1]
    return total


@nb.njit(cache=True, parallel=True)
def _goal_step(
    known, count, holding, overflow, active, gps, blue, clamped, offset, forget, slots,
    sight, x, y, heading, goal_xy, goal_seen,
):  # fmt: skip
    """GoalMemory.observe for every robot of the active matches, and the goal slots. sight:
    goal_sight's [on, merge_m, fov_deg, near_m, far_m]; goal_seen (B, R, G): the goals of its
    colours each robot's camera sees (goal_xy (B, G, 2)), placed from the true pose (x, y,
    heading) as sim.goal_sight reports them."""
    n_match, n_robot = clamped.shape
    cap = known.shape[2]
    n_goal = goal_xy.shape[1]
    out = np.zeros((n_match, n_robot, slots, 2))
    filled = np.zeros((n_match, n_robot), dtype=np.int64)
    for b in nb.prange(n_match):
        if not active[b]:
            continue
        keep = np.empty(cap, dtype=np.bool_)
        d2 = np.empty(slots)
        ok = np.empty(slots)
        local_seen = np.empty((n_goal, 2))
        found = np.empty((n_goal, 2))
        for i in range(n_robot):
            px, py, s, c = _alliance_pose(gps, blue, b, i)
            cx = px - offset * s
            cy = py - offset * c
            kn = known[b, i]
            k_n = count[b, i]
            if clamped[b, i] and not holding[b, i]:
                if k_n > 0:
                    best, best_d = 0, np.inf
                    for k in range(k_n):
                        d = math.hypot(kn[k, 0] - cx, kn[k, 1] - cy)
                        if d < best_d:
                            best, best_d = k, d
                    if best_d <= 2 * forget + offset:
                        for k in range(best, k_n - 1):
                            kn[k, 0] = kn[k + 1, 0]
                            kn[k, 1] = kn[k + 1, 1]
                        k_n -= 1
            elif holding[b, i] and not clamped[b, i]:
                if k_n < cap:
                    kn[k_n, 0] = cx
                    kn[k_n, 1] = cy
                    k_n += 1
                else:
                    overflow[b, i] += 1
            holding[b, i] = clamped[b, i]
            for k in range(k_n):
                keep[k] = not math.hypot(kn[k, 0] - px, kn[k, 1] - py) <= forget
            k_n = _compact(kn, k_n, ~keep)
            if sight[0] > 0.5:
                k_n = _by_sight(
                    kn, k_n, keep, b, i, px, py, s, c, x, y, heading, goal_xy, goal_seen,
                    local_seen, found, sight,
                )  # fmt: skip
                if k_n > cap:
                    overflow[b, i] += k_n - cap
                    k_n = cap
            count[b, i] = k_n
            # build_frame's goal slots: nearest first, equal distances in memory order.
            m = 0
            for k in range(k_n):
                dx = kn[k, 0] - px
                dy = kn[k, 1] - py
                lx = dx * c - dy * s
                ly = dx * s + dy * c
                m = insert_nearest(d2, out[b, i], ok, m, lx * lx + ly * ly, lx, ly, 1.0)
            filled[b, i] = m
    return out, filled
