"""The policy's input: one versioned, documented observation shared by the simulator and the Jetson.

numpy only: the Jetson imports this module (and sim.geometry) without PyBullet or Gymnasium.

One frame (version 1), with `n_other_robots` = R and `n_rings` = K:

    index            name              meaning
    0                time              elapsed match time / match_length_s, clipped to [0, 1]
    1, 2             x, y              own GPS position in the ALLIANCE frame / length_unit_m
    3, 4             cos_h, sin_h      cos and sin of own heading in the alliance frame
                                       (heading clockwise from +y, so sin_h is the forward
                                       vector's x and cos_h its y)
    5                held              rings held / ring_capacity_norm
    6 + 3r ..        robot_r x, y, ok  R other robots (nearest first) in the ROBOT frame
                                       (x right, y forward) / length_unit_m, ok = 1 when known
    6 + 3R + 3k ..   ring_k x, y, ok   K nearest visible rings in the ROBOT frame, sorted by
                                       distance, / length_unit_m; ok = 1 for a ring, 0 for an
                                       empty slot (whose x, y are 0 and never get noise)

Version 2 adds an optional ring memory (`ring_memory`): the ring slots then hold the K nearest
rings the robot KNOWS about, not only those in view. The memory (RingMemory) starts from the
field's starting layout (`prior_rings`, alliance frame, metres), takes every ring the camera
reports, and forgets a remembered ring once the camera looks at its place and does not see it,
or once the robot stands on it (collected or pushed away; with `memory_forget_intake`, once it
is inside the intake's reach: a ring the robot passes beside stays known; with `memory_push` as
well, a known ring the rest of the body drives over is moved out to the body's edge, where a
bumper shoves a real ring). ok is 1 for a ring
in view now and 0.5 for one remembered. This is the knowledge a team's route planner starts a
match with; a policy that sees only the camera's cone has to learn the layout from its own pose.
Where "the camera looks" is a cone around the robot's centre (`memory_view` "cone", what the
policies so far were trained with) or the camera's own picture ("camera": RingMemory is given
the camera's mount and intrinsics, MemoryCamera), which forgets no ring the camera cannot show.

Version 3 adds an optional goal memory (`goal_memory`): a scalar `clamped` after `held` (1
while the robot's clamp holds a mobile goal, from the Brain's State.goal_clamped) and `n_goals`
goal slots between the other robots and the rings: the nearest mobile goals the robot could
score with (its alliance's and the neutral ones), robot frame, ok = 1 for a filled slot. Nothing
on the robot sees goals, so the memory (GoalMemory) is dead reckoning from the field's starting
layout (`prior_goals`, alliance frame): when the clamp closes, the remembered goal nearest the
clamp point behind the robot is the one it holds (and leaves the slots); when the clamp opens,
the goal stays at the clamp point; a goal whose place the robot's centre comes within
`goal_forget_m` of cannot be there any more (pushed away) and is forgotten.

Version 4 adds optional route slots (`route_slots`, with the ring memory): between the goal
slots and the ring slots, the first stops of the tour the planner would drive over the rings the
memory knows (sim/route.py: a nearest-neighbour tour from each of the cheapest first stops,
2-opt, as many stops as the intake has room for, the current first stop kept unless another is
clearly cheaper), robot frame, in tour order, ok = 1 for a filled slot. The ring slots say which
rings are near; the route slots say which are worth the trip.

The observation is the current frame followed by the `n_stack` previous ones, newest first:
obs[f * frame_size + i] is item i of the frame f control steps ago. At reset every slot holds the
first frame. Defaults: K = 10, R = 0, n_stack = 10, so 36 values per frame and 396 in all.

Alliance symmetry: blue sees the field rotated 180 degrees (sim.geometry.to_alliance_frame), so a
blue robot and a red robot in mirrored places get identical observations. Robot-frame items need no
rotation. Noise (training): own x, y get uniform +-position_noise_m added, each visible ring or
robot coordinate is scaled by 1 + uniform +-relative_noise (errors grow with distance, as a depth
camera's do); empty slots and flags never get noise.

The spec is saved with every policy (to_dict / from_dict, JSON-safe) and has a fingerprint;
`describe()` lists every index of the stacked observation.
"""

from __future__ import annotations

import hashlib
import json
import math
import string
from collections import deque
from dataclasses import asdict, dataclass, field, fields, replace

import numpy as np
from numpy.typing import ArrayLike, NDArray

