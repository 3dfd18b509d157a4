"""`pete-jetson run` and `pete-jetson replay`: settings in, a running daemon out.

    build(settings)     -> Service: the policy, the camera (a process of its own), the recorder,
                        the Daemon
    Service.run()       serves until SIGTERM/SIGINT (or stop()), then sends a stop and exits
                        (within a second: the handlers only set a flag the loop looks at)
    add_commands(sub)   registers `run` and `replay` with pete-jetson's argument parser

The heavy imports (numpy, onnxruntime, OpenCV, jetson.autonomy.spec) happen inside these functions,
so that `pete-jetson --help` and the other commands stay light.
"""

from __future__ import annotations

import argparse
import json
import signal
import sys
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from types import FrameType
from typing import Any, TextIO

from jetson.errors import CameraProcessError, SettingsError
from jetson.settings import PLAYERS, ROLES, Settings

# Python hands the interpreter between threads every 5 ms by default: a State arriving while the
# camera thread runs Python code could wait that long. 1 ms bounds the wait at a small cost to
# the camera thread.
SWITCH_INTERVAL_S = 0.001
# After SIGTERM the stop Command goes first; then the recording's writer (Daemon.shutdown) and
# the camera thread get a few tenths of a second each to finish (both are daemon threads: the
# process exits regardless), so that the daemon is gone within a second of the signal.
CAMERA_WAIT_S = 0.3
DASHBOARD_WAIT_S = 0.2

HELP = """\
  pete-jetson run          the daemon: talk to the Brain, see rings, drive (jetson/README.md)
  pete-jetson replay       re-run a recorded session through the decision code, report changes
"""


class StopFlag:
    """A request to stop that a signal handler may make: set() writes two attributes and takes no
    lock (threading.Event.set takes one, which the interrupted thread may be holding). The loop
    looks at it every turn (at most ~0.1 s apart)."""

    def __init__(self) -> None:
        self.signum: int | None = None  # the signal that asked, if one did
        self._set = False

    def set(self, signum: int | None = None) -> None:
        if signum is not None:
            self.signum = signum
        self._set = True

    def is_set(self) -> bool:
        return self._set

    def wait(self, timeout: float) -> bool:
        deadline = time.monotonic() + timeout
        while not self._set:
            left = deadline - time.monotonic()
            if left <= 0:
                break
            time.sleep(min(left, 0.01))
        return self._set


@dataclass
class Service:
    """A built daemon and what it owns."""

    daemon: Any  # jetson.loop.Daemon
    camera: Any | None = None  # jetson.camera_process.CameraProcess or camera_feed.CameraWorker
    stop_event: StopFlag = field(default_factory=StopFlag)
    _files: list[TextIO] = field(default_factory=list)
    dashboard: Any | None = None  # jetson.dashboard.process.DashboardProcess, not started yet
    # The PM QoS request run() holds while the loop runs (jetson/cpu_latency.py); None: none.
    cpu_wake: Any | None = None
    _camera_started: bool = False

    def stop(self) -> None:
        self.stop_event.set()

    def start_camera(self) -> None:
        """Start the camera (once; run() starts it when no one has). A camera in its own process
        builds its pipeline here and raises CameraProcessError when it cannot (a missing model, a
        bad camera config)."""
        if self.camera is not None and not self._camera_started:
            self._camera_started = True
            self.camera.start()

    def run(self) -> int:
        sys.setswitchinterval(SWITCH_INTERVAL_S)
        if not self.stop_event.is_set():
            self.start_camera()
        self.start_dashboard()
        self.hold_cpu_wake_latency()
        try:
            self.daemon.run(self.stop_event)
        finally:
            if self.cpu_wake is not None:
                self.cpu_wake.release()
            if self.camera is not None:
                self.camera.stop(CAMERA_WAIT_S)
            if self.dashboard is not None:
                self.dashboard.stop(DASHBOARD_WAIT_S)
            for f in self._files:
                f.close()
        return 0

    def hold_cpu_wake_latency(self) -> None:
        """Keep the CPUs quick to wake while the loop runs, or log why they are not."""
        wake = self.cpu_wake
        if wake is None:
            return
        why = wake.hold()
        log = self.daemon.log
        if why is None:
            log.info(
                "cpu_wake_latency",
                f"CPUs wake within {wake.microseconds} us while the daemon runs",
                microseconds=wake.microseconds,
            )
        else:
            log.warning(
                "cpu_wake_latency",
                f"{why}: CPUs may sleep deeply between States, and the latency tail is longer "
                "(run as root, or install jetson/deploy/99-pete-brain.rules)",
            )

    def start_dashboard(self) -> None:
        """Launch the dashboard's process, if there is one, and go on: a thread waits for it to
        listen and logs where, or why it cannot; a dashboard that cannot listen is left off and
        the robot drives without it."""
        dashboard = self.dashboard
        if dashboard is None:
            return
        try:
            dashboard.launch()
        except OSError as exc:
            self._no_dashboard(str(exc))
            return
        threading.Thread(
            target=self._await_dashboard, args=(dashboard,), name="pete-dashboard-start",
            daemon=True,
        ).start()  # fmt: skip

    def _await_dashboard(self, dashboard: Any) -> None:
        why = dashboard.await_ready()
        if why is not None:
            self._no_dashboard(why)
            return
        url = dashboard.url
        self.daemon.log.info("dashboard", f"dashboard (read-only) at {url}", url=url)

    def _no_dashboard(self, why: str) -> None:
        self.daemon.log.error("dashboard", f"no dashboard: {why}")
        self.daemon.observer = None
        if self.daemon.frames is not None:
            self.daemon.frames.sink = None
        self.dashboard = None

    def install_signal_handlers(self) -> None:
        """SIGTERM (systemd stop) and SIGINT (Ctrl-C) end the loop, which sends a stop first."""
        install_signal_handlers(self.stop_event)


