"""Skills: a policy that picks WHAT to do, and a controller that knows HOW.

With a skill action space the policy's action is one score per option; the highest wins and a
pure-pursuit controller drives it. The options refer to the observation's own slots, so the
controller needs nothing the policy does not see (numpy only: the Jetson runs it beside the
policy, from the same observation):

    route       drive onto the first stop of the route slots (the planner's tour over the
                rings the memory knows, jetson/autonomy/route.py), with `route_option`;
    ring k      drive onto the ring in ring slot k (nearest first) with pure pursuit;
    goal j      back onto the goal in goal slot j until the clamp takes it;
    platform    drive onto the alliance's platform and stop there (with `share_platform` and
                the observation's role flag, each robot of the alliance up its own lane).

An empty slot makes its option a slow turn in place (looking for something). Control follows
sim.baselines.planner: targets far off the nose are turned to in place, a target beside the
bumper is backed away from, a robot that stops moving while driving backs off.
"""

from __future__ import annotations

import itertools
import math
from collections import deque
from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.spec import ObservationSpec


@dataclass(frozen=True)
class SkillConfig:
    route_option: bool = False  # the route's first stop (needs the observation's route slots)
    # Pure pursuit along first stop -> second stop, as the planner drives its tour (needs two
    # route slots): the robot arrives at a ring already turning for the next one.
    route_through_next: bool = False
    ring_options: int = 4  # the nearest ring slots the policy can pick from
    goal_options: int = 2
    platform: bool = True
    # The alliance's platform in its alliance frame (centre x, y and half extents), metres.
    platform_box: tuple[float, float, float, float] = (0.0, -1.5, 0.6, 0.3)
    # Two robots a side on one platform (needs the observation's role flag; off: both drive to
    # its centre and push each other off it): each climbs its own lane as the scripted alliance
    # does (platform_plan): to a stage in front of the board, facing the wall, then straight up
    # at platform_speed_mps to the hinge. The lanes are offsets from the platform's centre
    # along its long side, the tall robot's (the 24") first.
    share_platform: bool = False
    platform_lanes_m: tuple[float, float] = (-0.3, 0.4)
    platform_speed_mps: float = 0.35
    # With share_platform: how far past the hinge (toward the wall) a robot that climbs with a
    # goal stops, the tall robot's first. The goal rides behind it, over the board's field edge;
    # the robot's own weight past the hinge balances it (two goals at the hinge tip the board).
    # A robot must stay on the board to be Elevated: the 24" has the overhang's few cm, the 15"
    # about 0.16 m.
    platform_past_m: tuple[float, float] = (0.0, 0.0)
    # Split the field with the partner (needs the observation's partner block): the rings and
    # goals nearer the partner's reported position than this robot, by more than
    # split_margin_m, are the partner's; option() passes over their options for the best one
    # that is not (the best of all when none is left).
    split_with_partner: bool = False
    split_margin_m: float = 0.3
    # The endgame (0: off). In the match's last keep_clear_s seconds (the rules' protected
    # endgame, <SG3>, and a margin) option() passes over the rings and goals within
    # keep_clear_m of the other alliance's platform (platform_box turned half a turn about the
    # field's centre); touching it, or a robot on it, credits that alliance an Elevated robot.
    # In the last climb_at_s seconds the robot drives the platform skill whatever the action
    # (with the goal it carries: a goal on a Balanced board scores as Elevated).
    keep_clear_s: float = 0.0
    keep_clear_m: float = 0.5
    climb_at_s: float = 0.0
    # A tug of war (0: off; needs the goal memory's clamp flag): a robot whose clamp holds a goal
    # and that moves in ways its own commands do not move it (sideways, against them: more than
    # DRAG_M over DRAG_WINDOW_S, SkillDriver._dragged) is dragged by another robot that holds
    # the goal too and pulls harder. It lets go (`release`: the clamp opens) and drives straight
    # ahead, away from the goal at its back, for release_dragged_s, then passes over the goal
    # options for RELEASED_NO_GOALS_S.
    release_dragged_s: float = 0.0
    # Room to turn (0: off; needs the observation's partner block): a robot whose option has
    # nothing to drive to turns in place to look for one, its corners sweeping a circle; with
    # its partner nearer than partner_room_m (centre to centre) it backs straight away from the
    # partner instead (SkillDriver._look_around).
    partner_room_m: float = 0.0
    # The robot's size and top speeds (filled from the robot's config by the simulator and
    # saved with the policy, so the Jetson drives the robot the policy was trained on).
    robot_length_m: float = 0.381
    max_linear_mps: float = 1.0
    max_angular_rad_s: float = 4.8
    lookahead_m: float = 0.3
    turn_gain: float = 4.0
    turn_in_place_rad: float = 1.1
    # A goal option, once picked, is driven until the clamp closes or this long (0: off): one
    # pick is the whole manoeuvre, so a policy that tries a goal sees what it brings.
    commit_goal_s: float = 0.0
    stuck_window_s: float = 1.2
    stuck_distance_m: float = 0.04
    backoff_s: float = 0.6

    def __post_init__(self) -> None:
        counts = (self.ring_options, self.goal_options)
        if any(isinstance(n, bool) or not isinstance(n, int) or n < 0 for n in counts):
            raise ValueError(f"skills: ring_options and goal_options must be >= 0, got {counts}")
        positive = ("robot_length_m", "max_linear_mps", "max_angular_rad_s", "lookahead_m",
                    "turn_gain", "turn_in_place_rad", "stuck_window_s",
                    "platform_speed_mps")  # fmt: skip
        bad = [k for k in positive if not getattr(self, k) > 0]
        at_least_0 = ("commit_goal_s", "stuck_distance_m", "backoff_s", "split_margin_m",
                      "keep_clear_s", "keep_clear_m", "climb_at_s",
                      "release_dragged_s", "partner_room_m")  # fmt: skip
        bad += [k for k in at_least_0 if getattr(self, k) < 0]
        if len(self.platform_box) != 4 or min(self.platform_box[2:], default=0) <= 0:
            bad.append("platform_box")
        if len(self.platform_lanes_m) != 2:
            bad.append("platform_lanes_m")
        if len(self.platform_past_m) != 2 or min(self.platform_past_m, default=0) < 0:
            bad.append("platform_past_m")
        if bad:
            raise ValueError(f"skills: out of range: {bad}")

    @property
    def n_options(self) -> int:
        return int(self.route_option) + self.ring_options + self.goal_options + int(self.platform)

    def option_names(self) -> list[str]:
        names = ["route"] if self.route_option else []
        names += [f"ring{k}" for k in range(self.ring_options)]
        names += [f"goal{j}" for j in range(self.goal_options)]
        return names + (["platform"] if self.platform else [])

    def check(self, spec: ObservationSpec) -> None:
        if self.route_option and not spec.route_slots:
            raise ValueError("skills: the route option needs the observation's route slots")
        if self.route_through_next and (not self.route_option or spec.route_slots < 2):
            raise ValueError("skills: route_through_next needs the route option and 2 route slots")
        if self.n_options < 1:
            raise ValueError("skills: no options")
        if self.ring_options > spec.n_rings:
            raise ValueError(f"skills: {self.ring_options} ring options, {spec.n_rings} slots")
        if self.goal_options and (not spec.goal_memory or self.goal_options > spec.n_goals):
            raise ValueError("skills: goal options need the goal memory's slots")
        if self.share_platform and not spec.role_flag:
            raise ValueError("skills: share_platform needs the observation's role flag")
        if self.split_with_partner and not spec.partner:
            raise ValueError("skills: split_with_partner needs the observation's partner block")
        if self.climb_at_s > 0 and not self.platform:
            raise ValueError("skills: climb_at_s needs the platform option")
        if self.release_dragged_s > 0 and not spec.goal_memory:
            raise ValueError("skills: release_dragged_s needs the goal memory's clamp flag")
        if self.partner_room_m > 0 and not spec.partner:
            raise ValueError("skills: partner_room_m needs the observation's partner block")


