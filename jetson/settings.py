"""Every setting of `pete-jetson run`, with defaults, checks, and the TOML file that holds them.

The config file (jetson/deploy/pete-jetson.toml is the annotated example) has one table per
group. Every value, from the file or a command-line option (which overrides the file), is checked
against its field's type and range by jetson.config_check: an error names the file (or the
command line), the key (`[link] port`), what it takes and what was found; a key or table it does
not know is an error that names it and the known ones.
No numpy: `pete-jetson --help` must not load numpy, OpenCV or the simulator (msgspec only).
"""

from __future__ import annotations

import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

from jetson import config_check
from jetson.autonomy.providers import provider_names
from jetson.errors import SettingsError
from jetson.models import DEFAULT_POLICY
from protocol.compat import tomllib

PHASES = ("disabled", "autonomous", "driver")


def _check_providers(settings: Any, table: str) -> None:
    """[policy] / [camera] providers: tensorrt, cuda, cpu or onnxruntime's names, in order
    (jetson.autonomy.providers); whether onnxruntime has them is checked when the model opens."""
    if settings.providers is not None:
        try:
            provider_names(settings.providers)
        except ValueError as exc:
            raise SettingsError(f"{table} providers: {exc}") from None
        object.__setattr__(settings, "providers", tuple(settings.providers))


def _merge(base: Any, data: Any, table: str) -> Any:
    return config_check.merge(base, data, table, error=SettingsError)


@dataclass(frozen=True)
class LinkConfig:
    port: str | None = None  # None: find the V5 user port over USB (VID 0x2888)
    baud: int = 115200
    hello_period_s: float = 0.2
    mismatch_hello_period_s: float = 1.0
    silence_timeout_s: float = 2.0  # a connected Brain sends 50 States a second
    reconnect_poll_s: float = 0.05  # how often to look for a port that went away
    # A port that opens but fails is retried after reconnect_poll_s, doubling up to this.
    reconnect_max_s: float = 1.0
    exclusive: bool = True  # no second program may open the port while we hold it

    def __post_init__(self) -> None:
        for name in ("hello_period_s", "mismatch_hello_period_s", "silence_timeout_s"):
            if not getattr(self, name) > 0:
                raise SettingsError(f"link {name} must be positive")
        if not 0 < self.reconnect_poll_s <= 0.5:
            raise SettingsError("link reconnect_poll_s must be in (0, 0.5] s: reconnect within 1 s")
        if not self.reconnect_poll_s <= self.reconnect_max_s <= 1.0:
            raise SettingsError(
                "link reconnect_max_s must be in [reconnect_poll_s, 1] s: a Brain that comes back "
                f"is found within it (got {self.reconnect_max_s})"
            )


ROLES = ("24in", "15in")  # a VEX AI alliance is one team's 24-inch and 15-inch robot
PLAYERS = ("policy", "alliance")  # what decides: the ONNX policy, or the scripted alliance


