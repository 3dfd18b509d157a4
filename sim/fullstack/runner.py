"""One match, `pete-sim match`: the whole robot stack on the simulated field, or the policy alone.

--stack full (lockstep, the default), every 10 ms loop step of the Brain:

    1. the simulator reads the robot's sensors (GPS, encoders, competition switch) and hands them
       to brain_host with the step itself, in one side-channel round trip;
    2. brain_host runs the Brain core's step: it writes its State (and Logs, Hellos) on its pty;
    3. the cable carries those bytes to the daemon's pty; the daemon, its clock set to the step's
       time, reads them and answers the State with a Command (policy + perception);
    4. the cable carries the Command back; brain_host waits for those bytes before its next step,
       where it applies them;
    5. the World moves the robot by what the Brain told its motors for these 10 ms (the opponent
       decides at the policy's 12 Hz); every 1 / camera_hz the robot's camera renders a frame,
       which goes to the daemon's camera thread over the frame stream.

Everything is ordered by the simulated clock, so a seed gives the same match every time, as fast
as the machine allows. --realtime instead runs brain_host on its own wall clock and the daemon in
its own thread, as on the robot; the simulator keeps up with the wall clock.

--stack sim runs the same policy directly in the simulator at 12 Hz with the simulator's own
observation (what `pete-sim eval` measures): the reference the full stack is compared against.
"""

from __future__ import annotations

import contextlib
import json
import math
import tempfile
import threading
import time
from collections.abc import Callable
from dataclasses import asdict, dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from jetson.autonomy.geometry import field_to_robot
from sim.camera import render_camera
from sim.errors import MatchError
from sim.fullstack.options import LOOP_MS, MatchOptions
from sim.fullstack.partner_stack import (
    finish_step,
    note_change,
    send_frame,
    send_step,
    service_daemon,
    stream_ready,
)
from sim.fullstack.report import (
    MatchResult,
    PerceptionScore,
    Sample,
    compose_frame,
    percentiles_ms,
    plot,
    project_rings,
    write_summary,
    write_timeline,
)
from sim.fullstack.vexlink import Radio
from sim.world import sensors

PREROLL_MS = 1000  # powered and disabled before the match: the two sides shake hands
SAMPLE_MS = 100
POLICY_HZ = 12.0
# Pixels (at 640x480) a ring must cover in a frame to count as shown: a whole ring 3 m away
# covers about 120.
MIN_RING_PX = 40


def run_match(options: MatchOptions, progress: Callable[[str], None] | None = None) -> MatchResult:
    """Play one match and write its run folder (options.out); returns the result."""
    if not options.policy.is_file():
        raise MatchError(
            f"no policy at {options.policy}: the shipped one is jetson/models/policy/policy.onnx "
            "(pete-sim train, then export), or pass --policy"
        )
    folder = options.out
    folder.mkdir(parents=True, exist_ok=True)
    if options.stack == "sim":
        return SimStackMatch(options, folder, progress).run()
    if options.realtime:
        return FullStackMatch(options, folder, progress).run_realtime()
    return FullStackMatch(options, folder, progress).run()


# --- shared pieces ------------------------------------------------------------------------------


def _load_players(options: MatchOptions) -> tuple[Any, Any]:
    from sim.errors import EvalError
    from sim.evaluate import load_player

    try:
        a = load_player(str(options.policy))
        b = None if options.opponent == "none" else load_player(options.opponent)
    except (EvalError, ValueError) as exc:
        raise MatchError(str(exc)) from exc
    specs = [x.spec for x in (a, b) if x is not None and x.spec is not None]
    if len({spec.fingerprint() for spec in specs}) > 1:
        raise MatchError(
            "the opponent policy expects another observation than ours; pick another opponent"
        )
    return a, b


def _env(options: MatchOptions, spec: Any, opponent: bool) -> Any:
    from sim.errors import EvalError
    from sim.evaluate import eval_env

    try:
        env = eval_env(options.scenario, "training", spec)
    except EvalError as exc:
        raise MatchError(str(exc)) from exc
    if not opponent:
        env = replace(env, world=replace(env.world, blue=()))
    return env


def _caption(world: Any, labels: tuple[str, str]) -> str:
    s = world.score()
    parts = [f"t {world.time_s:5.1f}s"]
    if len(world.robots) > 2:  # an alliance a side: one entry each
        for alliance, label in zip(("red", "blue"), labels, strict=True):
            rings = sum(r.collected for r in world.robots if r.alliance == alliance)
            parts.append(f"{alliance} ({label}): {rings} rings {s[alliance].total} pts")
        return "  ".join(parts)
    for r in world.robots:
        label = labels[0] if r.alliance == "red" else labels[1]
        parts.append(f"{label}: {r.collected} rings {s[r.alliance].total} pts")
    return "  ".join(parts)


@dataclass
class _Driven:
    """A robot the twin drives (the opponent, the partner): its player and its decision's
    state between the policy-rate steps."""

    index: int
    player: Any
    spec: Any  # the player's observation spec, or None for one that reads the world
    stack: Any = None
    command: Any = None
    k: int = -1