DRAG_WINDOW_S = 2.0  # release_dragged_s: how long a robot's moves are compared with its commands
DRAG_M = 0.8  # ... and how far it must have moved against them to be dragged
RELEASED_NO_GOALS_S = 5.0  # after letting go, the goal options are passed over this long


class Trail:
    """A robot's recent positions, to tell one that drives from one that is stuck (the planner,
    the scripted chaser and the skill controller back off when it is)."""

    def __init__(self, window_s: float, min_distance_m: float) -> None:
        self.window_s = window_s
        self.min_distance_m = min_distance_m
        self._points: deque[tuple[float, float, float]] = deque()

    def push(self, now: float, x: float, y: float) -> None:
        self._points.append((now, x, y))
        while self._points and self._points[0][0] < now - self.window_s:
            self._points.popleft()

    def clear(self) -> None:
        self._points.clear()

    def stuck(self, now: float, speed: float) -> bool:
        """Commanded to drive (speed >= 0.2 m/s) for a whole window without moving."""
        p = self._points
        if speed < 0.2 or len(p) < 2 or now - p[0][0] < self.window_s * 0.95:
            return False
        return math.hypot(p[-1][1] - p[0][1], p[-1][2] - p[0][2]) < self.min_distance_m


def turn_first(
    tx: float,
    ty: float,
    max_linear_mps: float,
    max_angular_rad_s: float,
    turn_gain: float,
    turn_in_place_rad: float,
    robot_length_m: float,
) -> tuple[float, float] | None:
    """(v, w) for a target (robot frame) that no arc reaches yet: beside the bumper (back away
    while turning) or far off the nose (turn in place); None when an arc will do."""
    bearing = math.atan2(tx, ty)  # positive: to the right, a clockwise turn
    if abs(bearing) > math.radians(60) and math.hypot(tx, ty) < robot_length_m * 0.9:
        return -0.4 * max_linear_mps, math.copysign(0.6 * max_angular_rad_s, bearing)
    if abs(bearing) > turn_in_place_rad:
        w = float(np.clip(turn_gain * bearing, -max_angular_rad_s, max_angular_rad_s))
        return 0.0, w
    return None


