"""jetson.autonomy.skills' controller (SkillDriver) for every robot of every match, and the
planner teacher's skill label (option_for), compiled.

    drivers = FastSkillDrivers(configs, spec, n_matches, dt)   # configs: one per robot index
    drivers.reset(rows)                                        # matches `rows` start afresh
    busy = drivers.committed(obs, who, active)                 # SkillDriver.committed
    linear, angular = drivers.command(obs, actions, who, active)
    kind, local = drivers.targets(who)                         # SkillDriver.target
    labels = OptionLabels(spec, skills)(intent, point, pose, obs)

A skill policy's action is one score per skill, and each robot's SkillDriver drives the best
one: a Python call per robot and step. FastSkillDrivers is the same controller for robot who[b]
of every match b at once (numba): the same state (the trail of positions, the back-off, a goal
manoeuvre committed to) and the same arithmetic, on the observation rows the robots' own
controllers read. skills' turn_first, arc_through, pursuit_point, back_onto and Trail are
sim.fast.planner's compiled ports; tests/sim/fast/test_skills.py holds the whole controller to
SkillDriver command for command (to 1e-12: numpy's two-element dot products in pursuit_point may
fuse a multiply and an add, this arithmetic does not), and OptionLabels to rollout.intent_label.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numba as nb
import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.skills import (
    CLIMB,
    KEEP_CLEAR_CORNER_M,
    PLATFORM_AIM_M,
    PLATFORM_HINGE_M,
    PLATFORM_LANE_M,
    PLATFORM_STAGE_M,
    PLATFORM_STAGGER_M,
    STAGE,
    THERE,
    SkillConfig,
)
from jetson.autonomy.spec import ObservationSpec
from sim.fast.kernels import threads_for
from sim.fast.planner import (
    INTENTS,
    arc_through,
    back_onto,
    pursuit_point,
    to_robot,
    trail_push,
    trail_stuck,
    turn_first,
)

F64 = NDArray[np.float64]
F32 = NDArray[np.float32]
I64 = NDArray[np.int64]
Bool = NDArray[np.bool_]

# Columns of a robot's configuration row: its SkillConfig's numbers and where its spec puts the
# slots (the spec's offsets into a frame; _CLAMPED is -1 without a goal memory, _TALL without
# the role flag, _PARTNER_AT without the partner block).
(_ROUTE, _THROUGH, _RINGS, _GOALS, _PLATFORM, _BOX_X, _BOX_Y, _BOX_HX, _BOX_HY, _LENGTH, _MAX_V,
 _MAX_W, _LOOKAHEAD, _TURN_GAIN, _TURN_IN_PLACE, _COMMIT_S, _WINDOW, _STUCK_M, _BACKOFF, _UNIT,
 _MATCH_LENGTH, _ROUTE_AT, _RING_AT, _GOAL_AT, _CLAMPED, _SHARE, _LANE_TALL, _LANE_OTHER,
 _CLIMB_V, _TALL, _PARTNER_AT, _SPLIT, _SPLIT_M, _CLEAR_S, _CLEAR_M,
 _CLIMB_AT, _PAST_TALL, _PAST_OTHER) = range(38)  # fmt: skip
# Columns of a controller's state: SkillDriver's back-off and committed goal manoeuvre, and
# what its last command drove to (SkillDriver.target: TARGET_KINDS' index, robot-frame point).
(_BACKOFF_UNTIL, _BACKOFF_TURN, _COMMITTED, _COMMIT_X, _COMMIT_Y, _COMMIT_UNTIL, _TARGET,
 _TARGET_X, _TARGET_Y) = range(9)  # fmt: skip
TARGET_KINDS = (None, "ring", "goal", "platform")
_RING, _GOAL, _PLATFORM_TARGET = 1, 2, 3
_MATCH_M = 0.3  # option_for's match_m: how near an option's slot must be to the intent


def config_row(config: SkillConfig, spec: ObservationSpec) -> list[float]:
    """One robot's SkillConfig and spec as the kernels read them (the column constants)."""
    c = config
    clamped = spec.scalar_index("clamped") if spec.goal_memory else -1
    tall = spec.scalar_index("tall") if spec.role_flag else -1
    partner = spec.partner_offset if spec.partner else -1
    return [
        float(c.route_option), float(c.route_through_next), c.ring_options, c.goal_options,
        float(c.platform), *c.platform_box, c.robot_length_m, c.max_linear_mps,
        c.max_angular_rad_s, c.lookahead_m, c.turn_gain, c.turn_in_place_rad, c.commit_goal_s,
        c.stuck_window_s, c.stuck_distance_m, c.backoff_s, spec.length_unit_m,
        spec.match_length_s, spec.route_offset, spec.ring_offset, spec.goal_offset, clamped,
        float(c.share_platform), *c.platform_lanes_m, c.platform_speed_mps, tall, partner,
        float(c.split_with_partner), c.split_margin_m, c.keep_clear_s, c.keep_clear_m,
        c.climb_at_s, *c.platform_past_m,
    ]  # fmt: skip