class _Replay:
    """GIF frames and samples while a match runs."""

    def __init__(self, options: MatchOptions) -> None:
        self.options = options
        self.frames: list[np.ndarray] = []
        self.interest: list[int] = []  # rings circled in each frame: replay.png shows the most
        self.samples: list[Sample] = []
        self.events: list[tuple[float, str]] = []
        self._next_gif = 0.0
        self._next_sample = SAMPLE_MS / 1000.0

    def gif_due(self, t_s: float) -> bool:
        if not self.options.gif or t_s + 1e-9 < self._next_gif:
            return False
        self._next_gif += self.options.gif_every_s
        return True

    def sample_due(self, t_s: float) -> bool:
        if t_s + 1e-9 < self._next_sample:
            return False
        self._next_sample += SAMPLE_MS / 1000.0
        return True

    def event(self, t_s: float, text: str) -> None:
        self.events.append((round(t_s, 3), text))

    def write(self, folder: Path, latencies_s: list[float], title: str) -> dict[str, str]:
        from sim.render import save_gif, save_png

        files = {"timeline": str(write_timeline(self.samples, folder / "timeline.csv"))}
        if self.frames:
            fps = min(25.0, max(2.0, 4.0 / self.options.gif_every_s))
            files["gif"] = str(save_gif(self.frames, folder / "replay.gif", fps=fps))
            best = int(np.argmax(self.interest)) if self.interest else len(self.frames) // 3
            files["png"] = str(save_png(self.frames[best], folder / "replay.png"))
        if self.options.plots and self.samples:
            files["plots"] = str(
                plot(self.samples, latencies_s, folder / "plots.png", title, self.events)
            )
        if self.events:
            (folder / "events.txt").write_text(
                "".join(f"{t:8.2f}  {what}\n" for t, what in self.events)
            )
            files["events"] = str(folder / "events.txt")
        return files


# --- the full stack -----------------------------------------------------------------------------


@dataclass
class BrainTrack:
    """What the Brain did over the match, from its reports."""

    applied: int = 0  # distinct Commands that drove the motors
    last_seq: int = 0
    source_ms: dict[str, int] = field(default_factory=dict)
    faults_seen: set[str] = field(default_factory=set)
    link_states: set[str] = field(default_factory=set)
    answered_at: dict[int, int] = field(default_factory=dict)  # Command seq -> State time, ms
    ages_ms: list[float] = field(default_factory=list)
    moved_ms: int = 0  # match time with the motors driven
    last: Any = None
    # Lockstep: every Command the Brain received (this boot), seq -> the step that read it, so
    # that each step the Jetson drove is checked against the Command it drove by.
    ledger: bool = False
    valid_ms: int = 250
    delivered: dict[int, int] = field(default_factory=dict)
    stop_seqs: set[int] = field(default_factory=set)  # those that said stop (no speed, no turn)
    jetson_steps: int = 0
    invalid_steps: int = 0  # driven by a Command never delivered as sent, or past its validity
    invalid_examples: list[str] = field(default_factory=list)
    max_command_age_ms: int = 0
    brains: int = 1

    def command_delivered(self, seq: int, t_ms: int, stop: bool = False) -> None:
        """A Command's bytes reached brain_host after its step at t_ms: it reads them at its
        next step, where the Command's validity starts."""
        self.delivered[int(seq)] = t_ms + LOOP_MS
        if stop:
            self.stop_seqs.add(int(seq))
        else:
            self.stop_seqs.discard(int(seq))

    def applies_stop(self, report: Any) -> bool:
        """The Brain is acting on a Command that says stop (braking under its acceleration
        limit, the motors still turning down to zero)."""
        return int(report.last_command_seq) in self.stop_seqs

    def age_ms(self, report: Any) -> int | None:
        """How old the Command the Brain applied at this step was (None: not one it read)."""
        at = self.delivered.get(int(report.last_command_seq))
        return None if at is None else report.last_step_ms - at

    def new_brain(self) -> None:
        """A rebooted Brain: it holds none of the Commands the old one received."""
        self.delivered.clear()
        self.stop_seqs.clear()
        self.last_seq = 0
        self.brains += 1

    def note(self, report: Any, in_match: bool) -> None:
        self.last = report
        if in_match:
            self.source_ms[report.source] = self.source_ms.get(report.source, 0) + LOOP_MS
            if report.moving:
                self.moved_ms += LOOP_MS
        if self.ledger and report.source == "jetson":
            self._check_command(report)
        self.faults_seen.update(report.faults)
        self.link_states.add(report.link)
        if report.last_command_seq != self.last_seq and report.last_command_seq != 0:
            self.last_seq = report.last_command_seq
            self.applied += 1
            answered = self.answered_at.pop(report.last_command_seq, None)
            if answered is not None:
                self.ages_ms.append(report.last_step_ms - answered)

    def _check_command(self, report: Any) -> None:
        """A step the Jetson drove: by a Command the Brain received, within its validity?"""
        self.jetson_steps += 1
        age = self.age_ms(report)
        why = None
        if age is None:
            why = f"Command {report.last_command_seq} was never delivered as sent"
        else:
            self.max_command_age_ms = max(self.max_command_age_ms, age)
            if age > self.valid_ms:
                why = f"Command {report.last_command_seq} was {age} ms old"
        if why is not None:
            self.invalid_steps += 1
            if len(self.invalid_examples) < 5:
                self.invalid_examples.append(f"step {report.last_step_ms} ms: {why}")

    def as_dict(self) -> dict[str, Any]:
        last = self.last
        return {
            "commands_applied": self.applied,
            "command_timeouts": last.timeouts if last else 0,
            "steps": last.steps if last else 0,
            "faults_seen": sorted(self.faults_seen),
            "link_states": sorted(self.link_states),
            "source_s": {k: v / 1000 for k, v in sorted(self.source_ms.items())},
            "driven_s": self.moved_ms / 1000,
            "command_age": percentiles_ms([a / 1000 for a in self.ages_ms]),
            "brains": self.brains,
            **(
                {
                    "jetson_steps": self.jetson_steps,
                    "invalid_command_steps": self.invalid_steps,
                    "max_command_age_ms": self.max_command_age_ms,
                }
                if self.ledger
                else {}
            ),
        }