def arc_through(
    px: float, py: float, speed: float, max_angular_rad_s: float
) -> tuple[float, float]:
    """Pure pursuit's (v, w): the arc through the lookahead point (curvature 2 x / d^2), slowed
    only where the turn-rate limit demands."""
    d2 = px * px + py * py
    curvature = 2.0 * px / d2 if d2 > 1e-9 else 0.0
    v = speed
    if abs(curvature) * v > max_angular_rad_s:
        v = max_angular_rad_s / abs(curvature)
    return v, v * curvature


def pursuit_point(path_robot: NDArray[np.floating], lookahead: float) -> tuple[float, float]:
    """The pure-pursuit goal point: where the polyline origin -> path[0] -> path[1] ... first
    leaves the circle of radius `lookahead` about the robot (robot frame). When the whole path
    lies inside the circle, its end."""
    prev = np.zeros(2)
    for q in np.asarray(path_robot, dtype=np.float64).reshape(-1, 2):
        if np.hypot(*q) >= lookahead:
            d = q - prev
            a = float(d @ d)
            b = 2.0 * float(prev @ d)
            cc = float(prev @ prev) - lookahead * lookahead
            disc = b * b - 4 * a * cc
            if a > 1e-12 and disc >= 0:
                t = (-b + math.sqrt(disc)) / (2 * a)
                t = min(max(t, 0.0), 1.0)
                p = prev + t * d
                return float(p[0]), float(p[1])
            return float(q[0]), float(q[1])
        prev = q
    return float(prev[0]), float(prev[1])


def back_onto(
    gx: float, gy: float, max_linear_mps: float, max_angular_rad_s: float, turn_gain: float
) -> tuple[float, float]:
    """(v, w) that turns the robot's back to a goal (robot frame) and reverses onto it, faster
    the better it is lined up."""
    back = math.atan2(-gx, -gy)  # bearing seen from the back: positive turns clockwise
    w = float(np.clip(turn_gain * back, -max_angular_rad_s, max_angular_rad_s))
    return -0.7 * max_linear_mps * max(0.0, math.cos(back)) ** 3, w


def _to_robot(
    point: NDArray[np.float64], pos: NDArray[np.float64], cos_h: float, sin_h: float
) -> NDArray[np.float64]:
    """Alliance frame -> robot frame (x right = (cos_h, -sin_h), y forward = (sin_h, cos_h))."""
    dx, dy = point[0] - pos[0], point[1] - pos[1]
    return np.array([dx * cos_h - dy * sin_h, dx * sin_h + dy * cos_h])


def _to_alliance(
    local: NDArray[np.float64], pos: NDArray[np.float64], cos_h: float, sin_h: float
) -> NDArray[np.float64]:
    x, y = float(local[0]), float(local[1])
    return np.array([pos[0] + x * cos_h + y * sin_h, pos[1] - x * sin_h + y * cos_h])


# platform_plan's modes: drive to the stage (pure pursuit), climb the lane, stop (there).
STAGE, CLIMB, THERE = 0, 1, 2
PLATFORM_STAGE_M = 0.65  # the stage: this far in front of the board's field edge, ...
PLATFORM_STAGGER_M = 0.45  # ... and this much farther for the other robot (turning in place
# at the stages, the two would touch)
PLATFORM_LANE_M = 0.12  # within this of its lane (along the wall) a robot climbs
PLATFORM_HINGE_M = 0.02  # within this of the hinge a climbing robot stops
PLATFORM_AIM_M = 1.0  # a climbing robot steers at its lane's point this far past the hinge


