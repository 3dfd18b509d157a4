"""Building the observation: one frame from what the robot knows, and the stack of recent frames.

A frame (RobotView -> build_frame) holds the match time, the robot's pose in its alliance frame,
the rings it holds, then the slots ObservationSpec lays out: other robots, remembered goals,
route stops and rings, each in the robot frame, nearest first. Blue sees the field rotated 180
degrees (geometry.to_alliance_frame), so mirrored places give identical observations. Noise
(training only, when an rng is given): own x, y get uniform +-position_noise_m, each ring or
robot coordinate is scaled by 1 + uniform +-relative_noise; empty slots and flags never do.
With spec.partner the partner block follows the other robots' slots: the partner's reported
position and its claimed target in the robot frame (PartnerView; own-position noise on each),
its clamp and its rings; all zero when there is no fresh report.
FrameStack keeps the current frame and the n_stack before it, newest first.
"""

from __future__ import annotations

import math
from collections import deque
from dataclasses import dataclass, field

import numpy as np
from numpy.typing import ArrayLike, NDArray

from jetson.autonomy.geometry import AllianceName, pose_to_alliance_frame
from jetson.autonomy.spec import REMEMBERED, SEEN, ObservationSpec
from jetson.errors import ObservationError


@dataclass(frozen=True)
class PartnerView:
    """The alliance partner as the newest report over VEXlink tells it (jetson.partner), in the
    receiving robot's frame, metres; None where the report has no pose or claims nothing."""

    xy: tuple[float, float] | None
    clamped: bool
    rings: int  # 0 when the partner has no ring counter
    claim_xy: tuple[float, float] | None


@dataclass
class RobotView:
    """What the robot knows at one control step, in the units the sensors give."""

    x: float  # GPS field frame, metres
    y: float
    heading_deg: float  # GPS heading, clockwise from +y
    alliance: AllianceName
    time_s: float  # elapsed match time
    rings_robot_xy: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    rings_held: int = 0
    others_robot_xy: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    # Rings known but not in view (RingMemory.recall), robot frame: slots with ok = 0.5.
    rings_remembered_xy: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    goal_clamped: bool = False  # the Brain's clamp holds a mobile goal
    # Mobile goals the robot could score with, robot frame (GoalMemory.observe).
    goals_robot_xy: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    # The goals a fresh camera result shows, (N, 3) x, y robot frame and colour code
    # (goal_colours), for a goal memory corrected by sight (spec.goal_sight); None: no fresh
    # result (nothing to correct by).
    goals_seen_robot: NDArray[np.float64] | None = None
    # The route's stops, robot frame, tour order (RingMemory with spec.route_slots).
    route_robot_xy: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    intake_fills: bool = True  # the intake has a capacity (False: it never fills)
    tall: bool = False  # the alliance's robot that reaches the high branch (spec role_flag)
    # The alliance partner's newest report (spec.partner); None without a fresh one.
    partner: PartnerView | None = None


def as_points(value: ArrayLike, what: str) -> NDArray[np.float64]:
    arr = np.asarray(value, dtype=np.float64)
    if arr.size == 0:
        return np.zeros((0, 2))
    if arr.ndim != 2 or arr.shape[1] != 2:
        raise ObservationError(f"{what} must have shape (N, 2), got {arr.shape}")
    if not np.all(np.isfinite(arr)):
        raise ObservationError(f"{what} contains NaN or infinity")
    return arr


def _fill_slots(
    out: NDArray[np.float32],
    offset: int,
    n_slots: int,
    points: NDArray[np.float64],
    unit: float,
    relative_noise: float,
    rng: np.random.Generator | None,
    ok: NDArray[np.float64] | None = None,
) -> None:
    if len(points) == 0:
        return
    d2 = np.einsum("ij,ij->i", points, points)
    count = min(n_slots, len(points))
    # argsort with a stable kind keeps equal-distance items in input order: deterministic.
    order = np.argsort(d2, kind="stable")[:count]
    nearest = points[order]
    if rng is not None and relative_noise > 0:
        nearest = nearest * (1.0 + rng.uniform(-relative_noise, relative_noise, nearest.shape))
    block = out[offset : offset + 3 * count].reshape(count, 3)
    block[:, :2] = nearest / unit
    block[:, 2] = 1.0 if ok is None else ok[order]


@dataclass(frozen=True)
class _Layout:
    """Where a spec puts things in a frame (ObservationSpec's offsets, which it works out on
    every read)."""

    frame_size: int
    n_scalars: int
    partner_offset: int
    goal_offset: int
    route_offset: int
    ring_offset: int
    clamped: int  # the scalars' indices; -1 when the spec has none
    fills: int
    tall: int


# Layouts by spec, kept with their spec so that an id is never mistaken for another's.
_LAYOUTS: dict[int, tuple[ObservationSpec, _Layout]] = {}


def _layout(spec: ObservationSpec) -> _Layout:
    hit = _LAYOUTS.get(id(spec))
    if hit is not None and hit[0] is spec:
        return hit[1]
    scalars = spec.scalars
    lay = _Layout(
        frame_size=spec.frame_size,
        n_scalars=len(scalars),
        partner_offset=spec.partner_offset,
        goal_offset=spec.goal_offset,
        route_offset=spec.route_offset,
        ring_offset=spec.ring_offset,
        clamped=scalars.index("clamped") if "clamped" in scalars else -1,
        fills=scalars.index("fills") if "fills" in scalars else -1,
        tall=scalars.index("tall") if "tall" in scalars else -1,
    )
    if len(_LAYOUTS) >= 64:  # a process that makes many specs keeps only the recent ones
        _LAYOUTS.clear()
    _LAYOUTS[id(spec)] = (spec, lay)
    return lay