from sim.geometry import (
    Alliance,
    field_to_robot,
    project_points,
    push_out_of_box,
    robot_to_camera_rotation,
    robot_to_field,
    to_alliance_frame,
)
from sim.route import TourConfig, tour

SPEC_VERSION = 5
SUPPORTED_VERSIONS = (1, 2, 3, 4, 5)
SEEN, REMEMBERED = 1.0, 0.5  # a ring slot's ok value
SCALARS = ("time", "x", "y", "cos_h", "sin_h", "held")
SCALAR_MEANINGS = {
    "time": "elapsed match time / match_length_s, clipped to [0, 1]",
    "x": "own x in the alliance frame / length_unit_m",
    "y": "own y in the alliance frame / length_unit_m",
    "cos_h": "cos(own heading in the alliance frame)",
    "sin_h": "sin(own heading in the alliance frame)",
    "held": "rings held / ring_capacity_norm",
    "clamped": "1 while the clamp holds a mobile goal, else 0 (goal_memory)",
    "fills": "1 when the intake has a capacity, 0 when it never fills (intake_flag)",
}


_MEMORY_FIELDS = (
    "ring_memory",
    "prior_rings",
    "memory_fov_deg",
    "memory_near_m",
    "memory_far_m",
    "memory_merge_m",
    "memory_forget_m",
    "memory_forget_intake",
    "memory_intake_zone",
    "memory_push",
    "memory_body",
)
# Added after policies with a ring memory were shipped: at their defaults they stay out of the
# fingerprint, so those policies keep theirs.
_INTAKE_FIELDS = ("memory_forget_intake", "memory_intake_zone")
_PUSH_FIELDS = ("memory_push", "memory_body")
MEMORY_VIEWS = ("cone", "camera")
_ROUTE_FIELDS = (
    "route_slots",
    "route_candidates",
    "route_turn_cost_m_per_rad",
    "route_switch_margin_m",
)
_GOAL_FIELDS = ("goal_memory", "prior_goals", "n_goals", "goal_clamp_offset_m", "goal_forget_m")


class ObservationError(ValueError):
    """Bad input to the observation builder or a spec that cannot be used."""