class FullStackMatch:
    """brain_host + cable + in-process daemon + World, stepped together."""

    def __init__(
        self, options: MatchOptions, folder: Path, progress: Callable[[str], None] | None
    ) -> None:
        from sim.fullstack.faults import make_scenario

        self.options = options
        self.folder = folder
        self.progress = progress or (lambda _msg: None)
        self.scenario = make_scenario(options.fault, options.fault_at_s, options)
        self.replay = _Replay(options)
        self.brain_track = BrainTrack()
        self.truth: dict[int, np.ndarray] = {}
        self.extra_lines: list[str] = []  # side-channel commands a fault adds to the next step
        self.t_ms = 0
        self.frame_index = 0
        # The last few frames' images by index: the GIF shows the one the policy's rings came
        # from (the newest may still be in perception).
        self.camera_rgb: dict[int, np.ndarray] = {}
        self.camera_stopped = False  # a fault stopped the camera
        self.realtime = False
        self.server: Any = None
        self.dashboard: Any = None  # jetson.dashboard.process.DashboardProcess (--dashboard)
        self.frames_address: str | None = None
        self.jetson: Any = None
        self.daemon_mode = self.scenario.daemon_mode(options)
        self.brain: Any = None
        self.brain_offset_ms = 0  # the simulator's clock when this brain_host started
        self.brain_statuses: list[int | None] = []
        self.cable: Any = None
        self.others: list[_Driven] = []  # the robots the twin drives
        # --partner stack: the alliance partner on the full stack too, linked by VEXlink.
        self.partner_index: int | None = None
        self.partner: Any = None  # sim.fullstack.partner_stack.PartnerStack
        self.vexlink: Any = None  # sim.fullstack.vexlink.Vexlink between the two Brains
        self.radio: Radio | None = None  # our Brain's radio, with a partner
        self._partner_report: Any = None
        self.partner_links: list[tuple[int, str]] = []  # our Brain's link: (match ms, state)
        self._sent_seq = 0
        self._jetson_alive = False

    # --- setup ----------------------------------------------------------------------------------

    @property
    def match_ms(self) -> int:
        return self.t_ms - PREROLL_MS

    def brain_now_ms(self) -> int:
        """brain_host's clock now: the tick's time in lockstep; asked for in realtime."""
        return self.brain.get().t_ms if self.realtime else self.t_ms

    def step_match_ms(self, report: Any) -> int:
        """Match time of the Brain step a report describes, on the simulator's clock. In
        realtime brain_host keeps its own clock: its last step was (t - last_step_ms) before the
        report, which the simulator asked for at its current tick."""
        if self.realtime:
            return self.t_ms - (report.t_ms - report.last_step_ms) - PREROLL_MS
        return report.last_step_ms - PREROLL_MS

    def _setup(self, tmp: Path, realtime: bool) -> None:
        from jetson.clock import ManualClock, MonotonicClock
        from jetson.perception.camera import CameraConfig as JetsonCamera
        from sim.errors import DaemonError
        from sim.fullstack.cable import Cable
        from sim.fullstack.daemon import DaemonHost, DaemonOptions
        from sim.fullstack.hardware import RobotHardware
        from sim.match import MatchCore

        o = self.options
        if o.whole_game:
            self._setup_game()
        else:
            a, b = _load_players(o)
            self.labels = (a.label, b.label if b else "-")
            env = _env(o, a.spec, b is not None)
            world_cfg = replace(env.world, control_hz=1000.0 / LOOP_MS)
            self.core = MatchCore(env, world_cfg)
            self.core.reset(np.random.default_rng(o.seed))
            self.world = self.core.world
            self.ia = 0
            self.ib = 1 if b is not None else None
            if b is not None:
                self.others = [_Driven(1, b.make(), b.spec)]
        for d in self.others:
            d.player.reset(self.core, d.index, np.random.default_rng((o.seed, d.index)))
        self.hardware = RobotHardware(
            self.world,
            self.ia,
            np.random.default_rng((o.seed, 77)),
            o.ring_counter,
            gps_occlusion=sensors.GpsOcclusion() if o.gps_occlusion else None,
        )
        limit = self.world.match_length_s if o.seconds is None else o.seconds
        self.match_len_ms = round(min(limit, self.world.match_length_s) * 1000 / LOOP_MS) * LOOP_MS
        self.cam_cfg = self.world.robots[self.ia].config.camera.scaled(
            o.camera_width, o.camera_height
        )

        self._start_brain(0x5EED0000 + (o.seed & 0xFFFF), realtime)
        self.cable = Cable(self.brain.pty_path, tmp / "brain-usb", seed=o.seed)
        if not realtime:
            self.cable.keep_received(down=True)  # the Command ledger (BrainTrack)
            self.brain_track.ledger = True

        frames_address = None
        camera_file = None
        if o.camera:
            from jetson.perception.sources.stream import FrameStreamServer

            frames_address = f"unix:{tmp / 'frames.sock'}"
            self.frames_address = frames_address
            self.server = FrameStreamServer(frames_address)
            c = self.cam_cfg
            camera_file = self.folder / "camera.json"
            JetsonCamera(c.intrinsics, c.mount).save(camera_file)
        kind, model = o.detector_choice()
        self.detector = kind
        jopts = DaemonOptions(
            policy=o.policy,
            # The whole game: the scripted alliance decides on the robot, as this robot's role,
            # unless a policy was asked for (a learned alliance).
            player=o.jetson_player,
            role=self.world.robots[self.ia].config.name if o.whole_game else "24in",
            camera=o.camera,
            detector=kind,
            detector_model=model,
            camera_config=camera_file,
            perception_latency_s=o.perception_latency_s,
            boot_id=0x7E750000 + (o.seed & 0xFFFF),
            fingerprint=self.scenario.jetson_fingerprint(),
            record_dir=self.folder / "sessions" if o.record else None,
        )
        self.brain_track.valid_ms = jopts.valid_ms
        self.clock = MonotonicClock() if realtime else ManualClock(0.0)
        self.daemon_log = (self.folder / "daemon.jsonl").open("w")
        try:
            if self.daemon_mode == "process":
                from sim.fullstack.daemon_process import DaemonProcess

                (self.folder / "daemon.stderr").unlink(missing_ok=True)
                self.jetson = DaemonProcess(
                    jopts, self.clock, self.cable.port_path, frames_address, self.daemon_log,
                    self.folder / "daemon.stderr", realtime=realtime,
                )  # fmt: skip
            else:
                self.jetson = DaemonHost(
                    jopts, self.clock, self.cable.port_path, frames_address, self.daemon_log,
                    realtime=realtime,
                )  # fmt: skip
        except DaemonError as exc:
            raise MatchError(str(exc)) from exc
        if o.dashboard is not None:
            self._start_dashboard()
        self.jetson.start()
        self._jetson_alive = True
        self._accept_camera()
        if self.partner_index is not None:
            self._start_partner(tmp, jopts)

    def _start_partner(self, tmp: Path, jopts: Any) -> None:
        """The partner's full stack, and the VEXlink radio between the two Brains."""
        from sim.fullstack.partner_stack import PartnerStack
        from sim.fullstack.vexlink import Vexlink, VexlinkConfig

        assert self.partner_index is not None
        o = self.options
        self.partner = PartnerStack.start(
            self.world, self.partner_index, o, self.folder, tmp, self.clock, jopts
        )
        self.vexlink = Vexlink(VexlinkConfig(), np.random.default_rng((o.seed, 46)))
        self.radio = Radio()
        self.brain.set_radio("on")
        self.partner.brain.set_radio("on")

    def _setup_game(self) -> None:
        """The whole game (options.world): our robot is the red alliance's first (the 24"), its
        partner and the blue alliance are players in the twin (sim.evaluate.load_side)."""
        from sim.errors import EvalError
        from sim.evaluate import eval_env, load_side, side_label
        from sim.match import MatchCore

        o = self.options
        on_stack = o.partner == "stack"
        try:
            partner = load_side("alliance" if on_stack else o.partner)
            blue = load_side(o.opponent)
            env = eval_env(o.scenario, "training", world=o.world)
        except (EvalError, ValueError) as exc:
            raise MatchError(str(exc)) from exc
        world_cfg = replace(env.world, control_hz=1000.0 / LOOP_MS)
        self.core = MatchCore(env, world_cfg)
        self.core.reset(np.random.default_rng(o.seed))
        self.world = self.core.world
        lineup = [r.alliance for r in self.world.robots]
        reds = [i for i, a in enumerate(lineup) if a == "red"]
        blues = [i for i, a in enumerate(lineup) if a == "blue"]
        self.ia = reds[0]
        self.ib = blues[0] if blues else None
        self.others = []
        twin_reds = reds[1:]
        if on_stack:
            if len(reds) < 2:
                raise MatchError("--partner stack needs a world with two red robots")
            self.partner_index, twin_reds = reds[1], reds[2:]
        for robots, side, name in ((twin_reds, partner, "partner"), (blues, blue, "opponent")):
            if len(side) not in (1, len(robots)) and robots:
                raise MatchError(
                    f"--{name} names {len(side)} players for {len(robots)} robots: give one "
                    "name for all of them or one per robot"
                )
            for k, i in enumerate(robots):
                spec = side[0] if len(side) == 1 else side[k]
                self.others.append(_Driven(i, spec.make(), spec.spec))
        mate = "full stack" if on_stack else side_label(partner)
        self.labels = (f"full stack + {mate}", side_label(blue))

    def _start_dashboard(self) -> None:
        """The daemon's live dashboard (jetson/dashboard), as `pete-jetson run --dashboard`."""
        from jetson.dashboard.process import live_server
        from jetson.errors import SettingsError
        from jetson.settings import DashboardSettings

        if self.daemon_mode == "process":
            raise MatchError(
                "the dashboard follows the daemon in this process; this fault runs it as its own"
            )
        try:
            settings = DashboardSettings(address=str(self.options.dashboard))
            self.dashboard = live_server(
                self.jetson.daemon, self.jetson.camera, settings,
                title=f"pete-sim match, seed {self.options.seed}",
            ).start()  # fmt: skip
        except (SettingsError, OSError) as exc:
            raise MatchError(f"the dashboard: {exc}") from exc
        self.progress(f"dashboard (read-only) at {self.dashboard.url}")

    def _start_brain(self, boot_id: int, realtime: bool, append_stderr: bool = False) -> None:
        from sim.errors import BrainHostError
        from sim.fullstack.brain_host import BrainHost

        try:
            self.brain = BrainHost.start(
                lockstep=not realtime,
                alliance="red",
                boot_id=boot_id,
                phase="disabled",
                binary=self.options.brain_host,
                stderr_path=self.folder / "brain_host.stderr",
                append_stderr=append_stderr,
                # the Brain converts Commands to wheel speeds with the robot's own track
                track_width_m=self.world.robots[self.ia].config.track_m,
            )
        except BrainHostError as exc:
            raise MatchError(str(exc)) from exc
        if self.brain.period_ms != LOOP_MS:
            raise MatchError(
                f"brain_host's loop period is {self.brain.period_ms} ms, not {LOOP_MS}"
            )

    def _accept_camera(self) -> None:
        """The daemon's camera thread connects to the frame stream (at start, after a restart,
        when the camera comes back)."""
        if self.server is not None and not self.server.wait_for_client(10.0):
            raise MatchError("the daemon's camera thread never connected to the frame stream")

    # --- what faults do (sim.fullstack.faults) --------------------------------------------------

    def restart_daemon(self) -> None:
        """A new daemon process on the same port, as systemd's Restart=always starts one."""
        from sim.errors import DaemonError

        if self.daemon_mode != "process":
            raise MatchError("restarting the daemon needs it as a process (--daemon process)")
        self.cable.new_reader()
        try:
            self.jetson.restart()
        except DaemonError as exc:
            raise MatchError(str(exc)) from exc
        self._jetson_alive = True
        if not self.camera_stopped:
            self._accept_camera()

    def power_off_brain(self) -> None:
        """The Brain goes down (a reboot): brain_host ends; its motors stop."""
        if self.realtime:
            raise MatchError("rebooting the Brain is a lockstep fault")
        if self.brain is not None:
            self.brain_statuses.append(self.brain.close())
            self.brain = None
        self.cable.brain_off()

    def boot_brain(self, boot_id: int) -> None:
        """The Brain comes back with a new boot id: a new brain_host, its clock from zero, on a
        new pty the cable moves to (the USB port the daemon holds stays)."""
        self._start_brain(boot_id, realtime=False, append_stderr=True)
        if self.vexlink is not None:
            self.brain.set_radio("on")
            self.radio = Radio()  # what was on its way to the old Brain went with it
        self.brain_offset_ms = self.t_ms
        self.cable.new_brain(self.brain.pty_path)
        self.hardware.forget_sent()
        self.brain_track.new_brain()

    def stop_camera(self) -> None:
        """The camera stops delivering frames (unplugged): the frame stream closes."""
        if self.server is None or self.camera_stopped:
            return
        self.camera_stopped = True
        self.server.close()
        self.server = None
        self.jetson.drop_pending_frames()

    def start_camera(self) -> None:
        """The camera is back: a new frame stream on the same address, the daemon's camera
        thread reconnects to it."""
        from jetson.perception.sources.stream import FrameStreamServer

        if not self.camera_stopped or self.frames_address is None:
            return
        self.server = FrameStreamServer(self.frames_address)
        self.camera_stopped = False
        if self.jetson.alive:
            self._accept_camera()

    def _teardown(self) -> None:
        if self.partner is not None:
            with contextlib.suppress(Exception):  # ours is stopped whatever the partner's did
                self.partner.close()
        # The stream first: the camera thread is blocked reading it and ends at its close.
        if self.server is not None:
            with contextlib.suppress(Exception):
                self.server.close()
        if self.jetson is not None:
            with contextlib.suppress(Exception):
                self.jetson.shutdown()
            if hasattr(self.jetson, "close"):
                self.jetson.close()
        if self.cable is not None:
            self.cable.close()
        if self.brain is not None:
            self.brain_statuses.append(self.brain.close())
            self.brain = None
        self.brain_status = self.brain_statuses[-1] if self.brain_statuses else None
        if getattr(self, "daemon_log", None) is not None:
            self.daemon_log.close()
        if getattr(self, "core", None) is not None:
            self.core.close()
        if self.dashboard is not None:
            self.dashboard.stop()

    # --- lockstep -------------------------------------------------------------------------------

    def run(self) -> MatchResult:
        wall0 = time.perf_counter()
        with tempfile.TemporaryDirectory(prefix="pete-match-") as tmp:
            try:
                self._setup(Path(tmp), realtime=False)
                self.progress(
                    f"full stack, lockstep: brain_host {self.brain.pty_path}, daemon on "
                    f"{self.cable.port_path}, detector {self.detector}"
                )
                end_ms = PREROLL_MS + self.match_len_ms
                while self.t_ms < end_ms:
                    self._tick()
                    self.t_ms += LOOP_MS
                    if self.match_ms > 0 and self.match_ms % 10_000 == 0:
                        self.progress(
                            f"  {self.match_ms / 1000:5.0f} s  {_caption(self.world, self.labels)}"
                        )
            finally:
                self._teardown()
        return self._result(time.perf_counter() - wall0, "lockstep")

    def _tick(self) -> None:
        from sim.fullstack.brain_host import BrainReport
        from sim.fullstack.hardware import competition_phase

        t = self.t_ms
        started = t >= PREROLL_MS
        self.scenario.before_tick(self)
        w = self.world
        over = started and self.match_ms >= self.match_len_ms
        phase = competition_phase(w.time_s, w.isolation_s, started, over or w.over)
        reading = self.hardware.read(phase)
        # Both Brains' steps are sent before either is read: each brain_host runs its step
        # while the other's batch goes out.
        step = None
        if self.brain is not None:
            lines = self.hardware.sensor_lines(reading) + self.extra_lines
            self.extra_lines = []
            until = t + LOOP_MS - self.brain_offset_ms
            step = send_step(self.brain, self.cable, lines, until, self.radio)
        partner_step = self.partner.send_tick(phase, t) if self.partner is not None else None
        if step is not None:
            report = finish_step(step, self.cable)
            if self.brain_offset_ms:
                report = report.shifted(self.brain_offset_ms)
        else:
            report = BrainReport.off(t)  # rebooting: nothing runs, the motors are off
        self.clock.set(t / 1000.0)
        j = self.jetson
        self._notice_daemon_exit()
        if j.alive:
            service_daemon(j, self.cable)
            seq = j.last_command_seq
            if seq and seq != self._sent_seq:
                self._sent_seq = seq
                self.brain_track.answered_at[seq] = t
            self._notice_daemon_exit()
        if self.brain_track.ledger:
            from protocol.messages import Command

            for msg in self.cable.take_received("down"):
                if isinstance(msg, Command):
                    stop = msg.linear == 0.0 and msg.angular == 0.0
                    self.brain_track.command_delivered(msg.seq, t, stop)
        if self.partner is not None:
            assert partner_step is not None
            self._partner_report = self.partner.finish_tick(partner_step, self.match_ms, started)
            if self.brain is not None:
                self.vexlink.relay(self.radio, self.partner.radio, t)
            else:  # our Brain is down (rebooting): its radio hears nothing meanwhile
                self.vexlink.a_down(t, self.partner.radio.radio_tx())
            note_change(self.partner_links, self.match_ms, report.partner)
        self.brain_track.note(report, started)
        self.scenario.after_tick(self, report)
        if started and not w.over:
            if w.steps == 0:
                self._send_frames(t / 1000.0)  # the cameras are on when the match starts
            self._step_world(report)

    def _notice_daemon_exit(self) -> None:
        """The daemon died (killed, or it exited at a SIGTERM): what it wrote before goes to the
        Brain, and the port has no reader until a new daemon opens it."""
        if self._jetson_alive and not self.jetson.alive:
            self._jetson_alive = False
            if self.cable.plugged:
                self.cable.drain_down()
            self.cable.reader_gone()

    def _step_world(self, report: Any) -> None:
        w = self.world
        commands: list[Any] = [None] * len(w.robots)
        commands[self.ia] = self.hardware.command(report)
        if self.partner is not None:
            commands[self.partner.index] = self.partner.command(self._partner_report)
        for d in self.others:
            commands[d.index] = self._player_command(d)
        w.step(commands)
        t_s = w.time_s
        world_ms = round(t_s * 1000)
        if world_ms % self.options.frame_period_ms == 0:
            self._send_frames((self.t_ms + LOOP_MS) / 1000.0)
        if self.replay.sample_due(t_s):
            self._sample(report)
        if self.replay.gif_due(t_s):
            self._gif_frame()

    def _player_command(self, d: _Driven) -> Any:
        """A robot the twin drives decides at the policy rate, as in the simulator's own
        matches, and keeps its command in between."""
        w = self.world
        k = math.floor(w.time_s * POLICY_HZ + 1e-6)
        if d.command is None or k != d.k:
            d.k = k
            obs = None
            if d.spec is not None:
                from jetson.autonomy.observation import FrameStack

                frame = self.core.frame(d.index)
                if d.stack is None:
                    d.stack = FrameStack(self.core.spec)
                    obs = d.stack.reset(frame)
                else:
                    obs = d.stack.push(frame)
            d.command = d.player.act(self.core, d.index, obs)
        return d.command

    def _send_frames(self, stamp_s: float) -> None:
        """Each camera's frame to its daemon: ours, and the partner's whatever a fault did to
        ours."""
        if stream_ready(self.server):
            self._send_frame(stamp_s)
        if self.partner is not None:
            self.partner.send_frame(self.world, stamp_s)

    def _send_frame(self, stamp_s: float) -> None:
        self.frame_index += 1
        k = self.frame_index
        f = render_camera(self.world, self.ia, self.cam_cfg)
        if not send_frame(self.server, self.jetson, f.rgb, f.depth, self.cam_cfg, stamp_s, k):
            self.replay.event(self.match_ms / 1000, "camera stream: the daemon hung up")
            return
        self.truth[k] = self._truth(f)
        self.camera_rgb[k] = f.rgb
        self.camera_rgb.pop(k - 4, None)

    def _truth(self, f: Any) -> np.ndarray:
        """The rings this frame shows, robot frame: every ring covering at least MIN_RING_PX
        pixels of the render (scaled from 640x480), within the camera's range. A ring cut by
        the image's edge counts when enough of it shows; one hidden behind another does not."""
        ids, counts = np.unique(f.ring_ids[f.ring_ids >= 0], return_counts=True)
        c = self.cam_cfg
        min_px = max(3.0, MIN_RING_PX * c.width * c.height / (640 * 480))
        shown = ids[counts >= min_px].astype(np.int64)
        if len(shown) == 0:
            return np.zeros((0, 2))
        w = self.world
        r = w.robots[self.ia]
        pts = np.column_stack([w.ring_xy[shown], w.ring_z[shown]])
        near = np.linalg.norm(f.pose.to_camera(pts), axis=1) <= c.max_range_m
        return field_to_robot(w.ring_xy[shown[near]], r.xy, r.heading).reshape(-1, 2)

    def _perceived(self) -> Any:
        feed = self.jetson.feed if self.jetson is not None else None
        return feed.latest() if feed is not None else None

    def _sample(self, report: Any) -> None:
        w = self.world
        r = w.robots[self.ia]
        s = w.score()
        opp = w.robots[self.ib] if self.ib is not None else None
        p = self._perceived()
        self.replay.samples.append(
            Sample(
                t_s=round(w.time_s, 3),
                x=round(r.x, 4),
                y=round(r.y, 4),
                heading=round(r.heading, 2),
                rings=r.collected,
                held=r.held,
                score=s[r.alliance].total,
                opponent_rings=opp.collected if opp else 0,
                opponent_score=s["blue"].total,
                v_cmd=round(0.0 if report.stopped else report.linear, 4),
                w_cmd=round(0.0 if report.stopped else report.angular, 4),
                v_actual=round(r.measured_v, 4),
                w_actual=round(r.measured_w, 4),
                source=report.source,
                link=report.link,
                faults="+".join(report.faults) or "none",
                perceived=-1 if p is None else len(p.rings_robot_xy),
                visible=len(sensors.visible_rings(w, self.ia)),
            )
        )

    def _gif_frame(self) -> None:
        from sim.render import top_down

        w = self.world
        top = top_down(w, self.options.gif_size, title=_caption(w, self.labels))
        p = self._perceived()
        rgb = None if p is None else self.camera_rgb.get(p.frame_index)
        uv = None
        if p is not None and rgb is not None:
            uv = project_rings(p.rings_robot_xy, self.cam_cfg, w.field.ring.thickness / 2)
        n = 0 if uv is None else len(uv)
        label = None
        if rgb is not None:
            age = self.clock.now() - p.stamp_s
            label = f"the frame the policy sees ({age * 1000:.0f} ms old): {n} rings (yellow)"
        self.replay.frames.append(compose_frame(top, rgb, uv, label))
        self.replay.interest.append(n)

    # --- realtime -------------------------------------------------------------------------------

    def run_realtime(self) -> MatchResult:
        from sim.fullstack.brain_host import BrainReport
        from sim.fullstack.hardware import competition_phase

        wall0 = time.perf_counter()
        stop = threading.Event()
        threads: list[threading.Thread] = []
        with tempfile.TemporaryDirectory(prefix="pete-match-") as tmp:
            try:
                self.realtime = True
                self._setup(Path(tmp), realtime=True)
                self.progress(
                    f"full stack, realtime: brain_host {self.brain.pty_path}, daemon on "
                    f"{self.cable.port_path}, detector {self.detector}"
                )
                threads.append(self.cable.start_forwarding(stop))
                threads.append(self.jetson.start_thread(stop))
                origin = time.monotonic()
                end_ms = PREROLL_MS + self.match_len_ms
                while self.t_ms < end_ms:
                    # The simulator follows the wall clock: each 10 ms of it, one World step.
                    due = origin + self.t_ms / 1000.0
                    delay = due - time.monotonic()
                    if delay > 0:
                        time.sleep(delay)
                    started = self.t_ms >= PREROLL_MS
                    self.scenario.before_tick(self)
                    w = self.world
                    over = started and self.match_ms >= self.match_len_ms
                    phase = competition_phase(w.time_s, w.isolation_s, started, over or w.over)
                    lines = self.hardware.sensor_lines(self.hardware.read(phase))
                    lines += [*self.extra_lines, "get"]
                    self.extra_lines = []
                    report = BrainReport.parse(self.brain.run_batch(lines)[-1])
                    self.brain_track.note(report, started)
                    self.scenario.after_tick(self, report)
                    if started and not w.over:
                        self._step_world(report)
                    self.t_ms += LOOP_MS
            finally:
                stop.set()
                for th in threads:
                    th.join(2.0)
                self._teardown()
        return self._result(time.perf_counter() - wall0, "realtime")

    # --- the result -----------------------------------------------------------------------------

    def _result(self, wall_s: float, mode: str) -> MatchResult:
        o = self.options
        w = self.world
        score = w.score()
        r = w.robots[self.ia]
        opp = w.robots[self.ib] if self.ib is not None else None
        perception = None
        if o.camera:
            ps = PerceptionScore()
            results = self.jetson.results
            for k, truth in sorted(self.truth.items()):
                got = results.get(k)
                if got is not None:
                    ps.add(got.rings_robot_xy, truth)
                elif k in self.jetson.failed_frames:
                    ps.add(np.zeros((0, 2)), truth)
            perception = ps.as_dict()
            perception["frames_sent"] = len(self.truth)
            perception["frames_failed"] = len(self.jetson.failed_frames)
            perception["detector"] = self.detector
            perception["resolution"] = f"{o.camera_width}x{o.camera_height}"
            perception["rate_hz"] = o.camera_hz
        j = self.jetson
        latencies = j.latencies
        daemon: dict[str, Any] = {
            "mode": self.daemon_mode,
            "counters": j.counters.as_dict(),
            "link_errors": j.link_errors(),
            "handshake": j.link_state,
        }
        if self.daemon_mode == "process":
            daemon["processes"] = len(j.start_wall_s)
            daemon["start_wall_s"] = [round(x, 3) for x in j.start_wall_s]
            daemon["exits"] = [asdict(e) for e in j.exits]
        result = MatchResult(
            stack="full",
            seed=o.seed,
            mode=mode,
            fault=o.fault,
            policy=_display(o.policy),
            opponent=o.opponent,
            sim_s=w.time_s,
            wall_s=wall_s,
            rings=r.collected,
            score=score[r.alliance].total,
            opponent_rings=opp.collected if opp else 0,
            opponent_score=score["blue"].total,
            latency=percentiles_ms(latencies),
            messages=self.cable.as_dict(),
            perception=perception,
            brain={
                **self.brain_track.as_dict(),
                "exit_status": getattr(self, "brain_status", None),
                "pose": self.hardware.pose_track.as_dict(),
            },
            daemon=daemon,
            settings=_settings(o, self.detector),
        )
        if o.whole_game:
            from sim.evaluate import element_breakdown

            result.game = element_breakdown(w)
        if self.partner is not None:
            result.partner = {**self.partner.as_dict(), "vexlink": asdict(self.vexlink.stats)}
            result.partner["our_partner_link"] = [list(x) for x in self.partner_links]
        result.checks = self.scenario.checks(self)
        result.faults = self.scenario.records(self)
        title = f"full stack, seed {o.seed}" + (f", fault {o.fault}" if o.fault else "")
        result.files = self.replay.write(self.folder, latencies, title)
        lat_file = self.folder / "latencies_ms.json"
        lat_file.write_text(json.dumps([round(x * 1e3, 4) for x in latencies]) + "\n")
        result.files["latencies"] = str(lat_file)
        result.files["daemon_log"] = str(self.folder / "daemon.jsonl")
        result.files["brain_stderr"] = str(self.folder / "brain_host.stderr")
        _finish(result, self.folder)
        return result