def platform_plan(
    config: SkillConfig,
    tall: bool,
    x: float,
    y: float,
    partner: tuple[float, float] | None,
    carrying: bool = False,
) -> tuple[int, float, float, float]:
    """The platform skill for a robot at alliance-frame (x, y): (mode, target x, target y,
    how far the robot stands from where it stops, toward the field: the hinge, or with
    share_platform and a goal carried, platform_past_m past it).

    Without share_platform: the platform's centre, THERE well inside it, else STAGE (pursue
    it). With it, in the robot's own lane: THERE at the hinge, CLIMB between the stage and the
    board's wall edge, else STAGE: the lane's point PLATFORM_STAGE_M in front of the board on
    the field side. A robot's lane is its
    role's (platform_lanes_m) on the side of the board where it stands against its partner
    (at the partner's alliance-frame point, None: unknown): the two never cross to reach their
    lanes. Climbing, the target is the lane's point PLATFORM_AIM_M past the hinge: steering at
    it holds the robot along its lane (its point at the hinge swings about as it nears)."""
    cx, cy, hx, hy = config.platform_box
    if not config.share_platform:
        inside = abs(x - cx) < hx - 0.2 and abs(y - cy) < hy - 0.2
        return (THERE if inside else STAGE), cx, cy, 0.0
    # In (depth, length) coordinates: the lanes run along the depth; the field side of the
    # board is toward the field's centre (the alliance frame's origin).
    flip = hx > hy
    c_d, c_l, h_d, d, ell = (cy, cx, hy, y, x) if flip else (cx, cy, hx, x, y)
    side = 1.0 if c_d <= 0 else -1.0
    lane = config.platform_lanes_m[0 if tall else 1]
    if partner is not None:
        mate = partner[0] if flip else partner[1]
        lane = abs(lane) if ell > mate else -abs(lane)
    lane += c_l
    ahead = (d - c_d) * side  # from the hinge toward the field
    stage = h_d + PLATFORM_STAGE_M + (0.0 if tall else PLATFORM_STAGGER_M)
    mode, t_d = STAGE, c_d + side * stage
    if abs(ell - lane) < PLATFORM_LANE_M and -h_d < ahead < stage + 0.1:
        mode, t_d = (THERE if abs(ahead) < PLATFORM_HINGE_M else CLIMB), c_d - side * PLATFORM_AIM_M
    if carrying:  # the stop is past the hinge: its weight there balances the goal behind it
        ahead += config.platform_past_m[0 if tall else 1]
        if mode != STAGE:
            mode = THERE if abs(ahead) < PLATFORM_HINGE_M else CLIMB
    return ((mode, lane, t_d) if flip else (mode, t_d, lane)) + (ahead,)


def climb(
    tx: float,
    ty: float,
    ahead: float,
    on_board: bool,
    speed: float,
    turn_gain: float,
    max_angular: float,
) -> tuple[float, float]:
    """(v, w) up a lane to the hinge, `ahead` metres toward the field from it (< 0: past it),
    steering at the lane's robot-frame point (tx, ty) beyond it: off the board, turn to face it
    first; then on at most `speed`, slowing into the hinge (backing onto it from past it,
    straight), steering gently (turning in place on a tilted board slides a robot sideways)."""
    bearing = math.atan2(tx, ty)
    if not on_board and ahead > 0 and abs(bearing) > 0.25:
        return 0.0, max(-max_angular, min(max_angular, turn_gain * bearing))
    v = max(-speed, min(speed, 2.0 * ahead))
    if v < 0:
        return v, 0.0
    return v * max(0.0, math.cos(bearing)), max(-1.5, min(1.5, turn_gain * bearing))


def _crosses(
    x0: float, y0: float, x1: float, y1: float, cx: float, cy: float, gx: float, gy: float
) -> bool:
    """Whether the segment (x0, y0) -> (x1, y1) passes through the open box about (cx, cy) with
    half extents (gx, gy) (the slab test)."""
    t0, t1 = 0.0, 1.0
    for p, d, lo, hi in ((x0, x1 - x0, cx - gx, cx + gx), (y0, y1 - y0, cy - gy, cy + gy)):
        if abs(d) < 1e-12:
            if not lo < p < hi:
                return False
            continue
        a, b = (lo - p) / d, (hi - p) / d
        t0, t1 = max(t0, min(a, b)), min(t1, max(a, b))
        if t0 >= t1:
            return False
    return True


KEEP_CLEAR_CORNER_M = 0.05  # a detour's corner lies this far outside the kept-clear box


def around(
    x: float, y: float, tx: float, ty: float, box: tuple[float, float, float, float], margin: float
) -> tuple[float, float]:
    """Where a robot at (x, y) steers on its way to (tx, ty), all in one frame, keeping out of a
    box (centre x, y, half extents) grown by `margin`: the target when the straight way misses
    the grown box, else the nearer way round: the grown box's corner (KEEP_CLEAR_CORNER_M
    further out) on the field's side of the box (the field's centre is the frame's origin;
    the box stands against a wall) that the robot sees and that makes the way shortest."""
    cx, cy, hx, hy = box
    gx, gy = hx + margin, hy + margin
    if not _crosses(x, y, tx, ty, cx, cy, gx, gy):
        return tx, ty
    ox, oy = gx + KEEP_CLEAR_CORNER_M, gy + KEEP_CLEAR_CORNER_M
    if abs(cx) >= abs(cy):
        corners = ((cx - math.copysign(ox, cx), cy - oy), (cx - math.copysign(ox, cx), cy + oy))
    else:
        corners = ((cx - ox, cy - math.copysign(oy, cy)), (cx + ox, cy - math.copysign(oy, cy)))
    best, way = (tx, ty), math.inf
    for px, py in corners:
        if _crosses(x, y, px, py, cx, cy, gx, gy):
            continue
        d = math.hypot(px - x, py - y) + math.hypot(tx - px, ty - py)
        if d < way:
            best, way = (px, py), d
    return best