@dataclass(frozen=True)
class ObservationSpec:
    """Everything that fixes the meaning of the policy's input vector."""

    version: int = SPEC_VERSION
    n_rings: int = 10
    n_other_robots: int = 0
    n_stack: int = 10
    length_unit_m: float = 1.8288  # half the Tipping Point field's width
    match_length_s: float = 105.0
    ring_capacity_norm: int = 10
    position_noise_m: float = 0.1
    relative_noise: float = 0.1
    # Version 2: the ring memory. The view cone is a little inside the camera's real one
    # (hfov 55.5 deg, floor visible from ~0.45 m ahead of the robot's centre, 3 m range), so a
    # ring at the cone's edge is never forgotten for flickering out of view.
    ring_memory: bool = False
    prior_rings: tuple[tuple[float, float], ...] = ()
    memory_fov_deg: float = 50.0
    memory_near_m: float = 0.55
    memory_far_m: float = 2.6
    memory_merge_m: float = 0.12
    memory_forget_m: float = 0.25
    # How the memory learns a ring was taken. Off: any ring within memory_forget_m of the
    # robot's centre is gone. On: only a ring inside the intake's reach (memory_intake_zone:
    # x_min, x_max, y_min, y_max in the robot frame, metres; the simulator fills it from the
    # robot when empty). Training rings are not bodies and real ones slide under a bumper, so a
    # ring the robot passes beside is still there; and the intake takes rings in the camera's
    # blind spot, ahead of the centre but nearer than memory_near_m.
    memory_forget_intake: bool = False
    memory_intake_zone: tuple[float, ...] = ()
    # With the intake rule: a known ring under the rest of the body (memory_body: the half
    # width and half length of the robot grown by a ring's radius, metres; the simulator fills
    # it when empty) is moved out across the nearer side, as a bumper shoves a ring, instead of
    # staying where the robot now stands. The shoved ring lies beside the robot, below the
    # camera's picture: forgotten, it is lost to the robot until it turns that way. Off: it
    # gains rings in training fidelity's pushing and loses them in high fidelity's (TRAINING.md).
    memory_push: bool = False
    memory_body: tuple[float, ...] = ()
    # Where the memory looks for rings it knows. "cone": the cone above around the robot's
    # centre. "camera": the camera's own picture (RingMemory's MemoryCamera: the mount and
    # intrinsics, given by the simulator or the Jetson's camera config) within memory_far_m of
    # the lens. The cone reaches past the picture's top edge (the floor shows to ~2.1 m) and
    # sides (the lens sits ahead of the centre), so it forgets rings the camera could not see.
    memory_view: str = "cone"
    # Version 3: the goal memory. The clamp offset is the distance from the robot's centre to a
    # clamped goal's centre (half the robot's length + the goal base's radius; the simulator
    # fills it from the robot when 0). Forgetting: the robot's centre cannot come closer than
    # about that to a goal that is still there.
    goal_memory: bool = False
    prior_goals: tuple[tuple[float, float], ...] = ()
    n_goals: int = 3
    goal_clamp_offset_m: float = 0.0
    goal_forget_m: float = 0.3
    # Version 4: the route slots. The first `route_slots` stops of the tour the planner would
    # drive over the rings the memory knows (sim/route.py), in tour order, between the goal and
    # the ring slots: which rings are worth the trip, not only which are near. The tour has as
    # many stops as ring_capacity_norm minus the rings held (at least one), the intake's room.
    route_slots: int = 0
    route_candidates: int = 6
    route_turn_cost_m_per_rad: float = 0.15
    route_switch_margin_m: float = 0.1
    # Version 5: whether the robot's intake fills (the `fills` scalar).
    intake_flag: bool = False

    def __post_init__(self) -> None:
        if self.version not in SUPPORTED_VERSIONS:
            raise ObservationError(
                f"observation spec version {self.version} is not supported "
                f"(this code reads {SUPPORTED_VERSIONS})"
            )
        if self.version < 2 and self.ring_memory:
            raise ObservationError("ring_memory needs observation spec version 2")
        if self.version < 3 and self.goal_memory:
            raise ObservationError("goal_memory needs observation spec version 3")
        if self.route_slots and (self.version < 4 or not self.ring_memory):
            raise ObservationError("route_slots needs observation spec version 4 and ring_memory")
        if self.intake_flag and self.version < 5:
            raise ObservationError("intake_flag needs observation spec version 5")
        for name in ("prior_rings", "prior_goals"):
            object.__setattr__(self, name, _points(getattr(self, name), name))
        object.__setattr__(self, "memory_intake_zone", _zone(self.memory_intake_zone))
        object.__setattr__(self, "memory_body", _body(self.memory_body))
        if self.memory_push and not self.memory_forget_intake:
            raise ObservationError(
                "memory_push needs memory_forget_intake: which known ring the intake took and "
                "which the body shoved is told by the intake's zone"
            )
        if not (self.goal_clamp_offset_m >= 0 and self.goal_forget_m >= 0):
            raise ObservationError("goal_clamp_offset_m and goal_forget_m must be >= 0")
        if self.memory_view not in MEMORY_VIEWS:
            raise ObservationError(
                f"memory_view must be one of {MEMORY_VIEWS}, got {self.memory_view!r}"
            )
        near, far = self.memory_near_m, self.memory_far_m
        if not (0 < self.memory_fov_deg < 180 and 0 <= near < far and self.memory_merge_m > 0):
            raise ObservationError(
                "ring memory: memory_fov_deg in (0, 180), 0 <= memory_near_m < memory_far_m, "
                "memory_merge_m > 0"
            )
        if self.route_candidates < 1 or not (
            self.route_turn_cost_m_per_rad >= 0 and self.route_switch_margin_m >= 0
        ):
            raise ObservationError(
                "route: route_candidates >= 1, route_turn_cost_m_per_rad >= 0, "
                "route_switch_margin_m >= 0"
            )
        for name in ("n_rings", "n_other_robots", "n_stack", "n_goals", "route_slots"):
            value = getattr(self, name)
            if isinstance(value, bool) or not isinstance(value, int) or value < 0:
                raise ObservationError(f"{name} must be a non-negative integer, got {value!r}")
        if self.n_rings == 0:
            raise ObservationError("n_rings must be at least 1")
        for name in ("length_unit_m", "match_length_s"):
            if not (getattr(self, name) > 0 and math.isfinite(getattr(self, name))):
                raise ObservationError(f"{name} must be positive, got {getattr(self, name)!r}")
        if self.ring_capacity_norm < 1:
            raise ObservationError("ring_capacity_norm must be at least 1")
        if not (self.position_noise_m >= 0 and self.relative_noise >= 0):
            raise ObservationError("noise levels must be non-negative")

    @property
    def needs_prior(self) -> bool:
        """A memory spec whose prior (the field's layout, the clamp's offset) the simulator has
        yet to fill."""
        rings = self.ring_memory and not self.prior_rings
        rings |= self.ring_memory and self.memory_forget_intake and not self.memory_intake_zone
        rings |= self.ring_memory and self.memory_push and not self.memory_body
        goals = self.goal_memory and not (self.prior_goals and self.goal_clamp_offset_m > 0)
        return rings or goals

    @property
    def scalars(self) -> tuple[str, ...]:
        extra = ("clamped",) * self.goal_memory + ("fills",) * self.intake_flag
        return (*SCALARS, *extra)

    def scalar_index(self, name: str) -> int:
        """Where a scalar sits in a frame (ObservationError when this spec has none of it)."""
        try:
            return self.scalars.index(name)
        except ValueError:
            raise ObservationError(f"this observation spec has no {name!r} scalar") from None

    @property
    def goal_slots(self) -> int:
        return self.n_goals if self.goal_memory else 0

    @property
    def frame_size(self) -> int:
        return self.ring_offset + 3 * self.n_rings

    @property
    def n_frames(self) -> int:
        return self.n_stack + 1

    @property
    def size(self) -> int:
        return self.frame_size * self.n_frames

    @property
    def tour(self) -> TourConfig:
        return TourConfig(
            self.route_candidates, self.route_turn_cost_m_per_rad, self.route_switch_margin_m
        )

    @property
    def route_offset(self) -> int:
        """Index of the first route slot within a frame."""
        return self.goal_offset + 3 * self.goal_slots

    @property
    def goal_offset(self) -> int:
        """Index of the first goal slot within a frame."""
        return len(self.scalars) + 3 * self.n_other_robots

    @property
    def ring_offset(self) -> int:
        """Index of the first ring slot within a frame."""
        return self.route_offset + 3 * self.route_slots

    def frame_names(self) -> list[str]:
        names = list(self.scalars)
        for r in range(self.n_other_robots):
            names += [f"robot{r}_x", f"robot{r}_y", f"robot{r}_ok"]
        for g in range(self.goal_slots):
            names += [f"goal{g}_x", f"goal{g}_y", f"goal{g}_ok"]
        for k in range(self.route_slots):
            names += [f"route{k}_x", f"route{k}_y", f"route{k}_ok"]
        for k in range(self.n_rings):
            names += [f"ring{k}_x", f"ring{k}_y", f"ring{k}_ok"]
        return names

    def describe(self) -> list[str]:
        """One line per index of the stacked observation."""
        lines = []
        names = self.frame_names()
        for f in range(self.n_frames):
            age = "now" if f == 0 else f"t-{f}"
            for i, name in enumerate(names):
                lines.append(f"{f * self.frame_size + i:4d}  [{age}] {name}: {_meaning(name)}")
        return lines

    def to_dict(self) -> dict[str, object]:
        """Plain JSON types (lists, not tuples): what a saved policy.json reads back as."""
        out = asdict(self)
        out["prior_rings"] = [list(xy) for xy in self.prior_rings]
        out["prior_goals"] = [list(xy) for xy in self.prior_goals]
        out["memory_intake_zone"] = list(self.memory_intake_zone)
        out["memory_body"] = list(self.memory_body)
        return out

    @classmethod
    def from_dict(cls, data: dict[str, object]) -> ObservationSpec:
        known = {f.name for f in fields(cls)}
        unknown = sorted(set(data) - known)
        if unknown:
            raise ObservationError(f"unknown observation spec keys: {unknown}")
        if "version" not in data:
            raise ObservationError("observation spec has no version")
        return cls(**data)  # type: ignore[arg-type]

    @property
    def memory_needs_camera(self) -> bool:
        """Whether a RingMemory for this spec must be given the camera (MemoryCamera)."""
        return self.ring_memory and self.memory_view == "camera"

    def fingerprint(self) -> str:
        """Stable short hash of the layout-defining fields (noise levels excluded: they do not
        change what an index means)."""
        layout = {
            k: v
            for k, v in self.to_dict().items()
            if k not in ("position_noise_m", "relative_noise")
        }
        # Without a memory its settings mean nothing: older specs hash as they always did.
        if not self.ring_memory:
            layout = {k: v for k, v in layout.items() if k not in _MEMORY_FIELDS}
        if not self.memory_forget_intake:
            layout = {k: v for k, v in layout.items() if k not in _INTAKE_FIELDS}
        if not self.memory_push:
            layout = {k: v for k, v in layout.items() if k not in _PUSH_FIELDS}
        if self.memory_view == "cone" or not self.ring_memory:
            layout.pop("memory_view", None)
        if not self.route_slots:
            layout = {k: v for k, v in layout.items() if k not in _ROUTE_FIELDS}
        if not self.goal_memory:
            layout = {k: v for k, v in layout.items() if k not in _GOAL_FIELDS}
        if not self.intake_flag:
            layout.pop("intake_flag")
        blob = json.dumps(layout, sort_keys=True).encode()
        return hashlib.sha256(blob).hexdigest()[:16]