class FastSkillDrivers:
    """A SkillDriver for every robot of every match (module docstring): configs[i] is robot
    i's SkillConfig (its platform, size and speeds: MatchCore.skill_driver's)."""

    def __init__(
        self, configs: Sequence[SkillConfig], spec: ObservationSpec, n_matches: int, dt: float
    ) -> None:
        for config in configs:
            config.check(spec)
            if config.release_dragged_s > 0:
                raise ValueError(
                    "skills: the batched controller does not let go in a tug of war "
                    "(release_dragged_s): train with it off and set it on the exported policy "
                    "(pete-sim export --skill release_dragged_s=1.0)"
                )
            if config.partner_room_m > 0:
                raise ValueError(
                    "skills: the batched controller does not keep room from the partner to "
                    "turn (partner_room_m): train with it off and set it on the exported policy "
                    "(pete-sim export --skill partner_room_m=0.8)"
                )
        self.configs = tuple(configs)
        self.spec = spec
        self.n = n_matches
        self.n_robots = len(configs)
        self.n_options = max(c.n_options for c in configs)
        self._cfg = np.array([config_row(c, spec) for c in configs], dtype=np.float64)
        rows = n_matches * self.n_robots  # one controller per (match, robot): b * R + i
        window = max(c.stuck_window_s for c in configs)
        self.trail = np.zeros((rows, math.ceil(window / dt) + 8, 3))
        self.trail_n = np.zeros(rows, dtype=np.int64)
        self.overflow = np.zeros(rows, dtype=np.int64)  # trail rows dropped for room
        self.state = np.zeros((rows, 9))
        self.reset(np.arange(n_matches))

    def reset(self, rows: I64) -> None:
        """Every robot of matches `rows` gets a fresh controller (SkillDriver.reset)."""
        r = np.asarray(rows, dtype=np.int64)[:, None] * self.n_robots + np.arange(self.n_robots)
        r = r.reshape(-1)
        self.trail_n[r] = 0
        self.overflow[r] = 0
        self.state[r] = 0.0
        self.state[r, _BACKOFF_UNTIL] = -1.0
        self.state[r, _BACKOFF_TURN] = 1.0
        self.state[r, _COMMIT_UNTIL] = -1.0

    def targets(self, who: I64) -> tuple[I64, F64]:
        """SkillDriver.target of robot who[b] of every match b after its last command: the
        kind (an index of TARGET_KINDS, 0 for none) (B,) and the robot-frame point (B, 2)."""
        r = np.arange(self.n) * self.n_robots + np.asarray(who, dtype=np.int64)
        st = self.state[r]
        return st[:, _TARGET].astype(np.int64), st[:, _TARGET_X : _TARGET_Y + 1].copy()

    def committed(self, obs: F32, who: I64, active: Bool) -> Bool:
        """SkillDriver.committed of robot who[b] of each active match b on its observation
        obs[b] (B, spec.size): whether its next command ignores its action. False elsewhere."""
        with threads_for(self.n):
            return _committed_all(
                np.asarray(active, dtype=np.bool_), np.asarray(who, dtype=np.int64),
                np.asarray(obs, dtype=np.float32), self._cfg, self.state, self.n_robots,
            )  # fmt: skip

    def command(self, obs: F32, actions: F64, who: I64, active: Bool) -> tuple[F64, F64]:
        """SkillDriver.command of robot who[b] of each active match b: (linear m/s, angular
        rad/s clockwise), (B,) each, zeros where not active; actions (B, >= n_options)."""
        a = np.asarray(actions, dtype=np.float64)
        if a.ndim != 2 or a.shape[1] < self.n_options:
            raise ValueError(f"actions must have shape (B, >= {self.n_options})")
        with threads_for(self.n):
            return _command_all(
                np.asarray(active, dtype=np.bool_), np.asarray(who, dtype=np.int64),
                np.asarray(obs, dtype=np.float32), a, self._cfg, self.trail, self.trail_n,
                self.overflow, self.state, self.n_robots,
            )  # fmt: skip