def install_signal_handlers(flag: StopFlag) -> None:
    """SIGTERM and SIGINT set `flag`, and do nothing else: a handler runs between two bytecodes
    of the main thread, which may hold the log's lock (or any other), so logging or taking a
    lock there can hang the process for good. The loop sees the flag, logs the signal, sends a
    stop and exits."""

    def handler(signum: int, _frame: FrameType | None) -> None:
        flag.set(signum)

    signal.signal(signal.SIGTERM, handler)
    signal.signal(signal.SIGINT, handler)


def build(
    settings: Settings,
    clock: Any | None = None,
    log_stream: TextIO | None = None,
    human_stream: TextIO | None = None,
    policy: Any | None = None,
    perception: Any | None = None,
    boot_id: int | None = None,
    fingerprint: int | None = None,
) -> Service:
    """Everything `pete-jetson run` runs, from settings. Pass clock / policy / perception to
    replace the real ones (a lockstep simulator, tests); fingerprint plays a Jetson built from
    another schema (tests of the refusal)."""
    from jetson.autonomy.policy import OnnxPolicy
    from jetson.clock import MonotonicClock
    from jetson.decide import Decider
    from jetson.link import PortLocator
    from jetson.log import EventLog
    from jetson.loop import Daemon
    from jetson.recorder import RecordingDir

    clock = clock or MonotonicClock()
    files: list[TextIO] = []
    if log_stream is None:
        if settings.log.file:
            path = Path(settings.log.file)
            path.parent.mkdir(parents=True, exist_ok=True)
            log_stream = path.open("a", encoding="utf-8")
            files.append(log_stream)
        else:
            log_stream = sys.stdout
    if human_stream is None and settings.log.summary:
        human_stream = sys.stderr
    log = EventLog(log_stream, human_stream, clock, settings.log.level)
    decider: Any
    if settings.decision.player == "alliance":
        # The scripted alliance decides (jetson/scripted.py): no policy file is read.
        from jetson.scripted import ScriptedDecider

        decider = ScriptedDecider(settings.decision)
        policy_header: dict[str, Any] = {
            "path": None, "sha256": None, "description": decider.description,
        }  # fmt: skip
    else:
        if policy is None:
            policy = OnnxPolicy(settings.policy.path, providers=settings.policy.providers)
            log.info("onnxruntime", f"policy runs on {policy.provider}", policy=policy.provider)
        # Only a policy whose ring memory looks through the camera reads [camera]'s mount here,
        # so a cone policy runs as before whatever that file holds.
        needs_camera = policy.spec.memory_needs_camera
        decider = Decider(
            policy, settings.decision, memory_camera(settings.camera) if needs_camera else None
        )
        policy_header = {
            "path": str(Path(getattr(policy, "path", "")).resolve())
            if hasattr(policy, "path")
            else None,
            "sha256": getattr(policy, "sha256", None),
            "description": getattr(policy, "description", type(policy).__name__),
        }
    camera = None
    if perception is None and settings.camera.enabled:
        # On the machine's own clock the camera runs in a process of its own; a lockstep
        # simulator's clock exists only in this process, so its camera is a thread here.
        own = isinstance(clock, MonotonicClock)
        camera = make_camera(
            settings, clock, log, own_process=own, robots=policy_reads_robots(decider),
            goals=policy_reads_goals(decider),
        )  # fmt: skip
        perception = camera
    recordings = None
    if settings.record.dir:
        keep = int(settings.record.keep_mb * 1e6)
        recordings = RecordingDir(
            Path(settings.record.dir), keep, settings.record.compress,
            frames_hz=settings.record.frames_hz, frame_width=settings.record.frame_width,
        )  # fmt: skip
    header = {
        "policy": policy_header,
        "camera": {"enabled": perception is not None, "source": settings.camera.source},
        # What the ring memory looked through, so a replay decides as the daemon did.
        "memory_camera": asdict(decider.camera) if decider.camera is not None else None,
    }
    daemon = Daemon(
        decider,
        clock,
        log,
        perception=perception,
        link=settings.link,
        locator=PortLocator(settings.link.port),
        recordings=recordings,
        header=header,
        boot_id=boot_id,
        summary_period_s=settings.log.summary_period_s,
        **({} if fingerprint is None else {"fingerprint": fingerprint}),
    )
    # The camera thread, ours or the caller's (a CameraWorker given as `perception`), hands
    # small copies of its frames to the recording and the dashboard.
    camera_thread = camera if camera is not None else perception
    if not hasattr(camera_thread, "tap"):
        camera_thread = None
    if camera_thread is not None and recordings is not None and settings.record.frames_hz > 0:
        period, width = 1.0 / settings.record.frames_hz, settings.record.frame_width
        if hasattr(camera_thread, "frame_copies"):  # a camera in its own process
            daemon.frames = camera_thread.frame_copies(period, width)
        else:
            from jetson.frames import FrameTap

            daemon.frames = camera_thread.tap = FrameTap(period, width)
    dashboard = None
    if settings.dashboard.address:
        from jetson.dashboard.process import live_server

        dashboard = live_server(
            daemon, camera_thread, settings.dashboard, settings.record.dir or None,
            "pete-jetson run",
        )  # fmt: skip
    log.info(
        "config",
        f"policy {header['policy']['description']}, decisions at {decider.decision_hz:g} Hz, "
        f"drives in {', '.join(settings.decision.drive_phases) or 'no phase'}",
        settings=_settings_dict(settings),
    )
    cpu_wake = None
    if settings.system.cpu_wake_latency_us >= 0 and isinstance(clock, MonotonicClock):
        from jetson.cpu_latency import CpuWakeLatency

        cpu_wake = CpuWakeLatency(settings.system.cpu_wake_latency_us)
    return Service(daemon, camera, _files=files, dashboard=dashboard, cpu_wake=cpu_wake)