def _finish(result: MatchResult, folder: Path) -> None:
    result.files["summary"] = str(folder / "summary.txt")
    result.files["summary_json"] = str(folder / "summary.json")
    write_summary(result, folder)


def _display(path: Path) -> str:
    """A path as short as it reads well: relative to the working folder when inside it."""
    try:
        return str(path.resolve().relative_to(Path.cwd().resolve()))
    except ValueError:
        return str(path)


def _settings(o: MatchOptions, detector: str) -> dict[str, Any]:
    return {
        "scenario": o.scenario,
        "seconds": o.seconds,
        "camera": o.camera,
        "ring_counter": o.ring_counter,
        "camera_size": f"{o.camera_width}x{o.camera_height}",
        "camera_hz": o.camera_hz,
        "detector": detector,
        "perception_latency_s": o.perception_latency_s,
        "fault_at_s": o.fault_at_s,
    }


# --- the simulator stack ------------------------------------------------------------------------


class _TimedPlayer:
    """A player whose decisions are timed (the sim stack's "loop latency")."""

    def __init__(self, inner: Any) -> None:
        self.inner = inner
        self.name = getattr(inner, "name", "policy")
        self.times_s: list[float] = []

    def reset(self, core: Any, index: int, rng: np.random.Generator) -> None:
        self.inner.reset(core, index, rng)

    def act(self, core: Any, index: int, obs: np.ndarray) -> Any:
        t0 = time.perf_counter()
        cmd = self.inner.act(core, index, obs)
        self.times_s.append(time.perf_counter() - t0)
        return cmd