class OptionLabels:
    """rollout.intent_label of a skill policy for every match at once: the option that does what
    the planner intends (option_for) as a label, 1 for it and -1 for the others, NaN where no
    option does it."""

    def __init__(self, spec: ObservationSpec, skills: SkillConfig) -> None:
        skills.check(spec)
        assert INTENTS == ("other", "ring", "goal", "home")  # _option's kinds
        self.n_options = skills.n_options
        self._cfg = np.array(config_row(skills, spec), dtype=np.float64)

    def __call__(self, intent: I64, point: F64, pose: F64, obs: F32) -> F32:
        """(B, n_options) labels: intent (B,) indexes sim.fast.planner.INTENTS, point (B, 2)
        its point in the field frame, pose (B, 3) the robot's field pose (x, y, heading in
        degrees), obs (B, spec.size) the robot's observation."""
        with threads_for(len(intent)):
            return _labels(
                np.asarray(intent, dtype=np.int64), np.asarray(point, dtype=np.float64),
                np.asarray(pose, dtype=np.float64), np.asarray(obs, dtype=np.float32),
                self._cfg, self.n_options,
            )  # fmt: skip


# --- the controller, one robot --------------------------------------------------------------


@nb.njit(cache=True)
def _is_committed(f, st, r, c):
    """SkillDriver.committed for controller r on frame f: a goal manoeuvre under way (the clamp
    still open and its time not up); one that ended is dropped."""
    if not st[r, _COMMITTED] > 0.5:
        return False
    at = int(c[_CLAMPED])
    clamped = at >= 0 and np.float64(f[at]) > 0.5
    if clamped or np.float64(f[0]) * c[_MATCH_LENGTH] >= st[r, _COMMIT_UNTIL]:
        st[r, _COMMITTED] = 0.0
        return False
    return True


@nb.njit(cache=True)
def _crosses(x0, y0, x1, y1, cx, cy, gx, gy):
    """skills._crosses: the segment through the open box (the slab test)."""
    t0, t1 = 0.0, 1.0
    for axis in range(2):
        p, d, lo, hi = (
            (x0, x1 - x0, cx - gx, cx + gx) if axis == 0 else (y0, y1 - y0, cy - gy, cy + gy)
        )
        if abs(d) < 1e-12:
            if not lo < p < hi:
                return False
            continue
        a, b = (lo - p) / d, (hi - p) / d
        t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
        if t0 >= t1:
            return False
    return True