def _points(value: object, what: str) -> tuple[tuple[float, float], ...]:
    try:
        pts = tuple((float(x), float(y)) for x, y in value)  # type: ignore[attr-defined]
    except (TypeError, ValueError) as e:
        raise ObservationError(f"{what} must be (x, y) pairs: {e}") from e
    if not all(math.isfinite(v) for xy in pts for v in xy):
        raise ObservationError(f"{what} must be finite")
    return pts


def _zone(value: object) -> tuple[float, ...]:
    try:
        zone = tuple(float(v) for v in value)  # type: ignore[attr-defined]
    except (TypeError, ValueError) as e:
        raise ObservationError(f"memory_intake_zone must be 4 numbers: {e}") from e
    if zone and not (len(zone) == 4 and zone[0] < zone[1] and zone[2] < zone[3]):
        raise ObservationError(
            f"memory_intake_zone must be (x_min, x_max, y_min, y_max) with min < max, got {zone}"
        )
    if not all(math.isfinite(v) for v in zone):
        raise ObservationError("memory_intake_zone must be finite")
    return zone


def _body(value: object) -> tuple[float, ...]:
    try:
        body = tuple(float(v) for v in value)  # type: ignore[attr-defined]
    except (TypeError, ValueError) as e:
        raise ObservationError(f"memory_body must be 2 numbers: {e}") from e
    if body and not (len(body) == 2 and all(math.isfinite(v) and v > 0 for v in body)):
        raise ObservationError(
            f"memory_body must be (half_width, half_length), both positive metres, got {body}"
        )
    return body


