"""What a full-stack match is asked for, and what its parts share without importing each other.

MatchOptions is one match's options (pete-sim match's flags); LOOP_MS the Brain's loop period.
RunningMatch is what a fault scenario (sim.fullstack.faults) reads and changes of the match that
runs it (sim.fullstack.runner.FullStackMatch is the one), so the scenarios need not import the
runner that imports them.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from pathlib import Path
from typing import TYPE_CHECKING, Any, Protocol

from jetson.models import DEFAULT_DETECTOR, DEFAULT_POLICY
from sim.errors import MatchError

if TYPE_CHECKING:
    from jetson.clock import Clock
    from sim.fullstack.brain_host import BrainReport
    from sim.fullstack.cable import Cable
    from sim.world.physics import World

STACKS = ("full", "sim")
DAEMON_MODES = (None, "inprocess", "process")
LOOP_MS = 10  # the Brain's loop period (brain_host reports it; checked at start)


@dataclass(frozen=True)
class MatchOptions:
    stack: str = "full"
    seed: int = 0
    policy: Path = DEFAULT_POLICY
    opponent: str = "planner"  # a sim player word (sim.evaluate.load_player) or "none"
    seconds: float | None = None  # stop the match early (the match clock still says 105 s)
    realtime: bool = False
    fault: str | None = None
    fault_at_s: float | None = None  # match time of the fault (default: a third of the match)
    scenario: str = "capped"
    camera: bool = True
    ring_counter: bool = True  # the simulated intake counts its rings (the State's rings_held)
    # The GPS loses the field strip behind robots, goals and platforms (sim.world.sensors.
    # GpsOcclusion) and the Brain rides through on odometry and its IMU; off: it never fails.
    gps_occlusion: bool = False
    # A RealSense gives 30 frames/s; rendering costs ~20 ms a frame here, so the lockstep match
    # renders 10/s at 240x180 (perception places rings as well as at 320x240: F1 0.85 both).
    camera_width: int = 240
    camera_height: int = 180
    camera_hz: float = 10.0
    detector: str = "auto"  # auto (cnn when its model is there, else classical) | cnn | classical
    detector_model: Path | None = None
    perception_latency_s: float = 0.05
    gif: bool = True
    gif_every_s: float = 0.5
    gif_size: int = 400
    plots: bool = True
    record: bool = False  # keep the daemon's session recording (sessions/ in the run folder)
    out: Path = Path("runs/match")
    brain_host: Path | None = None
    # Where the daemon runs: "inprocess" (a thread's worth of it in this process), "process"
    # (its own process, so that it gets real signals); None: a process only for the faults that
    # need one (sim.fullstack.faults).
    daemon: str | None = None
    # Several faults in one match, (name, match time s) each; instead of fault / fault_at_s.
    faults: tuple[tuple[str, float], ...] = ()
    # "[HOST:]PORT": the daemon's live dashboard (jetson/dashboard/README.md); None is off.
    dashboard: str | None = None
    # The match (sim.config.WORLD_PRESETS): None the ring race (our robot against `opponent`);
    # a whole-game world (tipping_point_2v2) plays VEX AI's match, our robot the red 24" run by
    # the daemon with the scripted alliance ([decision] player = "alliance"), its partner in
    # the twin by `partner`, the blue alliance by `opponent` (a side: NAME or NAME,NAME).
    # partner = "stack": the partner runs the full stack too (its own brain_host, daemon and
    # camera; sim.fullstack.partner_stack), the two Brains linked by VEXlink.
    world: str | None = None
    partner: str = "alliance"
    # What decides on our robots' Jetsons ([decision] player): "policy" (`policy`) or
    # "alliance" (the scripted alliance, the whole game only); None: the scripted alliance in
    # the whole game, the policy in the ring race. A learned alliance is "policy" with its
    # policy.onnx on both robots (--partner stack).
    player: str | None = None

    def __post_init__(self) -> None:
        if self.stack not in STACKS:
            raise MatchError(f"stack must be one of {STACKS}, got {self.stack!r}")
        if self.seconds is not None and not (self.seconds > 0 and math.isfinite(self.seconds)):
            raise MatchError(f"seconds must be a positive number, got {self.seconds}")
        if not 16 <= self.camera_width <= 1280 or not 12 <= self.camera_height <= 960:
            raise MatchError(
                f"camera size {self.camera_width}x{self.camera_height} is outside 16x12..1280x960"
            )
        period = 1000.0 / self.camera_hz if self.camera_hz > 0 else math.inf
        if not (math.isfinite(period) and abs(period / LOOP_MS - round(period / LOOP_MS)) < 1e-6):
            raise MatchError(
                f"camera_hz {self.camera_hz} must give a frame period that is a whole number of "
                f"{LOOP_MS} ms loop steps (e.g. 10, 5, 4, 2.5)"
            )
        if self.detector not in ("auto", "cnn", "classical"):
            raise MatchError(f"detector must be auto, cnn or classical, got {self.detector!r}")
        if not 0 <= self.perception_latency_s < period / 1000.0:
            raise MatchError(
                f"perception_latency_s must be >= 0 and shorter than the frame period "
                f"({period:g} ms): one frame is processed at a time"
            )
        if not self.gif_every_s > 0 or not 64 <= self.gif_size <= 2048:
            raise MatchError("gif_every_s must be > 0 and gif_size within 64..2048")
        if (self.fault is not None or self.faults) and self.stack != "full":
            raise MatchError("faults are scenarios of the full stack: use --stack full")
        if self.daemon not in DAEMON_MODES:
            raise MatchError(f"daemon must be one of {DAEMON_MODES[1:]}, got {self.daemon!r}")
        if self.daemon == "process" and self.realtime:
            raise MatchError("the daemon as a process runs in lockstep only: drop --realtime")
        if self.dashboard is not None and (self.stack != "full" or self.daemon == "process"):
            raise MatchError(
                "the dashboard follows the daemon in this process: --stack full, without "
                "--daemon process"
            )

        if self.world is not None:
            from sim.config import WORLD_PRESETS

            if self.world not in WORLD_PRESETS:
                raise MatchError(
                    f"world must be one of {', '.join(WORLD_PRESETS)}, got {self.world!r}"
                )
        if self.player not in (None, "policy", "alliance"):
            raise MatchError(f"player must be policy or alliance, got {self.player!r}")
        if self.player == "alliance" and not self.whole_game:
            raise MatchError("the scripted alliance plays the whole game: give --world")
        if self.partner == "stack":
            if self.stack != "full" or not self.whole_game:
                raise MatchError(
                    "--partner stack runs our partner on the full stack: it needs --stack full "
                    "and a whole-game --world (tipping_point_2v2)"
                )
            if self.realtime:
                raise MatchError("--partner stack runs in lockstep only: drop --realtime")

    @property
    def jetson_player(self) -> str:
        """What decides on our robots' Jetsons (`player`, its default by the match)."""
        if self.player is not None:
            return self.player
        return "alliance" if self.whole_game else "policy"

    @property
    def whole_game(self) -> bool:
        """A VEX AI match of the whole game, not the ring race."""
        from sim.config import WORLD_PRESETS

        return self.world is not None and (
            WORLD_PRESETS[self.world].get("game", "ring_race") != "ring_race"
        )

    @property
    def frame_period_ms(self) -> int:
        return round(1000.0 / self.camera_hz)

    def detector_choice(self) -> tuple[str, Path | None]:
        if self.detector == "auto":
            model = self.detector_model or DEFAULT_DETECTOR
            return ("cnn", model) if model.is_file() else ("classical", None)
        return self.detector, self.detector_model