def leave(
    x: float, y: float, cos_h: float, sin_h: float, box: tuple[float, float, float, float],
    margin: float, speed: float,
) -> tuple[float, float] | None:  # fmt: skip
    """(v, w) that takes a robot at (x, y) heading (cos_h, sin_h) out of a box grown by `margin`
    without turning (a turning robot's corners sweep wider): straight forward or back, whichever
    leaves the box's nearest side, or, standing along that side, whichever way heads toward
    the field's centre; None outside the grown box."""
    cx, cy, hx, hy = box
    dx, dy = x - cx, y - cy
    if not (abs(dx) < hx + margin and abs(dy) < hy + margin):
        return None
    ax, ay = dx - max(-hx, min(hx, dx)), dy - max(-hy, min(hy, dy))  # from the box's nearest point
    if ax == 0.0 and ay == 0.0:
        ax, ay = dx, dy
    ahead = ax * sin_h + ay * cos_h  # along the heading (robot frame's y)
    if abs(ahead) >= 0.5 * math.hypot(ax, ay):
        return math.copysign(speed, ahead), 0.0
    home = -x * sin_h - y * cos_h
    return (speed if home >= 0 else -speed), 0.0


def skill_config_from_dict(data: dict[str, Any]) -> SkillConfig:
    known = {f.name for f in fields(SkillConfig)}
    unknown = sorted(set(data) - known)
    if unknown:
        raise ValueError(f"skills: unknown keys {unknown}")
    values = {k: tuple(v) if isinstance(v, list) else v for k, v in data.items()}
    return SkillConfig(**values)