def _meaning(name: str) -> str:
    if name in SCALAR_MEANINGS:
        return SCALAR_MEANINGS[name]
    kind, _, part = name.partition("_")
    what = {
        "robot": "nearest-first other robot",
        "goal": "nearest-first remembered mobile goal (goal_memory)",
        "ring": "nearest-first visible ring",
        "route": "route stop (route_slots; tour order over the known rings)",
    }[kind.rstrip("0123456789")]
    slot = kind.lstrip(string.ascii_lowercase)
    if part == "ok":
        if kind.startswith("ring"):
            return f"1 if ring slot {slot} is in view, 0.5 if remembered (ring_memory), else 0"
        return f"1 if {what} slot {slot} is filled, else 0"
    axis = "right" if part == "x" else "forward"
    return f"{what} slot {slot}, robot-frame {axis} / length_unit_m (0 when empty)"


@dataclass
class RobotView:
    """What the robot knows at one control step, in the units the sensors give."""

    x: float  # GPS field frame, metres
    y: float
    heading_deg: float  # GPS heading, clockwise from +y
    alliance: Alliance
    time_s: float  # elapsed match time
    rings_robot_xy: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    rings_held: int = 0
    others_robot_xy: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    # Rings known but not in view (RingMemory.recall), robot frame: slots with ok = 0.5.
    rings_remembered_xy: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    goal_clamped: bool = False  # the Brain's clamp holds a mobile goal
    # Mobile goals the robot could score with, robot frame (GoalMemory.observe).
    goals_robot_xy: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    # The route's stops, robot frame, tour order (RingMemory with spec.route_slots).
    route_robot_xy: NDArray[np.float64] = field(default_factory=lambda: np.zeros((0, 2)))
    intake_fills: bool = True  # the intake has a capacity (False: it never fills)