def build_frame(
    spec: ObservationSpec, view: RobotView, rng: np.random.Generator | None = None
) -> NDArray[np.float32]:
    """One observation frame. Noise is added only when `rng` is given."""
    values = (view.x, view.y, view.heading_deg, view.time_s)
    if not all(math.isfinite(float(v)) for v in values):
        raise ObservationError(f"pose and time must be finite, got {values}")
    if view.alliance not in ("red", "blue"):
        raise ObservationError(f"alliance must be 'red' or 'blue', got {view.alliance!r}")
    if view.rings_held < 0:
        raise ObservationError(f"rings_held must be >= 0, got {view.rings_held}")
    rings = as_points(view.rings_robot_xy, "rings_robot_xy")
    remembered = as_points(view.rings_remembered_xy, "rings_remembered_xy")
    others = as_points(view.others_robot_xy, "others_robot_xy")
    unit = spec.length_unit_m
    lay = _layout(spec)
    out = np.zeros(lay.frame_size, dtype=np.float32)
    x, y, heading = pose_to_alliance_frame(view.x, view.y, view.heading_deg, view.alliance)
    if rng is not None and spec.position_noise_m > 0:
        dx, dy = rng.uniform(-spec.position_noise_m, spec.position_noise_m, 2)
        x, y = x + dx, y + dy
    h = math.radians(heading)
    out[0] = min(max(view.time_s / spec.match_length_s, 0.0), 1.0)
    out[1] = x / unit
    out[2] = y / unit
    out[3] = math.cos(h)
    out[4] = math.sin(h)
    out[5] = view.rings_held / spec.ring_capacity_norm
    if spec.goal_memory:
        out[lay.clamped] = 1.0 if view.goal_clamped else 0.0
        goals = as_points(view.goals_robot_xy, "goals_robot_xy")
        _fill_slots(out, lay.goal_offset, spec.n_goals, goals, unit, 0.0, None)
    if spec.intake_flag:
        out[lay.fills] = 1.0 if view.intake_fills else 0.0
    if spec.role_flag:
        out[lay.tall] = 1.0 if view.tall else 0.0
    rel = spec.relative_noise
    _fill_slots(out, lay.n_scalars, spec.n_other_robots, others, unit, rel, rng)
    ok = None
    if len(remembered):
        ok = np.concatenate([np.full(len(rings), SEEN), np.full(len(remembered), REMEMBERED)])
        rings = np.concatenate([rings, remembered])
    _fill_slots(out, lay.ring_offset, spec.n_rings, rings, unit, spec.relative_noise, rng, ok)
    if spec.partner and view.partner is not None:
        _fill_partner(out, lay.partner_offset, spec, view.partner, rng)
    if spec.route_slots:
        route = as_points(view.route_robot_xy, "route_robot_xy")[: spec.route_slots]
        if rng is not None and rel > 0:
            route = route * (1.0 + rng.uniform(-rel, rel, route.shape))
        block = out[lay.route_offset : lay.route_offset + 3 * len(route)].reshape(-1, 3)
        block[:, :2] = route / unit  # tour order, not nearest first
        block[:, 2] = 1.0
    return out


def _fill_partner(
    out: NDArray[np.float32],
    offset: int,
    spec: ObservationSpec,
    partner: PartnerView,
    rng: np.random.Generator | None,
) -> None:
    """The partner block (spec.PARTNER_NAMES) at out[offset:]: its position and its claim
    (each with uniform +-position_noise_m when an rng is given: reports carry GPS poses), its
    clamp and its rings."""
    unit, noise = spec.length_unit_m, spec.position_noise_m
    block = out[offset : offset + 8]
    for at, xy in ((0, partner.xy), (5, partner.claim_xy)):
        if xy is None:
            continue
        x, y = float(xy[0]), float(xy[1])
        if not (math.isfinite(x) and math.isfinite(y)):
            raise ObservationError(f"the partner's points must be finite, got {xy}")
        if rng is not None and noise > 0:
            dx, dy = rng.uniform(-noise, noise, 2)
            x, y = x + dx, y + dy
        block[at : at + 3] = (x / unit, y / unit, 1.0)
    block[3] = 1.0 if partner.clamped else 0.0
    block[4] = max(partner.rings, 0) / spec.ring_capacity_norm


class FrameStack:
    """The last n_stack + 1 frames as one flat vector, newest first."""

    def __init__(self, spec: ObservationSpec) -> None:
        self.spec = spec
        self._frames: deque[NDArray[np.float32]] = deque(maxlen=spec.n_frames)

    def _check(self, frame: NDArray[np.float32]) -> NDArray[np.float32]:
        f = np.asarray(frame, dtype=np.float32)
        if f.shape != (self.spec.frame_size,):
            raise ObservationError(
                f"frame must have shape ({self.spec.frame_size},), got {f.shape}"
            )
        return f

    def reset(self, frame: NDArray[np.float32]) -> NDArray[np.float32]:
        f = self._check(frame)
        self._frames.clear()
        for _ in range(self.spec.n_frames):
            self._frames.append(f)
        return self.observation()

    def push(self, frame: NDArray[np.float32]) -> NDArray[np.float32]:
        if not self._frames:
            return self.reset(frame)
        self._frames.appendleft(self._check(frame))
        return self.observation()

    def observation(self) -> NDArray[np.float32]:
        if not self._frames:
            raise ObservationError("FrameStack.observation() before reset()")
        return np.concatenate(self._frames)