class DaemonLike(Protocol):
    """What a fault scenario uses of the hosted daemon (sim.fullstack.daemon.DaemonHost, or
    sim.fullstack.daemon_process.DaemonProcess, which adds signals and a full disk)."""

    alive: bool
    results: dict[int, Any]
    exits: list[Any]

    @property
    def counters(self) -> Any: ...

    def kill(self) -> None: ...

    def sigterm(self, delay_s: float = 0.0) -> None: ...

    def set_disk_full(self, full: bool) -> None: ...


class MatchEvents(Protocol):
    """The replay's event list (events.txt, the plots' markers)."""

    def event(self, t_s: float, text: str) -> None: ...


class BrainRecord(Protocol):
    """What the Brain did over the match so far, from its reports."""

    applied: int  # distinct Commands that drove the motors
    faults_seen: set[str]
    link_states: set[str]
    ledger: bool  # lockstep: each step the Jetson drove is checked against its Command
    valid_ms: int
    jetson_steps: int
    invalid_steps: int
    invalid_examples: list[str]
    max_command_age_ms: int

    def age_ms(self, report: BrainReport) -> int | None: ...

    def applies_stop(self, report: BrainReport) -> bool: ...


class RunningMatch(Protocol):
    """What a fault scenario needs of the full-stack match that runs it."""

    folder: Path  # the run folder (daemon.jsonl)
    realtime: bool
    world: World
    ia: int  # the robot the stack drives
    match_len_ms: int
    extra_lines: list[str]  # side-channel commands for brain_host's next step
    camera_stopped: bool
    cable: Cable
    jetson: DaemonLike
    server: Any  # the frame stream (jetson.perception.sources.stream), None without a camera
    clock: Clock  # the daemon's clock
    replay: MatchEvents
    brain_track: BrainRecord
    vexlink: Any  # sim.fullstack.vexlink.Vexlink between the alliance's Brains (--partner stack)
    partner: Any  # sim.fullstack.partner_stack.PartnerStack, None without --partner stack

    @property
    def match_ms(self) -> int: ...

    def brain_now_ms(self) -> int: ...

    def step_match_ms(self, report: BrainReport) -> int: ...

    def restart_daemon(self) -> None: ...

    def power_off_brain(self) -> None: ...

    def boot_brain(self, boot_id: int) -> None: ...

    def stop_camera(self) -> None: ...

    def start_camera(self) -> None: ...
