"""Configuration of robots, sensors, rewards and the world: plain dataclasses, numpy-free.

Every number the simulator uses that is not a property of the field (sim/field/*.toml) lives
here, with where its default comes from. Configs are frozen; derive variants with
dataclasses.replace or the `from_dict` helpers, which reject unknown keys by name.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, fields, replace
from dataclasses import field as dc_field
from typing import Any, Literal, TypeVar

from jetson import config_check
from jetson.autonomy.camera import CameraMount, Intrinsics
from jetson.autonomy.geometry import INCH
from sim.errors import ConfigError

Fidelity = Literal["training", "high"]
FIDELITIES: tuple[Fidelity, ...] = ("training", "high")
Game = Literal["ring_race", "tipping_point"]
GAMES: tuple[Game, ...] = ("ring_race", "tipping_point")


# Defaults from a real drivetrain: V5 Smart Motors with the 200 rpm (green) cartridge driving 4 in
# omni wheels directly: free speed pi * 4 in * 200 / 60 s = 1.064 m/s; 85 % of it under load.
_WHEEL_DIAMETER_M = 4 * INCH
_MOTOR_RPM = 200.0
_LOADED_FRACTION = 0.85
DRIVE_SPEED_MPS = round(math.pi * _WHEEL_DIAMETER_M * _MOTOR_RPM / 60.0 * _LOADED_FRACTION, 3)


@dataclass(frozen=True)
class CameraConfig:
    """A RealSense D435 colour camera as mounted on the robot.

    Intrinsics default to the original team's checkerboard calibration at 640x480
    (REFERENCE section 1): fx 608.39, fy 610.60, cx 332.60, cy 236.59. The mount (0.2 m ahead of
    the robot centre, tilted 30 degrees down) is also theirs; the height is unverified.
    """

    width: int = 640
    height: int = 480
    fx: float = 608.38952271
    fy: float = 610.59807426
    cx: float = 332.60130193
    cy: float = 236.58507294
    forward_m: float = 0.20  # camera ahead of the robot's centre of turning
    right_m: float = 0.0
    height_m: float = 0.30
    tilt_deg: float = -30.0  # negative looks down
    near_m: float = 0.17  # D435 minimum range at 640x480 is ~17-28 cm (REFERENCE section 5)
    max_range_m: float = 3.0  # rings farther than this are not reported (depth RMS grows)
    far_m: float = 8.0  # render far plane
    # The original dropped every ring while the robot turned faster than this (motion blur);
    # None keeps them.
    max_turn_rate_rad_s: float | None = None

    def __post_init__(self) -> None:
        if self.width < 8 or self.height < 8:
            raise ConfigError(f"camera image must be at least 8x8, got {self.width}x{self.height}")
        for name in ("fx", "fy", "near_m", "max_range_m", "far_m"):
            if not getattr(self, name) > 0:
                raise ConfigError(f"camera {name} must be positive, got {getattr(self, name)}")
        if not -89.0 <= self.tilt_deg <= 89.0:
            raise ConfigError(f"camera tilt_deg must be within +-89, got {self.tilt_deg}")
        if self.far_m <= self.near_m:
            raise ConfigError("camera far_m must exceed near_m")

    @property
    def intrinsics(self) -> Intrinsics:
        """The pinhole model, as the robot's camera model (jetson.autonomy.camera) holds it."""
        return Intrinsics(self.width, self.height, self.fx, self.fy, self.cx, self.cy)

    @property
    def mount(self) -> CameraMount:
        """Where the camera sits on the robot, as jetson.autonomy.camera holds it."""
        return CameraMount(self.forward_m, self.right_m, self.height_m, self.tilt_deg)

    def scaled(self, width: int, height: int) -> CameraConfig:
        """The same camera at another resolution (Intrinsics.scaled: they scale with the image)."""
        k = self.intrinsics.scaled(width, height)
        return replace(self, width=k.width, height=k.height, fx=k.fx, fy=k.fy, cx=k.cx, cy=k.cy)

    @property
    def hfov_deg(self) -> float:
        return math.degrees(2 * math.atan(self.width / (2 * self.fx)))


@dataclass(frozen=True)
class GpsConfig:
    """The V5 GPS as the Brain reads it: Gaussian noise and a fixed latency."""

    noise_xy_m: float = 0.015  # unverified: VEX quotes ~+-13 mm when the strip is in view
    noise_heading_deg: float = 0.5
    latency_s: float = 0.03
    offset_forward_m: float = 0.0  # the sensor's place relative to the centre of turning
    offset_right_m: float = 0.0

    def __post_init__(self) -> None:
        if min(self.noise_xy_m, self.noise_heading_deg, self.latency_s) < 0:
            raise ConfigError("GPS noise and latency must be non-negative")