@nb.njit(cache=True)
def _around(x, y, tx, ty, cx, cy, hx, hy, margin):
    """skills.around: the target, or the field-side corner of the grown box the way round."""
    gx, gy = hx + margin, hy + margin
    if not _crosses(x, y, tx, ty, cx, cy, gx, gy):
        return tx, ty
    ox, oy = gx + KEEP_CLEAR_CORNER_M, gy + KEEP_CLEAR_CORNER_M
    bx, by, way = tx, ty, np.inf
    for k in range(2):
        if abs(cx) >= abs(cy):
            px, py = cx - math.copysign(ox, cx), (cy - oy if k == 0 else cy + oy)
        else:
            px, py = (cx - ox if k == 0 else cx + ox), cy - math.copysign(oy, cy)
        if _crosses(x, y, px, py, cx, cy, gx, gy):
            continue
        d = math.hypot(px - x, py - y) + math.hypot(tx - px, ty - py)
        if d < way:
            bx, by, way = px, py, d
    return bx, by


@nb.njit(cache=True)
def _leave(x, y, cos_h, sin_h, cx, cy, hx, hy, margin, speed):
    """skills.leave: (whether inside the grown box, v, w) straight out of it."""
    dx, dy = x - cx, y - cy
    if not (abs(dx) < hx + margin and abs(dy) < hy + margin):
        return False, 0.0, 0.0
    ax, ay = dx - max(-hx, min(hx, dx)), dy - max(-hy, min(hy, dy))
    if ax == 0.0 and ay == 0.0:
        ax, ay = dx, dy
    ahead = ax * sin_h + ay * cos_h
    if abs(ahead) >= 0.5 * math.hypot(ax, ay):
        return True, math.copysign(speed, ahead), 0.0
    home = -x * sin_h - y * cos_h
    return True, (speed if home >= 0 else -speed), 0.0


@nb.njit(cache=True)
def _pursue(tx, ty, now, has_after, ax, ay, r, c, trail, trail_n, st, pose, clear):
    """SkillDriver._pursue: turn first, or the pure-pursuit arc onto (tx, ty) (along to
    (ax, ay) when has_after); a robot stuck while driving backs off. With `clear` (the
    endgame) the way goes round the other alliance's platform (pose: the robot's
    alliance-frame x, y, cos_h, sin_h)."""
    if clear:
        x, y, cos_h, sin_h = pose[0], pose[1], pose[2], pose[3]
        qx, qy = x + tx * cos_h + ty * sin_h, y - tx * sin_h + ty * cos_h
        px, py = _around(x, y, qx, qy, -c[_BOX_X], -c[_BOX_Y], c[_BOX_HX], c[_BOX_HY], c[_CLEAR_M])
        if px != qx or py != qy:
            dx, dy = px - x, py - y
            tx, ty, has_after = dx * cos_h - dy * sin_h, dx * sin_h + dy * cos_h, False
    turns, v, w = turn_first(
        tx, ty, c[_MAX_V], c[_MAX_W], c[_TURN_GAIN], c[_TURN_IN_PLACE], c[_LENGTH]
    )
    if turns:
        return v, w
    look = c[_LOOKAHEAD]
    if has_after:
        path = np.empty((2, 2))
        path[0, 0], path[0, 1], path[1, 0], path[1, 1] = tx, ty, ax, ay
        px, py = pursuit_point(path, look)
    else:
        d = math.hypot(tx, ty)
        px, py = (tx, ty) if d <= look else (tx * look / d, ty * look / d)
    v, w = arc_through(px, py, c[_MAX_V], c[_MAX_W])
    if trail_stuck(trail, trail_n, r, now, v, c[_WINDOW], c[_STUCK_M]):
        st[r, _BACKOFF_UNTIL] = now + c[_BACKOFF]
        st[r, _BACKOFF_TURN] = -1.0 if math.atan2(tx, ty) > 0 else 1.0
        trail_n[r] = 0
    return v, w