def _as_points(value: ArrayLike, what: str) -> NDArray[np.float64]:
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
    rings = _as_points(view.rings_robot_xy, "rings_robot_xy")
    remembered = _as_points(view.rings_remembered_xy, "rings_remembered_xy")
    others = _as_points(view.others_robot_xy, "others_robot_xy")
    unit = spec.length_unit_m
    out = np.zeros(spec.frame_size, dtype=np.float32)
    pos, heading = to_alliance_frame((view.x, view.y), view.heading_deg, view.alliance)
    assert heading is not None
    if rng is not None and spec.position_noise_m > 0:
        pos = pos + rng.uniform(-spec.position_noise_m, spec.position_noise_m, 2)
    h = math.radians(heading)
    out[0] = min(max(view.time_s / spec.match_length_s, 0.0), 1.0)
    out[1] = pos[0] / unit
    out[2] = pos[1] / unit
    out[3] = math.cos(h)
    out[4] = math.sin(h)
    out[5] = view.rings_held / spec.ring_capacity_norm
    if spec.goal_memory:
        out[spec.scalar_index("clamped")] = 1.0 if view.goal_clamped else 0.0
        goals = _as_points(view.goals_robot_xy, "goals_robot_xy")
        _fill_slots(out, spec.goal_offset, spec.n_goals, goals, unit, 0.0, None)
    if spec.intake_flag:
        out[spec.scalar_index("fills")] = 1.0 if view.intake_fills else 0.0
    rel = spec.relative_noise
    _fill_slots(out, len(spec.scalars), spec.n_other_robots, others, unit, rel, rng)
    ok = None
    if len(remembered):
        ok = np.concatenate([np.full(len(rings), SEEN), np.full(len(remembered), REMEMBERED)])
        rings = np.concatenate([rings, remembered])
    _fill_slots(out, spec.ring_offset, spec.n_rings, rings, unit, spec.relative_noise, rng, ok)
    if spec.route_slots:
        route = _as_points(view.route_robot_xy, "route_robot_xy")[: spec.route_slots]
        if rng is not None and rel > 0:
            route = route * (1.0 + rng.uniform(-rel, rel, route.shape))
        block = out[spec.route_offset : spec.route_offset + 3 * len(route)].reshape(-1, 3)
        block[:, :2] = route / unit  # tour order, not nearest first
        block[:, 2] = 1.0
    return out


@dataclass(frozen=True)
class MemoryCamera:
    """The camera as the ring memory needs it (spec.memory_view "camera"): where it sits on the
    robot (x right, y forward, z up from the centre of turning at floor level; tilt negative
    looking down) and its pinhole intrinsics, to tell which remembered rings are in its picture.
    The simulator builds one from the robot's camera, the Jetson from its camera config."""

    fx: float
    fy: float
    cx: float
    cy: float
    width: int
    height: int
    forward_m: float
    right_m: float
    height_m: float
    tilt_deg: float
    near_m: float = 0.17  # nearer than this along the optical axis the depth camera sees nothing
    ring_z_m: float = 0.0127  # a ring's centre above the floor (lying flat, 1 inch tube)

    def __post_init__(self) -> None:
        values = [getattr(self, f.name) for f in fields(self)]
        if not all(math.isfinite(v) for v in values):
            raise ObservationError(f"memory camera values must be finite: {self}")
        if not (self.fx > 0 and self.fy > 0 and self.width > 0 and self.height > 0):
            raise ObservationError("memory camera: fx, fy, width and height must be positive")

    def locate(
        self, robot_xy: NDArray[np.float64]
    ) -> tuple[NDArray[np.bool_], NDArray[np.float64]]:
        """For floor rings at robot-frame (x, y): inside the picture, and distance from the lens."""
        pts = np.asarray(robot_xy, dtype=np.float64).reshape(-1, 2)
        rel = np.column_stack(
            [
                pts[:, 0] - self.right_m,
                pts[:, 1] - self.forward_m,
                np.full(len(pts), self.ring_z_m - self.height_m),
            ]
        )
        optical = rel @ robot_to_camera_rotation(self.tilt_deg).T
        uv, z = project_points(optical, self.fx, self.fy, self.cx, self.cy)
        with np.errstate(invalid="ignore"):
            inside = (z > self.near_m) & (uv[:, 0] >= 0) & (uv[:, 0] < self.width)
            inside &= (uv[:, 1] >= 0) & (uv[:, 1] < self.height)
        return inside, np.linalg.norm(rel, axis=1)