@dataclass(frozen=True)
class RobotConfig:
    """A VEX AI robot as a box with a differential drive, an intake and a mobile-goal clamp.

    The mechanisms (the whole game; the ring race ignores where rings land): `clamp` is where the
    clamp holds a goal (its back or its front face); `loads` is what the intake does with a ring
    when a goal is clamped: a conveyor that threads it onto the goal's branches ("branch") or one
    that drops it in the goal's base ("base"); `reaches_high_branch`: the lift reaches a neutral
    goal's high branch (rings go there first, 10 points each); `clamp_lifts`: the clamp lifts the
    goal off the tiles (then it is not Scored in a Home Zone until it is set down; it still is
    Elevated with an Elevated robot). `pull_n`, the force its drive pulls with (traction-limited:
    mass x max_linear_accel), decides a tug of war over a goal.
    """

    name: str = "15in"
    width_m: float = 15 * INCH
    length_m: float = 15 * INCH
    height_m: float = 0.30
    mass_kg: float = 5.5  # unverified
    track_m: float = 0.30  # wheel-to-wheel, for wheel speed <-> (v, w)
    max_linear_mps: float = DRIVE_SPEED_MPS
    # The original scaled its rotation action to 276.86 deg/s (4.83 rad/s).
    max_angular_rad_s: float = 4.8
    max_linear_accel: float = 2.5  # unverified: a traction-limited VEX drive
    max_angular_accel: float = 20.0
    intake_width_m: float = 0.22  # across the front, centred
    intake_depth_m: float = 0.08  # how far ahead of the front face it reaches
    ring_capacity: int | None = 10  # None: unlimited
    clamp_reach_m: float = 0.06  # gap between the back face and a goal's base that still clamps
    clamp_half_width_m: float = 0.12  # how far off-centre a goal may be to clamp
    ring_transfer_s: float = 0.5  # a held ring moves onto the carried goal every this many s
    clamp: Literal["back", "front"] = "back"
    loads: Literal["branch", "base"] = "branch"
    reaches_high_branch: bool = False
    clamp_lifts: bool = False
    rgb: tuple[int, int, int] = (60, 60, 66)
    camera: CameraConfig = dc_field(default_factory=CameraConfig)
    gps: GpsConfig = dc_field(default_factory=GpsConfig)

    def __post_init__(self) -> None:
        for name in (
            "width_m",
            "length_m",
            "height_m",
            "mass_kg",
            "track_m",
            "max_linear_mps",
            "max_angular_rad_s",
            "max_linear_accel",
            "max_angular_accel",
            "ring_transfer_s",
        ):
            value = getattr(self, name)
            if not (isinstance(value, int | float) and value > 0 and math.isfinite(value)):
                raise ConfigError(f"robot {self.name}: {name} must be positive, got {value!r}")
        if self.ring_capacity is not None and self.ring_capacity < 0:
            raise ConfigError(f"robot {self.name}: ring_capacity must be >= 0 or None")
        if min(self.intake_width_m, self.intake_depth_m, self.clamp_reach_m) < 0:
            raise ConfigError(f"robot {self.name}: intake and clamp sizes must be >= 0")
        if self.clamp not in ("back", "front"):
            raise ConfigError(f"robot {self.name}: clamp must be 'back' or 'front'")
        if self.loads not in ("branch", "base"):
            raise ConfigError(f"robot {self.name}: loads must be 'branch' or 'base'")

    @property
    def clamp_sign(self) -> float:
        """-1: the clamp holds a goal behind the back face; +1: ahead of the front."""
        return -1.0 if self.clamp == "back" else 1.0

    @property
    def pull_n(self) -> float:
        """The drive's pull, N: what it can push or drag before its wheels slip."""
        return self.mass_kg * self.max_linear_accel

    @property
    def radius_m(self) -> float:
        """Half the footprint's diagonal: the robot fits in a circle of this radius."""
        return math.hypot(self.width_m, self.length_m) / 2.0

    def wheel_speeds(self, linear: float, angular_cw: float) -> tuple[float, float]:
        """Left and right wheel surface speeds (m/s) of a (v, w) command; w clockwise-positive."""
        half = self.track_m / 2.0
        return linear + angular_cw * half, linear - angular_cw * half

    def from_wheel_speeds(self, left: float, right: float) -> tuple[float, float]:
        """(v, w clockwise-positive) of left/right wheel surface speeds."""
        return (left + right) / 2.0, (left - right) / self.track_m