@nb.njit(cache=True)
def _reverse_onto(gx, gy, now, r, c, trail, trail_n, st, pose, clear):
    """SkillDriver._reverse_onto: drive to half a metre short of a far goal (robot frame),
    then back onto it; forward when stuck."""
    dist = math.hypot(gx, gy)
    if dist > 1.0:
        k = 1.0 - 0.5 / dist
        return _pursue(gx * k, gy * k, now, False, 0.0, 0.0, r, c, trail, trail_n, st, pose, clear)
    v, w = back_onto(gx, gy, c[_MAX_V], c[_MAX_W], c[_TURN_GAIN])
    if trail_stuck(trail, trail_n, r, now, abs(v), c[_WINDOW], c[_STUCK_M]):
        st[r, _BACKOFF_UNTIL] = now + c[_BACKOFF] / 2
        st[r, _BACKOFF_TURN] = 1.0
        trail_n[r] = 0
        return 0.5 * c[_MAX_V], 0.0
    return v, w


@nb.njit(cache=True)
def _best(a, n):
    """SkillDriver.option: the first of the n highest scores (np.argmax)."""
    k = 0
    for j in range(1, n):
        if a[j] > a[k]:
            k = j
    return k


@nb.njit(cache=True)
def _option_point(f, k, c):
    """SkillDriver._option_point: (whether option k has a ring or goal, its robot-frame x,
    y in metres)."""
    route, rings, goals = int(c[_ROUTE]), int(c[_RINGS]), int(c[_GOALS])
    if k < route:
        at = int(c[_ROUTE_AT])
    elif k < route + rings:
        at = int(c[_RING_AT]) + 3 * (k - route)
    elif k < route + rings + goals:
        at = int(c[_GOAL_AT]) + 3 * (k - route - rings)
    else:
        return False, 0.0, 0.0
    if not f[at + 2] > 0:
        return False, 0.0, 0.0
    return True, np.float64(f[at]) * c[_UNIT], np.float64(f[at + 1]) * c[_UNIT]


@nb.njit(cache=True)
def _choose(f, a, n, c):
    """SkillDriver.option(action, obs): the platform in the last climb_at_s seconds; else the
    best of the n scores whose ring or goal is neither the partner's (split_with_partner) nor
    beside the other alliance's platform in the last keep_clear_s seconds, the best of all
    when every one is."""
    best = _best(a, n)
    left = c[_MATCH_LENGTH] * (1.0 - np.float64(f[0]))
    if c[_CLIMB_AT] > 0 and left <= c[_CLIMB_AT]:
        return n - 1
    at = int(c[_PARTNER_AT])
    split = c[_SPLIT] > 0.5 and at >= 0 and f[at + 2] > 0.5
    clear = c[_CLEAR_S] > 0 and left <= c[_CLEAR_S]
    if not (split or clear):
        return best
    mx, my = 0.0, 0.0
    if split:
        mx, my = np.float64(f[at]) * c[_UNIT], np.float64(f[at + 1]) * c[_UNIT]
    p0, p1 = np.float64(f[1]) * c[_UNIT], np.float64(f[2]) * c[_UNIT]
    cos_h, sin_h = np.float64(f[3]), np.float64(f[4])
    m = c[_CLEAR_M]
    tried = 0  # a bit per option tried: no array allocated per robot and step
    for _ in range(n):
        k = -1  # the best untried score, the first of equals (a stable sort's order)
        for j in range(n):
            if not (tried >> j) & 1 and (k < 0 or a[j] > a[k]):
                k = j
        tried |= 1 << k
        has, px, py = _option_point(f, k, c)
        if not has:
            return k
        if split and math.hypot(px, py) > math.hypot(px - mx, py - my) + c[_SPLIT_M]:
            continue
        if clear:
            # skills._to_alliance of the point; the other platform is the box turned about 0.
            qx, qy = p0 + px * cos_h + py * sin_h, p1 - px * sin_h + py * cos_h
            if abs(qx + c[_BOX_X]) < c[_BOX_HX] + m and abs(qy + c[_BOX_Y]) < c[_BOX_HY] + m:
                continue
        return k
    return best


@nb.njit(cache=True)
def _aim(st, r, kind, x, y):
    """Controller r drives to a `kind` target at robot-frame (x, y) (SkillDriver.target)."""
    st[r, _TARGET] = kind
    st[r, _TARGET_X] = x
    st[r, _TARGET_Y] = y