def memory_camera(camera_settings: Any) -> Any:
    """The camera as the ring memory sees through it (jetson.autonomy.spec.MemoryCamera): [camera]'s
    config file, or the default mount and intrinsics without one."""
    from jetson.autonomy.camera import MemoryCamera
    from jetson.perception.camera import CameraConfig

    cs = camera_settings
    camera = CameraConfig.load(Path(cs.config)) if cs.config else CameraConfig()
    k, m = camera.intrinsics, camera.mount
    return MemoryCamera(
        fx=k.fx, fy=k.fy, cx=k.cx, cy=k.cy, width=k.width, height=k.height,
        forward_m=m.forward_m, right_m=m.right_m, height_m=m.height_m, tilt_deg=m.tilt_deg,
    )  # fmt: skip


def policy_reads_robots(decider: Any) -> bool:
    """Whether the decider's observation reads the robots the camera sees: its spec's
    `seen_opponents` (false for a spec without it, and for the scripted alliance)."""
    return bool(getattr(getattr(decider, "spec", None), "seen_opponents", False))


def policy_reads_goals(decider: Any) -> bool:
    """Whether the decider's goal memory is corrected by the goals the camera sees: its spec's
    `goal_sight` (false for a spec without it; the scripted alliance: Settings.detects_goals)."""
    return bool(getattr(getattr(decider, "spec", None), "goal_sight", False))