# The VEX AI pair (Appendix D: one 24" and one 15" robot an alliance). The 24" carries the lift
# that reaches a neutral goal's high branch; the 15" threads rings onto the low branches.
ROBOT_15 = RobotConfig()
ROBOT_24 = RobotConfig(
    name="24in",
    width_m=24 * INCH,
    length_m=24 * INCH,
    height_m=0.38,
    mass_kg=9.0,
    track_m=0.52,
    intake_width_m=0.30,
    reaches_high_branch=True,
    # The camera must sit outside the body: at the front edge of the larger robot, higher up.
    camera=CameraConfig(forward_m=0.32, height_m=0.40),
)
ROBOTS = {"15in": ROBOT_15, "24in": ROBOT_24}


@dataclass(frozen=True)
class RewardConfig:
    """The report's reward table (GameManager.cs), weights configurable.

    ring: per ring collected, for the first `ring_cap` rings (None: every ring);
    pin: to both robots when a pin is called (the episode then ends when end_on_pin);
    goal_end: per mobile goal counting for the alliance in its own zone at the end;
    opponent_side_end: ending the match on the opponent's half;
    elevated_end: ending the match on the alliance's own platform (the report had no platform;
    the score term rewards it too, but only while the robot stays, which a policy rarely finds);
    approach: per metre the front of the robot gets closer to the nearest ring on the floor
    while it has room, a potential-based shaping (Ng et al. 1999: the sum over a match is the
    potential's change, so it cannot be farmed and leaves the best policy the best);
    park: per metre the robot gets closer to its alliance's platform during the last
    `park_from_s` seconds of the match, the same kind of shaping (the potential is 0 before);
    the target is the platform shrunk by `park_margin_m` on every side, so the pull goes on past
    the edge to where the robot's noisy GPS still reads inside;
    clamp: when the robot's clamp takes a mobile goal that scores for its alliance (once per
    goal: the auto clamp never lets go);
    goal_approach: per metre the robot's clamp point (behind its back) gets closer to the
    nearest goal it could score with, while it holds none: potential-based shaping again.
    score: weight on the change of the alliance's match-score margin (0: off).
    hurry: per second while the robot has fewer than `ring_cap` rings (off without a cap); a
    negative weight is a cost of time: potential shaping only steers, this makes a faster fill
    worth more than the discount alone does (the competence test judges the fill time).
    partner_contact: each time the robot and its alliance partner come into contact (within
    pin_contact_m, World.touching), to both; a negative weight teaches partners to keep apart.
    """

    ring: float = 5.0
    ring_cap: int | None = 10
    pin: float = -5.0
    goal_end: float = 12.0
    opponent_side_end: float = -17.5
    elevated_end: float = 0.0
    approach: float = 0.0
    park: float = 0.0
    park_from_s: float = 15.0
    park_margin_m: float = 0.0
    clamp: float = 0.0
    goal_approach: float = 0.0
    score: float = 0.0
    hurry: float = 0.0
    partner_contact: float = 0.0
    goal_zone: Literal["home", "half"] = "home"

    def __post_init__(self) -> None:
        if self.goal_zone not in ("home", "half"):
            raise ConfigError(f"goal_zone must be 'home' or 'half', got {self.goal_zone!r}")
        if self.ring_cap is not None and self.ring_cap < 0:
            raise ConfigError("ring_cap must be >= 0 or None")
        if self.park_from_s < 0:
            raise ConfigError("park_from_s must be >= 0")
        if self.park_margin_m < 0:
            raise ConfigError("park_margin_m must be >= 0")