@nb.njit(cache=True)
def _platform_plan(c, tall, x, y, known, mx, my, carrying):
    """skills.platform_plan for a robot at alliance-frame (x, y), its partner at (mx, my) when
    known, carrying a goal or not: (mode: STAGE, CLIMB or THERE, target x, target y, metres
    from where it stops)."""
    cx, cy, hx, hy = c[_BOX_X], c[_BOX_Y], c[_BOX_HX], c[_BOX_HY]
    if not c[_SHARE] > 0.5:
        inside = abs(x - cx) < hx - 0.2 and abs(y - cy) < hy - 0.2
        return (THERE if inside else STAGE), cx, cy, 0.0
    flip = hx > hy
    c_d, c_l, h_d, d, ell = (cy, cx, hy, y, x) if flip else (cx, cy, hx, x, y)
    side = 1.0 if c_d <= 0 else -1.0
    lane = c[_LANE_TALL] if tall else c[_LANE_OTHER]
    if known:
        mate = mx if flip else my
        lane = abs(lane) if ell > mate else -abs(lane)
    lane += c_l
    ahead = (d - c_d) * side
    stage = h_d + PLATFORM_STAGE_M + (0.0 if tall else PLATFORM_STAGGER_M)
    mode, t_d = STAGE, c_d + side * stage
    if abs(ell - lane) < PLATFORM_LANE_M and -h_d < ahead < stage + 0.1:
        mode, t_d = (THERE if abs(ahead) < PLATFORM_HINGE_M else CLIMB), c_d - side * PLATFORM_AIM_M
    if carrying:
        ahead += c[_PAST_TALL] if tall else c[_PAST_OTHER]
        if mode != STAGE:
            mode = THERE if abs(ahead) < PLATFORM_HINGE_M else CLIMB
    if flip:
        return mode, lane, t_d, ahead
    return mode, t_d, lane, ahead


@nb.njit(cache=True)
def _climb(tx, ty, ahead, on_board, speed, turn_gain, max_angular):
    """skills.climb: (v, w) up a lane to the hinge `ahead` metres on, steering at its
    robot-frame point (tx, ty)."""
    bearing = math.atan2(tx, ty)
    if not on_board and ahead > 0 and abs(bearing) > 0.25:
        return 0.0, max(-max_angular, min(max_angular, turn_gain * bearing))
    v = max(-speed, min(speed, 2.0 * ahead))
    if v < 0:
        return v, 0.0
    return v * max(0.0, math.cos(bearing)), max(-1.5, min(1.5, turn_gain * bearing))