def make_camera(
    settings: Settings,
    clock: Any,
    log: Any,
    own_process: bool = False,
    robots: bool = False,
    goals: bool = False,
) -> Any:
    """The camera thread over the configured source and pipeline; a camera that is absent or
    fails later is retried by the thread, forever. `own_process`: the thread runs in a process
    of its own (jetson/camera_process.py), not started yet: its start() builds the pipeline and
    fails as this function would; `clock` must then be the machine's monotonic clock. The goal
    detector runs when Settings.detects_goals says so, the robot detector when
    Settings.detects_robots does; `robots`: the policy reads the robots it sees
    (policy_reads_robots), which turns it on unless [camera] robots is set; `goals` likewise
    the goals (policy_reads_goals)."""
    from dataclasses import replace

    from jetson.camera_feed import CameraWorker
    from jetson.perception.pipeline import make_pipeline
    from jetson.perception.sources import open_source

    cs = replace(
        settings.camera,
        goals=settings.detects_goals(goals),
        robots=settings.detects_robots(robots),
    )
    if own_process:
        from jetson.camera_process import CameraProcess

        return CameraProcess(cs, log)
    camera, pipeline = make_pipeline(cs)
    if (provider := getattr(pipeline.detector, "provider", None)) is not None:
        log.info("onnxruntime", f"ring detector runs on {provider}", detector=provider)
    return CameraWorker(
        lambda: open_source(cs.source, camera.intrinsics),
        pipeline.process,
        clock,
        log,
        retry_s=cs.retry_s,
        frame_clock=cs.frame_clock,
    )


def _settings_dict(settings: Settings) -> dict[str, Any]:
    return asdict(settings)


# --- command line ---------------------------------------------------------------------------------