class SimStackMatch:
    """The policy straight in the simulator: sim.evaluate's match, recorded like the full one."""

    def __init__(
        self, options: MatchOptions, folder: Path, progress: Callable[[str], None] | None
    ) -> None:
        self.options = options
        self.folder = folder
        self.progress = progress or (lambda _msg: None)
        self.replay = _Replay(options)

    def run(self) -> MatchResult:
        from sim.evaluate import make_cores, play_match
        from sim.render import top_down

        o = self.options
        wall0 = time.perf_counter()
        a, b = _load_players(o)
        labels = (a.label, b.label if b else "-")
        env = _env(o, a.spec, True)
        if o.seconds is not None:
            env = replace(env, max_steps=max(1, round(o.seconds * env.world.control_hz)))
        cores = make_cores(env)
        player = _TimedPlayer(a.make())
        opponent = b.make() if b is not None else None
        cam_cfg = None
        last = {"t": -1.0}
        pace0 = time.monotonic()

        def on_step(core: Any, results: list[Any]) -> None:
            w = core.world
            nonlocal cam_cfg
            if o.realtime:
                delay = pace0 + w.time_s - time.monotonic()
                if delay > 0:
                    time.sleep(delay)
            r = w.robots[0 if w.robots[0].alliance == "red" else 1]
            idx = r.index
            if self.replay.sample_due(w.time_s):
                s = w.score()
                opp = next((x for x in w.robots if x.index != idx), None)
                self.replay.samples.append(
                    Sample(
                        t_s=round(w.time_s, 3),
                        x=round(r.x, 4),
                        y=round(r.y, 4),
                        heading=round(r.heading, 2),
                        rings=r.collected,
                        held=r.held,
                        score=s[r.alliance].total,
                        opponent_rings=opp.collected if opp else 0,
                        opponent_score=s["blue"].total,
                        v_cmd=round(r.v, 4),
                        w_cmd=round(r.w, 4),
                        v_actual=round(r.measured_v, 4),
                        w_actual=round(r.measured_w, 4),
                        source="policy",
                        link="-",
                        faults="-",
                        perceived=len(sensors.visible_rings(w, idx)),
                        visible=len(sensors.visible_rings(w, idx)),
                    )
                )
            if self.replay.gif_due(w.time_s):
                if cam_cfg is None:
                    cam_cfg = r.config.camera.scaled(o.camera_width, o.camera_height)
                cam = render_camera(w, idx, cam_cfg) if o.camera else None
                uv = None
                if cam is not None:
                    uv = project_rings(cam.rings_robot_xy, cam_cfg, w.field.ring.thickness / 2)
                top = top_down(w, o.gif_size, title=_caption(w, labels))
                n = 0 if uv is None else len(uv)
                label = f"robot's camera: {n} rings the policy sees (yellow)" if cam else None
                self.replay.frames.append(
                    compose_frame(top, None if cam is None else cam.rgb, uv, label)
                )
                self.replay.interest.append(n)
            last["t"] = w.time_s

        try:
            record = play_match(cores, player, opponent, o.seed, "red", on_step=on_step)
        finally:
            for core in cores.values():
                core.close()
        wall = time.perf_counter() - wall0
        result = MatchResult(
            stack="sim",
            seed=o.seed,
            mode="realtime" if o.realtime else "lockstep",
            fault=None,
            policy=_display(o.policy),
            opponent=o.opponent,
            sim_s=record.length_s,
            wall_s=wall,
            rings=record.rings[0],
            score=int(record.score[0]),
            opponent_rings=record.rings[1],
            opponent_score=int(record.score[1]),
            latency=percentiles_ms(player.times_s),
            settings=_settings(o, "-"),
        )
        result.files = self.replay.write(self.folder, player.times_s, f"sim stack, seed {o.seed}")
        _finish(result, self.folder)
        return result