class SkillDriver:
    """One robot's controller; reset() at the start of every match."""

    def __init__(self, config: SkillConfig, spec: ObservationSpec) -> None:
        config.check(spec)
        self.config = config
        self.spec = spec
        self.v_max = config.max_linear_mps
        self.w_max = config.max_angular_rad_s
        self._trail = Trail(config.stuck_window_s, config.stuck_distance_m)
        self._backoff_until = -1.0
        self._backoff_turn = 1.0
        self._commit_point: NDArray[np.float64] | None = None  # alliance frame
        # The endgame (keep_clear_s): the other alliance's platform, turned about the centre;
        # whether this command keeps clear of it, and the robot's alliance-frame pose.
        cx, cy, hx, hy = config.platform_box
        self._their_box = (-cx, -cy, hx, hy)
        self._clear = False
        self._pose = (0.0, 0.0, 1.0, 0.0)
        self._commit_until = -1.0
        # What the last command() drove to: ("ring" | "goal" | "platform", robot-frame point
        # of that moment, metres); None when it searched or was backing off when called (a
        # back-off that starts within the call keeps the target it was driving to); the
        # partner report's claim (jetson.decide.Decider.claim).
        self.target: tuple[str, tuple[float, float]] | None = None
        # The option the last command() drove (option(action, obs): split_with_partner may
        # pass the best score over); None while a goal manoeuvre or a back-off ran instead.
        self.driven: int | None = None
        # Whether the last command() lets go of the goal (release_dragged_s): the clamp opens.
        self.release = False
        # Its commands with the pose each was given at: (t, x, y, sin_h, cos_h, linear m/s).
        self._moves: deque[tuple[float, float, float, float, float, float]] = deque()
        self._release_until = -1.0
        self._no_goals_until = -1.0

    def reset(self) -> None:
        self._trail.clear()
        self._backoff_until = -1.0
        self._commit_point = None
        self.target = None
        self.driven = None
        self.release = False
        self._moves.clear()
        self._release_until = -1.0
        self._no_goals_until = -1.0

    def committed(self, obs: NDArray[np.floating]) -> bool:
        """Whether the next command() ignores its action: a goal manoeuvre is under way (the
        clamp still open and its time not up)."""
        if self._commit_point is None:
            return False
        s = self.spec
        f = np.asarray(obs, dtype=np.float64)[: s.frame_size]
        clamped = s.goal_memory and f[s.scalar_index("clamped")] > 0.5
        if clamped or float(f[0]) * s.match_length_s >= self._commit_until:
            self._commit_point = None
            return False
        return True

    def option(self, action: NDArray[np.floating], obs: NDArray[np.floating] | None = None) -> int:
        """The option the action picks: the highest score (the first of equals). With the
        observation: the platform in the match's last climb_at_s seconds; else the highest
        whose ring or goal is neither the partner's (split_with_partner: nearer the partner
        than this robot by more than split_margin_m) nor, in the last keep_clear_s seconds,
        beside the other alliance's platform (within keep_clear_m), the highest of all when
        every one is."""
        a = np.asarray(action, dtype=np.float64).reshape(-1)[: self.config.n_options]
        best = int(np.argmax(a))
        s, c = self.spec, self.config
        if obs is None:
            return best
        f = np.asarray(obs, dtype=np.float64)[: s.frame_size]
        left = s.match_length_s * (1.0 - float(f[0]))
        if c.climb_at_s > 0 and left <= c.climb_at_s:
            return c.n_options - 1
        mate = self._partner(f) if c.split_with_partner else None
        split = mate is not None
        clear = c.keep_clear_s > 0 and left <= c.keep_clear_s
        no_goals = float(f[0]) * s.match_length_s < self._no_goals_until
        if not (split or clear or no_goals):
            return best
        first_goal = int(c.route_option) + c.ring_options
        unit = s.length_unit_m
        mx, my = mate if mate is not None else (0.0, 0.0)
        cx, cy, hx, hy = self._their_box
        for k in np.argsort(-a, kind="stable"):
            if no_goals and first_goal <= k < first_goal + c.goal_options:
                continue
            point = self._option_point(f, int(k))
            if point is None:
                return int(k)
            px, py = point
            if split and math.hypot(px, py) > math.hypot(px - mx, py - my) + c.split_margin_m:
                continue
            if clear:
                q = _to_alliance(np.array(point), f[1:3] * unit, float(f[3]), float(f[4]))
                m = c.keep_clear_m
                if abs(q[0] - cx) < hx + m and abs(q[1] - cy) < hy + m:
                    continue
            return int(k)
        return best

    def _option_point(self, f: NDArray[np.float64], k: int) -> tuple[float, float] | None:
        """The robot-frame point (metres) of option k's ring or goal; None for the platform
        and an empty slot."""
        s, c = self.spec, self.config
        route = int(c.route_option)
        if k < route:
            at = s.route_offset
        elif k < route + c.ring_options:
            at = s.ring_offset + 3 * (k - route)
        elif k < route + c.ring_options + c.goal_options:
            at = s.goal_offset + 3 * (k - route - c.ring_options)
        else:
            return None
        if not f[at + 2] > 0:
            return None
        return float(f[at]) * s.length_unit_m, float(f[at + 1]) * s.length_unit_m

    def command(
        self, obs: NDArray[np.floating], action: NDArray[np.floating]
    ) -> tuple[float, float]:
        """(linear m/s, angular rad/s clockwise) for the stacked observation and the action;
        `release` says whether the clamp is to open with it."""
        s, c = self.spec, self.config
        f = np.asarray(obs, dtype=np.float64)[: s.frame_size]
        now = float(f[0]) * s.match_length_s
        self.release = False
        if c.release_dragged_s <= 0:
            return self._command(f, action, now)
        x, y = float(f[1]) * s.length_unit_m, float(f[2]) * s.length_unit_m
        clamped = float(f[s.scalar_index("clamped")]) > 0.5
        sin_h, cos_h = float(f[4]), float(f[3])
        if now < self._release_until or (clamped and self._dragged(now, x, y, sin_h, cos_h)):
            if now >= self._release_until:  # it lets go now
                self._release_until = now + c.release_dragged_s
                self._no_goals_until = now + RELEASED_NO_GOALS_S
                self._commit_point = None
                self._moves.clear()
            self._trail.push(now, x, y)
            self.target = self.driven = None
            self.release = True
            return 0.5 * self.v_max, 0.0
        v, w = self._command(f, action, now)
        self._moves.append((now, x, y, sin_h, cos_h, v))
        while self._moves[0][0] < now - DRAG_WINDOW_S:
            self._moves.popleft()
        return v, w

    def _dragged(self, now: float, x: float, y: float, sin_h: float, cos_h: float) -> bool:
        """Over the last DRAG_WINDOW_S (nearly all of it recorded) the robot moved more than
        DRAG_M in a way its own commands do not move it: sideways (a differential drive cannot),
        back against the way it was told to drive, or along while told to turn in place. Each
        step's move is split along and across the mean of its two headings (arcs move along)
        and the parts are summed with their signs, so the pose's noise cancels out and a robot
        that is slower than told (speeding up, or held) is not dragged."""
        m = (*self._moves, (now, x, y, sin_h, cos_h, 0.0))
        if len(m) < 3 or now - m[0][0] < 0.9 * DRAG_WINDOW_S:
            return False
        side = against = still = 0.0
        for a, b in itertools.pairwise(m):
            hx, hy = a[3] + b[3], a[4] + b[4]  # the mean heading's (sin, cos), unnormalised
            n = math.hypot(hx, hy)
            if n < 1e-9:
                continue  # half a turn in one step: no mean heading
            dx, dy = b[1] - a[1], b[2] - a[2]
            along = (dx * hx + dy * hy) / n
            side += (dx * hy - dy * hx) / n
            told = a[5]
            if abs(told) < 0.05:
                still += along
            else:
                against -= along if told > 0 else -along
        return max(abs(side), against, abs(still)) > DRAG_M

    def _command(
        self, f: NDArray[np.float64], action: NDArray[np.floating], now: float
    ) -> tuple[float, float]:
        s, c = self.spec, self.config
        unit = s.length_unit_m
        pos = f[1:3] * unit
        self._trail.push(now, float(pos[0]), float(pos[1]))
        self.target = None
        self.driven = None
        self._pose = (float(pos[0]), float(pos[1]), float(f[3]), float(f[4]))
        self._clear = c.keep_clear_s > 0 and s.match_length_s - now <= c.keep_clear_s
        if self._clear:
            out = leave(*self._pose, self._their_box, c.keep_clear_m, 0.5 * self.v_max)
            if out is not None:
                return out
        if self.committed(f):
            local = _to_robot(self._commit_point, pos, float(f[3]), float(f[4]))
            self.target = ("goal", (float(local[0]), float(local[1])))
            if now < self._backoff_until:
                return -0.6 * self.v_max, self._backoff_turn * 0.5 * self.w_max
            return self._reverse_onto(local, now)
        if now < self._backoff_until:
            return -0.6 * self.v_max, self._backoff_turn * 0.5 * self.w_max
        k = self.driven = self.option(action, f)
        if c.route_option:
            if k == 0:
                slot = f[s.route_offset : s.route_offset + 3]
                if slot[2] <= 0:
                    return self._look_around(f)
                after = None
                nxt = f[s.route_offset + 3 : s.route_offset + 6]  # the second stop's slot
                if c.route_through_next and nxt[2] > 0:
                    after = nxt[:2] * unit
                self.target = ("ring", _point(slot, unit))
                return self._pursue(slot[:2] * unit, now, after)
            k -= 1
        if k < c.ring_options:
            slot = f[s.ring_offset + 3 * k : s.ring_offset + 3 * k + 3]
            if slot[2] <= 0:
                return self._look_around(f)
            self.target = ("ring", _point(slot, unit))
            return self._pursue(slot[:2] * unit, now)
        k -= c.ring_options
        if k < c.goal_options:
            slot = f[s.goal_offset + 3 * k : s.goal_offset + 3 * k + 3]
            if slot[2] <= 0:
                return self._look_around(f)
            if c.commit_goal_s > 0:
                self._commit_point = _to_alliance(slot[:2] * unit, pos, float(f[3]), float(f[4]))
                self._commit_until = now + c.commit_goal_s
            self.target = ("goal", _point(slot, unit))
            return self._reverse_onto(slot[:2] * unit, now)
        return self._platform(f, pos)

    # --- the skills -------------------------------------------------------------------------

    def _look_around(self, f: NDArray[np.float64]) -> tuple[float, float]:
        """Nothing to drive to: turn in place to find something, or with the partner within
        partner_room_m, back straight away from it (a turning robot's corners sweep wider than
        its sides: two robots side by side touched every turn)."""
        room = self.config.partner_room_m
        mate = self._partner(f) if room > 0 else None
        if mate is not None and math.hypot(*mate) < room:
            return (-0.3 if mate[1] > 0 else 0.3) * self.v_max, 0.0
        return 0.0, 0.3 * self.w_max

    def _partner(self, f: NDArray[np.float64]) -> tuple[float, float] | None:
        """The partner's robot-frame position (metres) from the observation's partner block;
        None without the block or a fresh report."""
        s = self.spec
        if not s.partner or not f[s.partner_offset + 2] > 0.5:
            return None
        at, unit = s.partner_offset, s.length_unit_m
        return float(f[at]) * unit, float(f[at + 1]) * unit

    def _pursue(
        self, target: NDArray[np.float64], now: float, after: NDArray[np.float64] | None = None
    ) -> tuple[float, float]:
        c = self.config
        tx, ty = float(target[0]), float(target[1])
        if self._clear:
            # The endgame: the way round the other alliance's platform (alliance frame).
            x, y, cos_h, sin_h = self._pose
            ax, ay = x + tx * cos_h + ty * sin_h, y - tx * sin_h + ty * cos_h
            px, py = around(x, y, ax, ay, self._their_box, c.keep_clear_m)
            if (px, py) != (ax, ay):
                dx, dy = px - x, py - y
                tx, ty, after = dx * cos_h - dy * sin_h, dx * sin_h + dy * cos_h, None
                target = np.array([tx, ty])
        turn = turn_first(
            tx, ty, self.v_max, self.w_max, c.turn_gain, c.turn_in_place_rad, c.robot_length_m
        )
        if turn is not None:
            return turn
        if after is None:
            # This arithmetic, not pursuit_point's equal one, keeps the policies measured with it
            # driving bit for bit as they were.
            d = math.hypot(tx, ty)
            px, py = (
                (tx, ty) if d <= c.lookahead_m else (tx * c.lookahead_m / d, ty * c.lookahead_m / d)
            )
        else:
            px, py = pursuit_point(np.array([target, after]), c.lookahead_m)
        v, w = arc_through(px, py, self.v_max, self.w_max)
        if self._trail.stuck(now, v):
            self._backoff_until = now + c.backoff_s
            self._backoff_turn = -1.0 if math.atan2(tx, ty) > 0 else 1.0
            self._trail.clear()
        return v, w

    def _reverse_onto(self, goal: NDArray[np.float64], now: float) -> tuple[float, float]:
        gx, gy = float(goal[0]), float(goal[1])
        dist = math.hypot(gx, gy)
        if dist > 1.0:
            # Drive to a point half a metre short of it first, nose on.
            stage = goal * (1.0 - 0.5 / dist)
            return self._pursue(stage, now)
        v, w = back_onto(gx, gy, self.v_max, self.w_max, self.config.turn_gain)
        if self._trail.stuck(now, abs(v)):
            self._backoff_until = now + self.config.backoff_s / 2
            self._backoff_turn = 1.0
            self._trail.clear()
            return 0.5 * self.v_max, 0.0
        return v, w

    def _platform(self, f: NDArray[np.float64], pos: NDArray[np.float64]) -> tuple[float, float]:
        s, c = self.spec, self.config
        tall = s.role_flag and float(f[s.scalar_index("tall")]) > 0.5
        partner = None
        if c.share_platform and (local := self._partner(f)) is not None:
            mate = _to_alliance(np.array(local), pos, float(f[3]), float(f[4]))
            partner = (float(mate[0]), float(mate[1]))
        carrying = s.goal_memory and float(f[s.scalar_index("clamped")]) > 0.5
        mode, tx, ty, ahead = platform_plan(
            c, tall, float(pos[0]), float(pos[1]), partner, carrying
        )
        local = _to_robot(np.array([tx, ty]), pos, float(f[3]), float(f[4]))
        self.target = ("platform", (float(local[0]), float(local[1])))
        if mode == THERE:
            return 0.0, 0.0
        if mode == CLIMB:
            cx, cy, hx, hy = c.platform_box
            on_board = abs(pos[0] - cx) < hx and abs(pos[1] - cy) < hy
            v, w = climb(
                float(local[0]), float(local[1]), ahead, on_board, c.platform_speed_mps,
                c.turn_gain, self.w_max,
            )  # fmt: skip
            now = float(f[0]) * s.match_length_s
            if self._trail.stuck(now, abs(v)):
                # The board's field edge is up (a load on its wall half), or something stands
                # in the lane: straight back down it.
                self._backoff_until = now + c.backoff_s
                self._backoff_turn = 0.0
                self._trail.clear()
            return v, w
        return self._pursue(local, float(f[0]) * self.spec.match_length_s)