def add_commands(sub: argparse._SubParsersAction) -> None:
    # The defaults the options show are the settings' own (an option overrides the file).
    d = Settings()
    p = sub.add_parser(
        "run",
        help="the daemon: Brain link, perception, policy, Commands",
        description="Run the Jetson daemon until SIGTERM/SIGINT (then it sends a stop). "
        "Settings come from --config (TOML, see jetson/deploy/pete-jetson.toml) and these "
        "options, which override it; the defaults shown are those of a config without the key.",
    )
    p.add_argument("--config", type=Path, help="settings file (TOML) (default: none)")
    p.add_argument("--port", help="the Brain's user port (default: found over USB)")
    p.add_argument(
        "--policy", help="policy.onnx or its folder (default: the shipped jetson/models/policy/)"
    )
    p.add_argument(
        "--camera-source",
        help="realsense[:SERIAL], unix:PATH, tcp:HOST:PORT, a recording or image folder, a "
        f"video, synthetic[:FPS] (default: {d.camera.source})",
    )
    p.add_argument(
        "--camera-config",
        help="camera config JSON from `pete-jetson calibrate` (default: the built-in D435)",
    )
    p.add_argument(
        "--detector",
        choices=("cnn", "classical"),
        help=f"ring detector (default: {d.camera.detector})",
    )
    p.add_argument(
        "--detector-model", help="ring detector weights, .onnx (default: the shipped model)"
    )
    p.add_argument(
        "--no-camera", action="store_true", help="run without perception (the policy sees no rings)"
    )
    p.add_argument(
        "--frame-clock",
        action="store_true",
        default=None,
        help="the camera's frame timestamps are on this machine's monotonic clock",
    )
    p.add_argument(
        "--player",
        choices=PLAYERS,
        help="what decides: the ONNX policy (--policy), or the scripted alliance playing the "
        f"whole game as --role (default: {d.decision.player})",
    )
    p.add_argument(
        "--role",
        choices=ROLES,
        help=f"this robot in its VEX AI alliance (default: {d.decision.role})",
    )
    p.add_argument(
        "--drive-phases",
        help="comma-separated phases the policy may drive in "
        f"(default: {','.join(str(x) for x in d.decision.drive_phases)})",
    )
    p.add_argument(
        "--max-perception-age",
        type=float,
        help="older camera results count as no rings in view, seconds "
        f"(default: {d.decision.perception_max_age_s})",
    )
    p.add_argument(
        "--valid-ms",
        type=int,
        help=f"Command validity window, milliseconds (default: {d.decision.valid_ms})",
    )
    p.add_argument(
        "--record-dir", help=f"where session recordings go (default: {d.record.dir or 'none'})"
    )
    p.add_argument("--no-record", action="store_true", help="do not record sessions")
    p.add_argument("--log", help="JSON-lines log file (default: stdout)")
    p.add_argument(
        "--log-level",
        choices=("debug", "info", "warning", "error"),
        help=f"least severe level logged (default: {d.log.level})",
    )
    p.add_argument("--quiet", action="store_true", help="no human summary line on stderr")
    p.add_argument(
        "--dashboard",
        metavar="[HOST:]PORT",
        help="serve the read-only dashboard here (a port alone: 127.0.0.1 only; at a field the "
        "Jetson's hotspot or Ethernet address) (default: off)",
    )
    p.set_defaults(func=cmd_run)

    r = sub.add_parser(
        "replay",
        help="re-run a session recording through the decision code and report differences",
    )
    r.add_argument("file", type=Path, help="a session-*.jsonl[.gz] recording")
    r.add_argument("--policy", help="policy to replay with (default: the recorded path)")
    r.add_argument(
        "--tolerance",
        type=float,
        default=1e-6,
        help="largest difference that is not one, m/s, rad/s",
    )
    r.add_argument("--show", type=int, default=10, help="differences to list")
    r.add_argument("--json", action="store_true", help="print the report as JSON")
    r.set_defaults(func=cmd_replay)


def settings_from_args(args: argparse.Namespace) -> Settings:
    settings = Settings.load(args.config) if args.config else Settings()
    phases = None
    if args.drive_phases is not None:
        phases = tuple(p.strip() for p in args.drive_phases.split(",") if p.strip())
    settings = settings.with_overrides(
        link={"port": args.port},
        policy={"path": args.policy},
        camera={
            "source": args.camera_source,
            "config": args.camera_config,
            "detector": args.detector,
            "model": args.detector_model,
            "frame_clock": args.frame_clock,
            "enabled": False if args.no_camera else None,
        },
        decision={
            "player": args.player,
            "role": args.role,
            "drive_phases": phases,
            "perception_max_age_s": args.max_perception_age,
            "valid_ms": args.valid_ms,
        },
        record={"dir": "" if args.no_record else args.record_dir},
        log={
            "file": args.log,
            "level": args.log_level,
            "summary": False if args.quiet else None,
        },
        dashboard={"address": getattr(args, "dashboard", None)},
    )
    return settings


def cmd_run(args: argparse.Namespace) -> int:
    try:
        settings = settings_from_args(args)
        service = build(settings)
        service.start_camera()
    except (SettingsError, ValueError, CameraProcessError) as exc:
        raise RuntimeError(str(exc)) from exc
    # Until here a signal has its default effect (SIGTERM ends the process at once): no Brain
    # has been talked to yet.
    service.install_signal_handlers()
    return service.run()


def cmd_replay(args: argparse.Namespace) -> int:
    from jetson.autonomy.policy import OnnxPolicy
    from jetson.replay import replay

    policy = OnnxPolicy(args.policy) if args.policy else None
    report = replay(args.file, policy, args.tolerance)
    if args.json:
        print(json.dumps(report.as_dict(), indent=1, default=str))
    else:
        print(report.text(args.show))
    return 0 if report.ok else 1