@nb.njit(cache=True)
def _command(f, a, r, c, trail, trail_n, overflow, st):
    """SkillDriver.command for controller r (config row c) on frame f and scores a."""
    unit = c[_UNIT]
    now = np.float64(f[0]) * c[_MATCH_LENGTH]
    p0, p1 = np.float64(f[1]) * unit, np.float64(f[2]) * unit
    cos_h, sin_h = np.float64(f[3]), np.float64(f[4])
    trail_push(trail, trail_n, overflow, r, now, p0, p1, c[_WINDOW])
    backoff = -0.6 * c[_MAX_V], st[r, _BACKOFF_TURN] * 0.5 * c[_MAX_W]
    st[r, _TARGET] = 0.0
    pose = (p0, p1, cos_h, sin_h)  # a tuple: nothing allocated per robot and step
    clear = c[_CLEAR_S] > 0 and c[_MATCH_LENGTH] - now <= c[_CLEAR_S]
    if clear:
        out, v, w = _leave(
            p0, p1, cos_h, sin_h, -c[_BOX_X], -c[_BOX_Y], c[_BOX_HX], c[_BOX_HY], c[_CLEAR_M],
            0.5 * c[_MAX_V],
        )  # fmt: skip
        if out:
            return v, w
    if _is_committed(f, st, r, c):
        lx, ly = to_robot(st[r, _COMMIT_X], st[r, _COMMIT_Y], p0, p1, sin_h, cos_h)
        _aim(st, r, _GOAL, lx, ly)
        if now < st[r, _BACKOFF_UNTIL]:
            return backoff
        return _reverse_onto(lx, ly, now, r, c, trail, trail_n, st, pose, clear)
    if now < st[r, _BACKOFF_UNTIL]:
        return backoff
    search = 0.0, 0.3 * c[_MAX_W]  # an empty slot: a slow turn in place
    rings, goals = int(c[_RINGS]), int(c[_GOALS])
    route = int(c[_ROUTE])
    k = _choose(f, a, route + rings + goals + int(c[_PLATFORM]), c)
    if route:
        if k == 0:
            at = int(c[_ROUTE_AT])
            if not f[at + 2] > 0:
                return search
            tx, ty = np.float64(f[at]) * unit, np.float64(f[at + 1]) * unit
            _aim(st, r, _RING, tx, ty)
            has_after = c[_THROUGH] > 0.5 and f[at + 5] > 0
            ax, ay = 0.0, 0.0
            if has_after:
                ax, ay = np.float64(f[at + 3]) * unit, np.float64(f[at + 4]) * unit
            return _pursue(tx, ty, now, has_after, ax, ay, r, c, trail, trail_n, st, pose, clear)
        k -= 1
    if k < rings:
        at = int(c[_RING_AT]) + 3 * k
        if not f[at + 2] > 0:
            return search
        tx, ty = np.float64(f[at]) * unit, np.float64(f[at + 1]) * unit
        _aim(st, r, _RING, tx, ty)
        return _pursue(tx, ty, now, False, 0.0, 0.0, r, c, trail, trail_n, st, pose, clear)
    k -= rings
    if k < goals:
        at = int(c[_GOAL_AT]) + 3 * k
        if not f[at + 2] > 0:
            return search
        gx, gy = np.float64(f[at]) * unit, np.float64(f[at + 1]) * unit
        if c[_COMMIT_S] > 0:
            # skills._to_alliance: the goal's point in the alliance frame, held while committed.
            st[r, _COMMIT_X] = p0 + gx * cos_h + gy * sin_h
            st[r, _COMMIT_Y] = p1 - gx * sin_h + gy * cos_h
            st[r, _COMMIT_UNTIL] = now + c[_COMMIT_S]
            st[r, _COMMITTED] = 1.0
        _aim(st, r, _GOAL, gx, gy)
        return _reverse_onto(gx, gy, now, r, c, trail, trail_n, st, pose, clear)
    # The platform (skills.platform_plan): stop there, climb its lane, else drive to it.
    at = int(c[_TALL])
    tall = at >= 0 and np.float64(f[at]) > 0.5
    known, mx, my = False, 0.0, 0.0
    at = int(c[_PARTNER_AT])
    if c[_SHARE] > 0.5 and at >= 0 and f[at + 2] > 0.5:
        # skills._to_alliance of the partner's robot-frame point.
        qx, qy = np.float64(f[at]) * unit, np.float64(f[at + 1]) * unit
        known, mx, my = True, p0 + qx * cos_h + qy * sin_h, p1 - qx * sin_h + qy * cos_h
    at = int(c[_CLAMPED])
    carrying = at >= 0 and np.float64(f[at]) > 0.5
    mode, sx, sy, ahead = _platform_plan(c, tall, p0, p1, known, mx, my, carrying)
    lx, ly = to_robot(sx, sy, p0, p1, sin_h, cos_h)
    _aim(st, r, _PLATFORM_TARGET, lx, ly)
    if mode == THERE:
        return 0.0, 0.0
    if mode == CLIMB:
        on_board = abs(p0 - c[_BOX_X]) < c[_BOX_HX] and abs(p1 - c[_BOX_Y]) < c[_BOX_HY]
        v, w = _climb(lx, ly, ahead, on_board, c[_CLIMB_V], c[_TURN_GAIN], c[_MAX_W])
        if trail_stuck(trail, trail_n, r, now, abs(v), c[_WINDOW], c[_STUCK_M]):
            st[r, _BACKOFF_UNTIL] = now + c[_BACKOFF]
            st[r, _BACKOFF_TURN] = 0.0
            trail_n[r] = 0
        return v, w
    return _pursue(lx, ly, now, False, 0.0, 0.0, r, c, trail, trail_n, st, pose, clear)