@dataclass(frozen=True)
class WorldConfig:
    """One simulated match.

    Control runs at `control_hz`: a 105 s interaction period at 12 Hz is the 1260 steps the
    benchmark counts (the original decided at 10 Hz: physics 0.02 s x decision period 5). Physics
    substeps default to 60 Hz in training fidelity (rings are numpy, nothing thin needs small
    steps) and 240 Hz in high fidelity (dynamic rings fall through the floor below 120 Hz,
    REFERENCE section 7).
    """

    field: str = "tipping_point"
    # "ring_race": the original team's simplified game (every ring 3, a flat platform, no fouls);
    # "tipping_point": the whole game (sim/world/rules.py): branches, the see-saw, the autonomous
    # bonus and win point, fouls, goals released and fought over.
    game: Game = "ring_race"
    fidelity: Fidelity = "training"
    control_hz: float = 12.0
    physics_hz: float | None = None  # None: 60 (training) or 240 (high)
    red: tuple[str, ...] = ("15in",)
    blue: tuple[str, ...] = ("15in",)
    robots: dict[str, RobotConfig] = dc_field(default_factory=lambda: dict(ROBOTS))
    isolation_s: float = 0.0  # optional isolation period before the interaction period
    # The isolation period's centre-line wall that only robots hit (off: robots may cross it;
    # in the whole game contact with the other alliance's robots is then a foul).
    isolation_barrier: bool = True
    interaction_s: float | None = None  # None: the field file's (105 s)
    preloads: bool = False
    match_loads: bool = False
    auto_clamp: bool = True  # clamp the first goal that touches the back (no clamp action)
    pin_contact_m: float = 0.05  # robots closer than this (hull to hull) are in contact
    pin_time_s: float | None = None  # None: the field file's (5 s)
    start_jitter_m: float = 0.0  # uniform +- on start positions, for training variety
    start_jitter_deg: float = 0.0
    ring_jitter_m: float = 0.0  # uniform +- on ring start positions
    occlude_with_rings: bool = False  # rings also hide rings (high fidelity rays always do)
    # Training fidelity: a floor ring a robot's body drives over is pushed out to the body's
    # edge, as a ring body is in high fidelity, instead of lying under the robot where no
    # intake can reach it (a chaser that knows it is there turns over it for seconds).
    push_rings: bool = False

    def __post_init__(self) -> None:
        if self.fidelity not in FIDELITIES:
            raise ConfigError(f"fidelity must be one of {FIDELITIES}, got {self.fidelity!r}")
        if self.game not in GAMES:
            raise ConfigError(f"game must be one of {GAMES}, got {self.game!r}")
        if not self.control_hz > 0:
            raise ConfigError(f"control_hz must be positive, got {self.control_hz}")
        if self.physics_hz is not None and self.physics_hz < self.control_hz:
            raise ConfigError("physics_hz must be at least control_hz")
        for side in ("red", "blue"):
            names = getattr(self, side)
            if not 0 <= len(names) <= 2:
                raise ConfigError(f"{side} must list 0, 1 or 2 robots, got {names!r}")
            for n in names:
                if n not in self.robots:
                    raise ConfigError(
                        f"{side} robot {n!r} is not configured ({sorted(self.robots)})"
                    )
        if not self.red and not self.blue:
            raise ConfigError("a world needs at least one robot")
        if self.isolation_s < 0:
            raise ConfigError("isolation_s must be >= 0")

    @property
    def physics_rate(self) -> float:
        if self.physics_hz is not None:
            return self.physics_hz
        return 60.0 if self.fidelity == "training" else 240.0

    @property
    def substeps(self) -> int:
        """Physics steps per control step (at least 1)."""
        return max(1, round(self.physics_rate / self.control_hz))

    @property
    def control_dt(self) -> float:
        return 1.0 / self.control_hz


# Named matches (`world_preset(name)`). "ring_race" is today's default; "tipping_point_2v2" is the
# whole VEX AI match: a 24" and a 15" robot an alliance, starting in their zones with their
# preloads, the 15 s isolation period (no barrier: contact with the other alliance is a foul) and
# the 105 s interaction period.
WORLD_PRESETS: dict[str, dict[str, Any]] = {
    "ring_race": {},
    "tipping_point_1v1": {
        "game": "tipping_point",
        "red": ("24in",),
        "blue": ("24in",),
        "isolation_s": 15.0,
        "isolation_barrier": False,
        "preloads": True,
    },
    "tipping_point_2v2": {
        "game": "tipping_point",
        "red": ("24in", "15in"),
        "blue": ("24in", "15in"),
        "isolation_s": 15.0,
        "isolation_barrier": False,
        "preloads": True,
    },
}


def world_preset(name: str, **overrides: Any) -> WorldConfig:
    """A named match (WORLD_PRESETS) as a WorldConfig, with any field overridden."""
    if name not in WORLD_PRESETS:
        raise ConfigError(f"no world preset {name!r} ({sorted(WORLD_PRESETS)})")
    return WorldConfig(**{**WORLD_PRESETS[name], **overrides})


T = TypeVar("T")


def from_dict(cls: type[T], data: dict[str, Any] | None, where: str | None = None) -> T:
    """Build a config dataclass from a plain dict (a TOML table), nested dataclasses included."""
    return merge(cls(), data, where or cls.__name__)


def merge(base: T, data: dict[str, Any] | None, where: str | None = None) -> T:
    """A copy of config `base` with the values in `data` applied, each checked against its
    field's type (jetson.config_check: the one checker of every config table); nested tables
    merge into the nested configs (so {"camera": {"tilt_deg": -20}} keeps the other camera
    values), and a dict of configs (WorldConfig.robots) merges per entry, a new robot starting
    from RobotConfig(name=...). `where` is the table's path in its file ("env.world")."""
    return config_check.merge(
        base, data, type(base).__name__ if where is None else where,
        error=ConfigError, new_entry=_new_entry,
    )  # fmt: skip


def _new_entry(cls: type, name: str) -> Any:
    return cls(name=name) if "name" in {f.name for f in fields(cls)} else cls()