class RingMemory:
    """The rings a robot knows about, in its alliance frame (see the module docstring).

    Fed the camera's rings every control step by observe(); both the simulator and the Jetson
    keep one per robot when spec.ring_memory is on, so a policy sees the same memory on both.
    `camera` is needed when spec.memory_view is "camera".
    """

    def __init__(self, spec: ObservationSpec, camera: MemoryCamera | None = None) -> None:
        if spec.ring_memory and spec.memory_forget_intake and not spec.memory_intake_zone:
            raise ObservationError(
                "memory_forget_intake needs memory_intake_zone (the simulator fills it from the "
                "robot; a saved policy.json carries it)"
            )
        if spec.ring_memory and spec.memory_push and not spec.memory_body:
            raise ObservationError(
                "memory_push needs memory_body (the simulator fills it from the robot; a saved "
                "policy.json carries it)"
            )
        if spec.memory_needs_camera and camera is None:
            raise ObservationError(
                "this spec's ring memory looks through the camera (memory_view = 'camera'): "
                "give RingMemory the camera's mount and intrinsics (MemoryCamera)"
            )
        self.spec = spec
        self.camera = camera
        self.known = np.zeros((0, 2))
        self.target: NDArray[np.float64] | None = None  # the route's first stop, alliance frame
        self.reset()

    def reset(self) -> None:
        """Back to the field's starting layout: a new match."""
        self.known = np.asarray(self.spec.prior_rings, dtype=np.float64).reshape(-1, 2)
        self.target = None

    def observe(
        self, view: RobotView, seen_from: tuple[float, float, float] | None = None
    ) -> RobotView:
        """Update the memory with the view's rings and return the view with the remembered
        rings (known, not in view) added. Nothing changes for a spec without ring_memory.

        `seen_from` is the pose (GPS field frame x, y, heading) the view's rings were seen
        from, when the camera's frame is older than the view's pose: the rings are then given
        in that pose's robot frame, are placed on the field from it, and only rings inside the
        camera's cone *then* can be found missing. Placed from the current pose instead, a
        frame 100 ms old taken while the robot turns at 4 rad/s lands 25 degrees off, matches
        nothing and wipes the memory of every ring it should have confirmed. Without
        ring_memory the rings are only moved into the view's robot frame."""
        if not self.spec.ring_memory:
            if seen_from is None or not len(view.rings_robot_xy):
                return view
            then = robot_to_field(view.rings_robot_xy, seen_from[:2], seen_from[2])
            return replace(
                view, rings_robot_xy=field_to_robot(then, (view.x, view.y), view.heading_deg)
            )
        s = self.spec
        pos, heading = to_alliance_frame((view.x, view.y), view.heading_deg, view.alliance)
        assert heading is not None
        cam_pos, cam_heading = pos, heading
        if seen_from is not None:
            cam_pos, cam_heading = to_alliance_frame(seen_from[:2], seen_from[2], view.alliance)
            assert cam_heading is not None
        seen_local = _as_points(view.rings_robot_xy, "rings_robot_xy")
        seen = (
            robot_to_field(seen_local, cam_pos, cam_heading)
            if len(seen_local)
            else np.zeros((0, 2))
        )
        known = self.known
        if len(known):
            local = field_to_robot(known, pos, heading)
            if s.memory_forget_intake:
                x0, x1, y0, y1 = s.memory_intake_zone
                taken = (local[:, 0] >= x0) & (local[:, 0] <= x1)
                taken &= (local[:, 1] >= y0) & (local[:, 1] <= y1)
                if s.memory_push:
                    # Before the view test: a shoved ring is looked for where it now lies.
                    out, moved = push_out_of_box(local, *s.memory_body)
                    moved &= ~taken
                    if moved.any():
                        known = known.copy()
                        known[moved] = robot_to_field(out[moved], pos, heading)
            else:
                # Under the robot: collected, or pushed somewhere the camera will show.
                taken = np.hypot(local[:, 0], local[:, 1]) <= s.memory_forget_m
            cam = field_to_robot(known, cam_pos, cam_heading)
            if self.camera is not None and s.memory_view == "camera":
                in_view, lens_dist = self.camera.locate(cam)
                in_view &= lens_dist <= s.memory_far_m
            else:
                cam_dist = np.hypot(cam[:, 0], cam[:, 1])
                bearing = np.degrees(np.abs(np.arctan2(cam[:, 0], cam[:, 1])))
                in_view = (bearing <= s.memory_fov_deg / 2) & (cam_dist >= s.memory_near_m)
                in_view &= cam_dist <= s.memory_far_m
            matched = np.zeros(len(known), dtype=bool)
            if len(seen):
                d = np.linalg.norm(known[:, None, :] - seen[None, :, :], axis=2)
                matched = d.min(axis=1) <= s.memory_merge_m
            gone = (in_view & ~matched) | taken
            known = known[~gone]
        if len(seen):
            if len(known):
                d = np.linalg.norm(seen[:, None, :] - known[None, :, :], axis=2)
                stale = d.min(axis=0) <= s.memory_merge_m  # replaced by their fresh sighting
                known = known[~stale]
            known = np.concatenate([known, seen])
        self.known = known
        if seen_from is not None and len(seen):
            view = replace(view, rings_robot_xy=field_to_robot(seen, pos, heading))
        view = self._with_route(view, pos, heading)
        return self._with_remembered(view, known[: len(known) - len(seen)], pos, heading)

    def recall(self, view: RobotView) -> RobotView:
        """The view with every known ring as remembered, the memory unchanged: for a step with
        no camera frame (no rings seen is not the same as no picture)."""
        if not self.spec.ring_memory:
            return view
        pos, heading = to_alliance_frame((view.x, view.y), view.heading_deg, view.alliance)
        assert heading is not None
        return self._with_remembered(self._with_route(view, pos, heading), self.known, pos, heading)

    def _with_route(self, view: RobotView, pos: NDArray[np.float64], heading: float) -> RobotView:
        s = self.spec
        if not s.route_slots:
            return view
        known = self.known
        current = None
        if self.target is not None and len(known):
            d = np.linalg.norm(known - self.target, axis=1)
            if d.min() <= s.memory_merge_m:
                current = int(d.argmin())
        # As the planner plans: as many stops as the intake has room for (at least one; a
        # full intake's worth when it never fills).
        room = max(1, s.ring_capacity_norm - view.rings_held * view.intake_fills)
        order = tour(pos, heading, known, room, s.tour, current)
        self.target = known[order[0]].copy() if order else None
        stops = known[order[: s.route_slots]]
        local = field_to_robot(stops, pos, heading) if len(stops) else np.zeros((0, 2))
        return replace(view, route_robot_xy=local)

    @staticmethod
    def _with_remembered(
        view: RobotView, rings: NDArray[np.float64], pos: NDArray[np.float64], heading: float
    ) -> RobotView:
        remembered = field_to_robot(rings, pos, heading) if len(rings) else np.zeros((0, 2))
        return replace(view, rings_remembered_xy=remembered)