@dataclass(frozen=True)
class DecisionConfig:
    drive_phases: tuple[str, ...] = ("autonomous", "driver")
    perception_max_age_s: float = 0.3
    valid_ms: int = 250  # Command.valid_ms: the Brain stops if no newer Command comes in this
    decision_hz: float | None = None  # None: the policy's control rate, else 12 Hz
    driver_time_offset_s: float = 0.0  # match time at the start of driver control
    rings_held: int = 0  # what the observation says when the Brain has no ring counter
    intake_fills: bool = True  # the intake has a capacity (a policy with spec intake_flag reads it)
    # Place a camera result's rings from the pose the robot had when the frame was taken (the
    # States' poses over the last second), not from the newest one.
    frame_pose: bool = True
    # Drive at full speed while the Brain's pose (the GPS fused with odometry and the IMU) is
    # trusted this well: its State.pose_std at most this many metres; beyond it slower
    # (jetson.decide.pose_speed_scale). No pose (pose_fix lost) is a stop.
    pose_max_std_m: float = 0.15
    # The robot's role in its VEX AI alliance: the 24-inch or the 15-inch robot (a strategy that
    # shares the work reads it; the summary reports it).
    role: str = "24in"
    # What decides: "policy" (the ONNX policy at [policy] path) or "alliance" (the scripted
    # alliance of jetson/autonomy/alliance.py, playing the whole game as `role`).
    player: str = "policy"
    # The scripted alliance's steal (jetson/autonomy/alliance.py, AllianceConfig.steal_s): this
    # many seconds before the match's end (104: from the interaction period's first second) the
    # 24" stops scoring rings and takes neutral goals home, the other alliance's loaded one
    # first. 0: no steal (the 24" scores rings, both robots climb). Set it the same on both
    # robots of the alliance.
    steal_s: float = 104.0
    # With the steal: from 32 s before the end the 24" climbs after all, with the goal it holds
    # (another robot's loaded goal towed to its stage, always pulling, and up the board), and
    # the 15" climbs too (AllianceConfig.steal_climb). False: the 24" holds the goal home to
    # the end and the 15" stays balanced on the platform. The same on both robots.
    steal_climb: bool = True
    # A policy whose observation has the partner block (spec version 6) reads the partner's
    # reports over VEXlink while the newest is at most this old (they come about every 100 ms);
    # an older one counts as no partner: the robot plays alone.
    partner_max_age_s: float = 0.5

    def __post_init__(self) -> None:
        object.__setattr__(self, "drive_phases", tuple(self.drive_phases))
        for p in self.drive_phases:
            if p not in PHASES[1:]:
                raise SettingsError(
                    f"decision drive_phases: {p!r} is not a phase the policy may drive in "
                    "(autonomous, driver)"
                )
        age = self.perception_max_age_s
        if not (isinstance(age, int | float) and age > 0 and math.isfinite(age)):
            raise SettingsError("decision perception_max_age_s must be a positive number")
        partner_age = self.partner_max_age_s
        if not (
            isinstance(partner_age, int | float)
            and not isinstance(partner_age, bool)
            and 0 < partner_age <= 5.0
        ):
            raise SettingsError(
                "decision partner_max_age_s must be a number of seconds in (0, 5] (the partner "
                f"reports every 0.1 s), got {partner_age!r}"
            )
        if not (isinstance(self.valid_ms, int) and 1 <= self.valid_ms <= 1000):
            raise SettingsError("decision valid_ms must be 1..1000 (the Brain caps it at 1000)")
        if self.decision_hz is not None and not 0 < self.decision_hz <= 1000:
            raise SettingsError(
                f"decision decision_hz must be in (0, 1000], got {self.decision_hz}"
            )
        if not (math.isfinite(self.driver_time_offset_s) and self.driver_time_offset_s >= 0):
            raise SettingsError("decision driver_time_offset_s must be >= 0")
        if not (isinstance(self.rings_held, int) and self.rings_held >= 0):
            raise SettingsError("decision rings_held must be a whole number >= 0")
        if not isinstance(self.intake_fills, bool):
            raise SettingsError("decision intake_fills must be true or false")
        if not isinstance(self.frame_pose, bool):
            raise SettingsError("decision frame_pose must be true or false")
        std = self.pose_max_std_m
        if not (isinstance(std, int | float) and not isinstance(std, bool) and 0 < std <= 2.0):
            raise SettingsError(
                f"decision pose_max_std_m must be a number of metres in (0, 2], got {std!r}"
            )
        if self.role not in ROLES:
            raise SettingsError(
                f"decision role must be one of {', '.join(ROLES)} (the robot's size), "
                f"got {self.role!r}"
            )
        if self.player not in PLAYERS:
            raise SettingsError(
                f"decision player must be one of {', '.join(PLAYERS)}, got {self.player!r}"
            )
        steal = self.steal_s
        if not (
            isinstance(steal, int | float)
            and not isinstance(steal, bool)
            and math.isfinite(steal)
            and 0 <= steal <= 120
        ):
            raise SettingsError(
                "decision steal_s must be seconds before the match's end in [0, 120] "
                f"(0: no steal), got {steal!r}"
            )
        if not isinstance(self.steal_climb, bool):
            raise SettingsError("decision steal_climb must be true or false")

    def to_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["drive_phases"] = list(self.drive_phases)
        return d

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> DecisionConfig:
        return _merge(cls(), data, "decision")


