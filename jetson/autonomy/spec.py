"""The policy's input, specified: one versioned, documented observation shared by the simulator
and the Jetson.

ObservationSpec fixes what every index of the observation vector means: which scalars a frame
starts with, how many slots it has for other robots, mobile goals, route stops and rings, how
many past frames are stacked, the units and the noise levels used in training. It is saved with
every policy (to_dict / from_dict, JSON-safe) and has a fingerprint over the fields that change
an index's meaning, so a policy never runs on inputs it was not trained for; `describe()` lists
every index. The layout, the frames it uses and the versions (what each added) are in
jetson/autonomy/README.md. numpy only: the Jetson imports it without PyBullet or torch.
"""

from __future__ import annotations

import hashlib
import json
import math
import string
from dataclasses import asdict, dataclass, fields

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.route import TourConfig
from jetson.errors import ObservationError

SPEC_VERSION = 6
SUPPORTED_VERSIONS = (1, 2, 3, 4, 5, 6)
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
    "tall": "1 for the alliance's robot that reaches the high branch (the 24-inch), else 0 "
    "(role_flag)",
}
# Version 6: the alliance partner's block (spec.partner), from its newest report over VEXlink.
PARTNER_NAMES = (
    "partner_x", "partner_y", "partner_ok", "partner_clamped", "partner_held",
    "claim_x", "claim_y", "claim_ok",
)  # fmt: skip
PARTNER_MEANINGS = {
    "partner_x": "the partner's reported position, robot-frame right / length_unit_m (0 when none)",
    "partner_y": "the partner's reported position, robot-frame forward / length_unit_m",
    "partner_ok": "1 when a fresh partner report has its position, else 0",
    "partner_clamped": "1 when a fresh partner report says its clamp holds a goal, else 0",
    "partner_held": "the partner's rings (fresh report) / ring_capacity_norm, else 0",
    "claim_x": "the target the partner claimed, robot-frame right / length_unit_m (0 when none)",
    "claim_y": "the target the partner claimed, robot-frame forward / length_unit_m",
    "claim_ok": "1 when a fresh partner report claims a target, else 0",
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
    # gains rings in training fidelity's pushing and loses them in high fidelity's
    # (docs/notes/2026-11-26-training-pushed-rings-and-noise.md).
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
    # drive over the rings the memory knows (route.py), in tour order, between the goal and
    # the ring slots: which rings are worth the trip, not only which are near. The tour has as
    # many stops as ring_capacity_norm minus the rings held (at least one), the intake's room.
    route_slots: int = 0
    route_candidates: int = 6
    route_turn_cost_m_per_rad: float = 0.15
    route_switch_margin_m: float = 0.1
    # Version 5: whether the robot's intake fills (the `fills` scalar).
    intake_flag: bool = False
    # Version 6: the alliance partner (PARTNER_NAMES, between the other robots' slots and the
    # goal slots): where its newest report over VEXlink puts it, whether it holds a goal, its
    # rings, and the target it claimed, in the robot frame; all zero without a fresh report
    # (the link down: the robot plays alone).
    partner: bool = False
    # Version 6 too: the other robots' slots hold only the opponents the camera sees (the robot
    # detector's, jetson/perception/robots.py: a licence plate facing the camera within about
    # 2 m), nearest first, instead of every other robot wherever it is. The partner is the
    # partner block's; an opponent out of view leaves its slot empty.
    seen_opponents: bool = False
    # Version 6 too: the robot's role in its alliance (the `tall` scalar): one network plays
    # both robots of a 2v2 alliance and knows which of the two it drives.
    role_flag: bool = False
    # Version 6 too: the goal memory corrected by sight (with goal_memory). Each fresh camera
    # result's goals the robot could score with (yellow and its alliance's colour, from the goal
    # detector) move the remembered goal nearest them within goal_sight_merge_m there, or join
    # the memory; a remembered goal within the detector's reach (goal_sight_fov_deg about the
    # heading, goal_sight_near_m to goal_sight_far_m from the robot's centre) that no sighting
    # matched is not there and is forgotten.
    goal_sight: bool = False
    goal_sight_merge_m: float = 0.35
    goal_sight_fov_deg: float = 60.0
    goal_sight_near_m: float = 0.4
    goal_sight_far_m: float = 1.8

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
        if self.partner and self.version < 6:
            raise ObservationError("partner needs observation spec version 6")
        if self.role_flag and self.version < 6:
            raise ObservationError("role_flag needs observation spec version 6")
        if self.goal_sight and (self.version < 6 or not self.goal_memory):
            raise ObservationError("goal_sight needs observation spec version 6 and goal_memory")
        sight = (self.goal_sight_merge_m, self.goal_sight_near_m, self.goal_sight_far_m)
        if not (0 < self.goal_sight_fov_deg < 180 and min(sight) >= 0 and sight[1] < sight[2]):
            raise ObservationError(
                "goal sight: goal_sight_fov_deg in (0, 180), goal_sight_merge_m >= 0, "
                "0 <= goal_sight_near_m < goal_sight_far_m"
            )
        if self.seen_opponents and (self.version < 6 or self.n_other_robots < 1):
            raise ObservationError(
                "seen_opponents needs observation spec version 6 and n_other_robots >= 1"
            )
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
        extra += ("tall",) * self.role_flag
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
    def partner_offset(self) -> int:
        """Index of the partner block (PARTNER_NAMES) within a frame, when the spec has one."""
        return len(self.scalars) + 3 * self.n_other_robots

    @property
    def goal_offset(self) -> int:
        """Index of the first goal slot within a frame."""
        return self.partner_offset + len(PARTNER_NAMES) * self.partner

    @property
    def ring_offset(self) -> int:
        """Index of the first ring slot within a frame."""
        return self.route_offset + 3 * self.route_slots

    def frame_names(self) -> list[str]:
        names = list(self.scalars)
        for r in range(self.n_other_robots):
            names += [f"robot{r}_x", f"robot{r}_y", f"robot{r}_ok"]
        if self.partner:
            names += PARTNER_NAMES
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
                text = _meaning(name)
                if self.seen_opponents and name.startswith("robot"):
                    text = text.replace("other robot", "opponent the camera sees")
                lines.append(f"{f * self.frame_size + i:4d}  [{age}] {name}: {text}")
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
        if not self.partner:
            layout.pop("partner")
        if not self.seen_opponents:
            layout.pop("seen_opponents")
        if not self.role_flag:
            layout.pop("role_flag")
        if not self.goal_sight:
            layout = {k: v for k, v in layout.items() if not k.startswith("goal_sight")}
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
    if name in PARTNER_MEANINGS:
        return PARTNER_MEANINGS[name]
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


_FLAGS = ("clamped", "fills", "partner_clamped")


def observation_bounds(spec: ObservationSpec) -> tuple[NDArray[np.float32], NDArray[np.float32]]:
    """Bounds for a Box space: positions can exceed +-1 (far rings, noise), so they are +-4."""
    low = np.full(spec.frame_size, -4.0, dtype=np.float32)
    high = np.full(spec.frame_size, 4.0, dtype=np.float32)
    low[0], high[0] = 0.0, 1.0
    low[3:5], high[3:5] = -1.0, 1.0
    names = spec.frame_names()
    counts = [i for i, n in enumerate(names) if n in ("held", "partner_held")]
    low[counts], high[counts] = 0.0, 8.0
    flags = [i for i, n in enumerate(names) if n in _FLAGS or n.endswith("_ok")]
    low[flags], high[flags] = 0.0, 1.0
    return np.tile(low, spec.n_frames), np.tile(high, spec.n_frames)