class GoalMemory:
    """Where the mobile goals the robot could score with are believed to be, in its alliance
    frame (see the module docstring). Fed every control step by observe(); the simulator and the
    Jetson keep one per robot when spec.goal_memory is on."""

    def __init__(self, spec: ObservationSpec) -> None:
        self.spec = spec
        self.known = np.zeros((0, 2))
        self.holding = False
        self.reset()

    def reset(self) -> None:
        """Back to the field's starting layout: a new match."""
        self.known = np.asarray(self.spec.prior_goals, dtype=np.float64).reshape(-1, 2)
        self.holding = False

    def observe(self, view: RobotView) -> RobotView:
        """Update the memory with the clamp's state and the robot's pose; return the view with
        the remembered goals (not the held one) in the robot frame."""
        if not self.spec.goal_memory:
            return view
        s = self.spec
        pos, heading = to_alliance_frame((view.x, view.y), view.heading_deg, view.alliance)
        assert heading is not None
        h = math.radians(heading)
        clamp_point = pos - s.goal_clamp_offset_m * np.array([math.sin(h), math.cos(h)])
        known = self.known
        if view.goal_clamped and not self.holding:
            # The goal now held is the remembered one nearest the clamp (if any is near enough to
            # be it: a goal the memory had lost track of may be the one clamped).
            if len(known):
                d = np.hypot(*(known - clamp_point).T)
                i = int(np.argmin(d))
                if d[i] <= 2 * s.goal_forget_m + s.goal_clamp_offset_m:
                    known = np.delete(known, i, axis=0)
        elif self.holding and not view.goal_clamped:
            known = np.concatenate([known, clamp_point[None, :]])
        self.holding = bool(view.goal_clamped)
        if len(known):
            known = known[np.hypot(*(known - pos).T) > s.goal_forget_m]
        self.known = known
        local = field_to_robot(known, pos, heading) if len(known) else np.zeros((0, 2))
        return replace(view, goals_robot_xy=local)


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


def observation_bounds(spec: ObservationSpec) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Bounds for a Box space: positions can exceed +-1 (far rings, noise), so they are +-4."""
    low = np.full(spec.frame_size, -4.0, dtype=np.float32)
    high = np.full(spec.frame_size, 4.0, dtype=np.float32)
    low[0], high[0] = 0.0, 1.0
    low[3:5], high[3:5] = -1.0, 1.0
    low[5], high[5] = 0.0, 8.0
    flags = [spec.scalar_index(n) for n in ("clamped", "fills") if n in spec.scalars]
    low[flags], high[flags] = 0.0, 1.0
    ok_idx = np.arange(len(spec.scalars) + 2, spec.frame_size, 3)
    low[ok_idx], high[ok_idx] = 0.0, 1.0
    return np.tile(low, spec.n_frames), np.tile(high, spec.n_frames)