@dataclass(frozen=True)
class PolicySettings:
    path: str = str(DEFAULT_POLICY)  # policy.onnx (policy.json beside it) or its folder
    providers: tuple[str, ...] | None = None  # onnxruntime's, in order; None: the best installed

    def __post_init__(self) -> None:
        _check_providers(self, "policy")


@dataclass(frozen=True)
class CameraSettings:
    enabled: bool = True
    source: str = "realsense"  # see jetson/perception/sources: realsense, unix:PATH, a folder...
    detector: str = "cnn"  # cnn | classical
    model: str | None = None  # detector weights; None: the shipped ones
    threshold: float | None = None
    config: str | None = None  # camera config JSON from `pete-jetson calibrate`
    prefilter: bool = False
    retry_s: float = 1.0  # wait before reopening a failed camera
    frame_clock: bool = False  # frames are stamped on the daemon's clock (a lockstep simulator)
    providers: tuple[str, ...] | None = None  # the CNN's onnxruntime providers; None: the best
    # Find the mobile goals in each frame too (jetson/perception/goals.py), for the scripted
    # alliance; None: on when [decision] player is "alliance" (Settings.detects_goals).
    goals: bool | None = None
    # Find the robots in each frame too, by their licence plates (jetson/perception/robots.py),
    # for a policy whose observation reads the robots it sees; None: as that policy needs
    # (Settings.detects_robots, then jetson.service.make_camera).
    robots: bool | None = None

    def __post_init__(self) -> None:
        _check_providers(self, "camera")
        if self.detector not in ("cnn", "classical"):
            raise SettingsError(f"camera detector must be cnn or classical, not {self.detector!r}")
        if not self.retry_s > 0:
            raise SettingsError("camera retry_s must be positive")


@dataclass(frozen=True)
class RecordSettings:
    dir: str | None = "/var/lib/pete-jetson/sessions"  # None or "": do not record
    keep_mb: float = 2000.0  # the recordings' disk budget: the oldest sessions go first
    compress: bool = True
    # Downscaled camera frames kept a second (JPEG, with their detections), for the dashboard's
    # replay; 0 keeps none.
    frames_hz: float = 3.0
    frame_width: int = 160  # pixels

    def __post_init__(self) -> None:
        if not self.keep_mb > 0:
            raise SettingsError(
                f"record keep_mb must be a positive number of MB, got {self.keep_mb}"
            )
        if not (math.isfinite(self.frames_hz) and 0 <= self.frames_hz <= 30):
            raise SettingsError(f"record frames_hz must be in [0, 30], got {self.frames_hz}")
        if not 32 <= self.frame_width <= 640:
            raise SettingsError(f"record frame_width must be in [32, 640], got {self.frame_width}")


@dataclass(frozen=True)
class DashboardSettings:
    # "[HOST:]PORT" to serve the dashboard on (jetson/dashboard/README.md); "" is off. A port
    # alone listens on 127.0.0.1 only: at a field give the Jetson's hotspot or Ethernet address.
    address: str = ""
    state_hz: float = 20.0  # snapshots a second to each browser
    camera_hz: float = 10.0  # camera frames a second to each browser
    frame_width: int = 320  # the camera picture's width, pixels

    def __post_init__(self) -> None:
        if self.address:
            from jetson.dashboard.address import parse_address

            try:
                parse_address(self.address)
            except ValueError as exc:
                raise SettingsError(str(exc)) from None
        for name in ("state_hz", "camera_hz"):
            v = getattr(self, name)
            if not (math.isfinite(v) and 0.5 <= v <= 60):
                raise SettingsError(f"dashboard {name} must be in [0.5, 60], got {v}")
        if not 64 <= self.frame_width <= 1280:
            raise SettingsError(
                f"dashboard frame_width must be in [64, 1280], got {self.frame_width}"
            )