def _point(slot: NDArray[np.float64], unit: float) -> tuple[float, float]:
    """A slot's robot-frame point in metres."""
    return float(slot[0] * unit), float(slot[1] * unit)


def option_for(
    kind: str,
    point_robot_xy: NDArray[np.floating] | None,
    obs: NDArray[np.floating],
    spec: ObservationSpec,
    config: SkillConfig,
    match_m: float = 0.3,
) -> int | None:
    """The option that does what a planner intends (sim.baselines.planner.Planner.intent, its
    point in the robot frame): the ring or goal slot nearest its target, or the platform; None
    when no option does it (a target outside the slots, backing off, searching)."""
    f = np.asarray(obs, dtype=np.float64)[: spec.frame_size]
    unit = spec.length_unit_m
    if kind == "home":
        return config.n_options - 1 if config.platform else None
    if point_robot_xy is None or kind not in ("ring", "goal"):
        return None
    route = int(config.route_option)
    if kind == "ring" and route:
        stop = f[spec.route_offset : spec.route_offset + 3]
        if stop[2] > 0 and np.hypot(*(stop[:2] * unit - np.asarray(point_robot_xy))) <= match_m:
            return 0
    offset, count, first = (
        (spec.ring_offset, config.ring_options, route)
        if kind == "ring"
        else (spec.goal_offset, config.goal_options, route + config.ring_options)
    )
    if count == 0:
        return None
    slots = f[offset : offset + 3 * count].reshape(count, 3)
    filled = slots[:, 2] > 0
    if not filled.any():
        return None
    d = np.hypot(*(slots[:, :2] * unit - np.asarray(point_robot_xy)[None, :]).T)
    d[~filled] = np.inf
    k = int(np.argmin(d))
    return first + k if d[k] <= match_m else None