@nb.njit(cache=True, parallel=True)
def _command_all(active, who, obs, actions, cfg, trail, trail_n, overflow, st, n_robots):
    """_command for robot who[b] of every active match b: (linear, angular), zeros elsewhere."""
    n_match = active.shape[0]
    lin = np.zeros(n_match)
    ang = np.zeros(n_match)
    for b in nb.prange(n_match):
        if active[b]:
            r = b * n_robots + who[b]
            lin[b], ang[b] = _command(
                obs[b], actions[b], r, cfg[who[b]], trail, trail_n, overflow, st
            )
    return lin, ang


@nb.njit(cache=True, parallel=True)
def _committed_all(active, who, obs, cfg, st, n_robots):
    """_is_committed for robot who[b] of every active match b; False elsewhere."""
    n_match = active.shape[0]
    out = np.zeros(n_match, dtype=np.bool_)
    for b in nb.prange(n_match):
        if active[b]:
            out[b] = _is_committed(obs[b], st, b * n_robots + who[b], cfg[who[b]])
    return out


# --- the teacher's label ---------------------------------------------------------------------


@nb.njit(cache=True)
def _nearest_slot(f, at, count, lx, ly, unit):
    """option_for's pick among `count` slots from frame index `at`: the filled slot nearest
    (lx, ly) (the first of equals), -1 when none is filled or it is farther than _MATCH_M."""
    k, best = -1, np.inf
    for j in range(count):
        s = at + 3 * j
        if f[s + 2] > 0:
            d = math.hypot(np.float64(f[s]) * unit - lx, np.float64(f[s + 1]) * unit - ly)
            if d < best:
                k, best = j, d
    return k if k >= 0 and best <= _MATCH_M else -1


@nb.njit(cache=True)
def _option(kind, qx, qy, x, y, heading, f, c, n_options):
    """skills.option_for of the planner's intent (kind, field point) for a robot at (x, y,
    heading): the option index, -1 for none."""
    if kind == 3:  # home
        return n_options - 1 if c[_PLATFORM] > 0.5 else -1
    if kind != 1 and kind != 2:
        return -1
    h = math.radians(heading)
    s, co = math.sin(h), math.cos(h)
    lx, ly = to_robot(qx, qy, x, y, s, co)
    unit = c[_UNIT]
    route = int(c[_ROUTE])
    if kind == 1 and route:
        at = int(c[_ROUTE_AT])
        if f[at + 2] > 0:
            d = math.hypot(np.float64(f[at]) * unit - lx, np.float64(f[at + 1]) * unit - ly)
            if d <= _MATCH_M:
                return 0
    if kind == 1:
        k = _nearest_slot(f, int(c[_RING_AT]), int(c[_RINGS]), lx, ly, unit)
        return -1 if k < 0 else route + k
    k = _nearest_slot(f, int(c[_GOAL_AT]), int(c[_GOALS]), lx, ly, unit)
    return -1 if k < 0 else route + int(c[_RINGS]) + k


@nb.njit(cache=True, parallel=True)
def _labels(intent, point, pose, obs, c, n_options):
    """_option for every match as rollout.intent_label's label: (B, n_options) float32."""
    n_match = intent.shape[0]
    out = np.empty((n_match, n_options), dtype=np.float32)
    for b in nb.prange(n_match):
        k = _option(
            intent[b], point[b, 0], point[b, 1], pose[b, 0], pose[b, 1], pose[b, 2], obs[b], c,
            n_options,
        )  # fmt: skip
        for j in range(n_options):
            out[b, j] = np.nan if k < 0 else (1.0 if j == k else -1.0)
    return out