@dataclass(frozen=True)
class LogSettings:
    file: str | None = None  # JSON lines; None: stdout
    level: str = "info"
    summary: bool = True  # the human summary line on stderr each second
    summary_period_s: float = 1.0

    def __post_init__(self) -> None:
        if self.level not in ("debug", "info", "warning", "error"):
            raise SettingsError(f"log level must be debug, info, warning or error: {self.level!r}")


@dataclass(frozen=True)
class SystemSettings:
    # While the daemon runs, CPUs wake within this many microseconds (a PM QoS request on
    # /dev/cpu_dma_latency, jetson/cpu_latency.py): 0 keeps idle CPUs polling, for the shortest
    # State -> Command tail at some power; -1 makes no request.
    cpu_wake_latency_us: int = 0

    def __post_init__(self) -> None:
        us = self.cpu_wake_latency_us
        if isinstance(us, bool) or not isinstance(us, int) or not -1 <= us <= 1_000_000:
            raise SettingsError(
                "system cpu_wake_latency_us must be a whole number of microseconds in "
                f"[0, 1000000], or -1 for no request; got {us!r}"
            )


@dataclass(frozen=True)
class Settings:
    link: LinkConfig = field(default_factory=LinkConfig)
    decision: DecisionConfig = field(default_factory=DecisionConfig)
    policy: PolicySettings = field(default_factory=PolicySettings)
    camera: CameraSettings = field(default_factory=CameraSettings)
    record: RecordSettings = field(default_factory=RecordSettings)
    log: LogSettings = field(default_factory=LogSettings)
    dashboard: DashboardSettings = field(default_factory=DashboardSettings)
    system: SystemSettings = field(default_factory=SystemSettings)

    def detects_goals(self, policy_reads_goals: bool = False) -> bool:
        """Whether the camera finds goals: [camera] goals, or when it is not set, whether the
        scripted alliance decides (it reads goals) or the policy's goal memory is corrected by
        sight (`policy_reads_goals`, known once the policy is loaded: spec goal_sight)."""
        if self.camera.goals is not None:
            return self.camera.goals
        return self.decision.player == "alliance" or policy_reads_goals

    def detects_robots(self, policy_reads_robots: bool = False) -> bool:
        """Whether the camera finds robots: [camera] robots, or when it is not set, whether the
        policy's observation reads the robots it sees (`policy_reads_robots`). That is known only
        once the policy is loaded, so the settings alone say off: jetson.service.build passes it
        for a policy whose spec reads seen opponents (`seen_opponents`), through make_camera."""
        if self.camera.robots is not None:
            return self.camera.robots
        return policy_reads_robots

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> Settings:
        """Settings from a config file's tables, every value checked (jetson.config_check)."""
        return _merge(cls(), data, "")

    @classmethod
    def load(cls, path: str | Path) -> Settings:
        try:
            data = tomllib.loads(Path(path).read_text())
        except FileNotFoundError as exc:
            raise SettingsError(f"config file {path} does not exist") from exc
        except (OSError, tomllib.TOMLDecodeError) as exc:
            raise SettingsError(f"config file {path}: {exc}") from exc
        try:
            return cls.from_dict(data)
        except SettingsError as exc:
            raise SettingsError(f"config file {path}: {exc}") from exc

    def with_overrides(self, **groups: dict[str, Any]) -> Settings:
        """A copy with some settings replaced, e.g. with_overrides(link={"port": "/dev/x"});
        None values are ignored (an option that was not given). Every value is checked as the
        file's are; an error names the command line and the key."""
        data = {}
        for group, values in groups.items():
            values = {k: v for k, v in values.items() if v is not None}
            if values:
                data[group] = values
        try:
            return _merge(self, data, "")
        except SettingsError as exc:
            raise SettingsError(f"command line: {exc}") from exc
