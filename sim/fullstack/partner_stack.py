"""The alliance partner on the full stack (`pete-sim match --world ... --partner stack`).

The red alliance's second robot runs what ours runs: its own Brain (a brain_host), USB cable,
daemon (in this process, the scripted alliance as its role) and camera, stepped in lockstep
beside ours by sim.fullstack.runner.FullStackMatch. The two Brains' radios are linked by
sim.fullstack.vexlink.Vexlink, so each daemon hears the other's partner reports as it would on
the field. Faults act on our robot; `vexlink-lost` cuts the radio between the two.

The lockstep pieces both robots' stacks run are here, one each: a Brain's step (`send_step`,
then `finish_step`: both Brains' steps are sent before either is read), a daemon's turn
(`service_daemon`), a camera frame to its daemon (`stream_ready`, `send_frame`), a link's
changes over the match (`note_change`).
"""

from __future__ import annotations

import contextlib
from dataclasses import dataclass, field
from pathlib import Path
from typing import IO, Any

import numpy as np

from sim.camera import render_view
from sim.errors import BrainHostError, DaemonError, MatchError
from sim.fullstack.brain_host import RADIO_TX, BrainHost, BrainReport
from sim.fullstack.cable import Cable
from sim.fullstack.daemon import DaemonHost, DaemonOptions
from sim.fullstack.hardware import RobotHardware
from sim.fullstack.options import LOOP_MS
from sim.fullstack.report import percentiles_ms
from sim.fullstack.vexlink import Radio

# Boot ids of the partner's Brain and Jetson (ours: 0x5EED0000 and 0x7E750000, plus the seed's
# low 16 bits), so the two robots' logs never share one.
PARTNER_BRAIN_BOOT = 0x5EEE0000
PARTNER_JETSON_BOOT = 0x7E760000


@dataclass
class BrainStep:
    """A Brain's step sent (send_step) and not yet read (finish_step): two Brains step side by
    side, each brain_host running while the other's batch is written."""

    brain: BrainHost
    lines: list[str]
    radio: Radio | None


def send_step(
    brain: BrainHost, cable: Cable, lines: list[str], until_ms: int, radio: Radio | None = None
) -> BrainStep:
    """One 10 ms step of a Brain, sent: the radio's bytes, the sensors' and any extra
    side-channel lines, the step to until_ms (on the Brain's own clock) once the Jetson's bytes
    sent so far have arrived, then what the radio wrote."""
    batch = [brain.radio_rx_line(radio.incoming)] if radio is not None and radio.incoming else []
    batch += [*lines, brain.step_line("until", until_ms, cable.delivered_down)]
    if radio is not None:
        radio.incoming = b""
        batch.append(RADIO_TX)
    brain.send_batch(batch)
    return BrainStep(brain, batch, radio)


def finish_step(step: BrainStep, cable: Cable) -> BrainReport:
    """The step's replies: its report; what the Brain wrote goes up the cable, what its radio
    wrote to step.radio."""
    replies = step.brain.read_batch(step.lines)
    if step.radio is not None:
        step.radio.outgoing = BrainHost.radio_tx_bytes(replies.pop())
    report = BrainReport.parse(replies[-1])
    cable.pump_up(report.tx)
    return report


def note_change(changes: list[tuple[int, str]], t_ms: int, state: str) -> None:
    """Keep a state's history as its changes: (t_ms, state) when it differs from the last."""
    if not changes or changes[-1][1] != state:
        changes.append((t_ms, state))


def stream_ready(server: Any) -> bool:
    """Whether a frame stream has its daemon's camera thread. One that gave up on a quiet stream
    (its read timeout is wall time: a loaded machine can take longer than that over the preroll,
    when no frames are sent) and connected again is taken back here."""
    if server is None:
        return False
    server.accept_pending()
    return bool(server.connected)


def send_frame(
    server: Any, jetson: Any, rgb: Any, depth: Any, cam: Any, stamp_s: float, k: int
) -> bool:
    """Camera frame k (sim.camera's rgb and depth, rendered now) to its daemon, told when it was
    taken; False when the daemon hung up."""
    from jetson.perception.frame import Frame

    frame = Frame(np.ascontiguousarray(rgb[:, :, ::-1]), depth, cam.intrinsics, stamp_s, k)
    if not server.send(frame):
        return False
    jetson.frame_sent(k, stamp_s)
    return True


def service_daemon(jetson: Any, cable: Cable) -> None:
    """One lockstep turn of a daemon: it reads what the cable delivered and answers; its bytes go
    down the cable."""
    jetson.service(cable.delivered_up_on_connection)
    if jetson.alive and jetson.connected and cable.plugged:
        cable.pump_down(jetson.tx_on_connection)


@dataclass
class PartnerStack:
    """One more robot of our alliance on the full stack (lockstep)."""

    index: int  # its robot in the World
    hardware: RobotHardware
    brain: BrainHost
    cable: Cable
    jetson: DaemonHost
    log: IO[str]
    server: Any = None  # its camera's frame stream
    cam_cfg: Any = None
    frame_index: int = 0
    steps: int = 0  # match steps since the start
    jetson_steps: int = 0  # of them, steps the Jetson's Commands drove its motors
    links: list[tuple[int, str]] = field(default_factory=list)  # (match ms, state) changes
    statuses: list[int | None] = field(default_factory=list)
    last_report: BrainReport | None = None
    radio: Radio = field(default_factory=Radio)

    @classmethod
    def start(
        cls,
        world: Any,
        index: int,
        options: Any,
        folder: Path,
        tmp: Path,
        clock: Any,
        daemon: DaemonOptions,
    ) -> PartnerStack:
        """Its Brain, cable, daemon and camera, started. `daemon`: our robot's daemon options,
        which it shares but for its role, boot id, camera file, recordings and fingerprint (a
        fault of ours, schema-mismatch, is not the partner's). What started is stopped again
        when a later part fails."""
        from dataclasses import replace

        from jetson.perception.camera import CameraConfig as JetsonCamera
        from jetson.perception.sources.stream import FrameStreamServer
        from protocol import messages
        from sim.world import sensors

        robot = world.robots[index]
        seed = options.seed
        hardware = RobotHardware(
            world,
            index,
            np.random.default_rng((seed, 78)),
            options.ring_counter,
            gps_occlusion=sensors.GpsOcclusion() if options.gps_occlusion else None,
        )
        with contextlib.ExitStack() as undo:
            try:
                brain = BrainHost.start(
                    lockstep=True,
                    alliance=robot.alliance,
                    boot_id=PARTNER_BRAIN_BOOT + (seed & 0xFFFF),
                    phase="disabled",
                    binary=options.brain_host,
                    stderr_path=folder / "partner_brain_host.stderr",
                    track_width_m=robot.config.track_m,
                )
            except BrainHostError as exc:
                raise MatchError(f"the partner's Brain: {exc}") from exc
            undo.callback(brain.close)
            if brain.period_ms != LOOP_MS:
                raise MatchError(
                    f"the partner's brain_host loop period is {brain.period_ms} ms, not {LOOP_MS}"
                )
            cable = Cable(brain.pty_path, tmp / "partner-usb", seed=seed + 1)
            undo.callback(cable.close)
            server = cam_cfg = address = camera_file = None
            if daemon.camera:
                address = f"unix:{tmp / 'partner-frames.sock'}"
                server = FrameStreamServer(address)
                undo.callback(server.close)
                cam_cfg = robot.config.camera.scaled(options.camera_width, options.camera_height)
                camera_file = folder / "partner_camera.json"
                JetsonCamera(cam_cfg.intrinsics, cam_cfg.mount).save(camera_file)
            opts = replace(
                daemon,
                role=robot.config.name,
                boot_id=PARTNER_JETSON_BOOT + (seed & 0xFFFF),
                camera_config=camera_file,
                record_dir=None,
                fingerprint=messages.FINGERPRINT,
            )
            log = undo.enter_context((folder / "partner_daemon.jsonl").open("w"))
            try:
                jetson = DaemonHost(opts, clock, cable.port_path, address, log)
            except DaemonError as exc:
                raise MatchError(f"the partner's daemon: {exc}") from exc
            undo.callback(jetson.shutdown)
            jetson.start()
            if server is not None and not server.wait_for_client(10.0):
                raise MatchError("the partner's camera thread never connected to its frame stream")
            undo.pop_all()  # all started: close() stops them
        return cls(index, hardware, brain, cable, jetson, log, server, cam_cfg)

    def send_tick(self, phase: str, t_ms: int) -> BrainStep:
        """Its Brain's step to t_ms + one loop, sent (finish_tick reads it)."""
        lines = self.hardware.sensor_lines(self.hardware.read(phase))
        return send_step(self.brain, self.cable, lines, t_ms + LOOP_MS, self.radio)

    def finish_tick(self, step: BrainStep, match_ms: int, started: bool) -> BrainReport:
        """Its Brain's step read, then its daemon's turn (the clock already set)."""
        report = finish_step(step, self.cable)
        service_daemon(self.jetson, self.cable)
        if started:
            self.steps += 1
            self.jetson_steps += report.source == "jetson"
        note_change(self.links, match_ms, report.partner)
        self.last_report = report
        return report

    def command(self, report: BrainReport) -> Any:
        return self.hardware.command(report)

    def send_frame(self, world: Any, stamp_s: float) -> None:
        """A frame of its camera to its daemon."""
        if stream_ready(self.server):
            self.frame_index += 1
            k = self.frame_index
            rgb, depth = render_view(world, self.index, self.cam_cfg)  # nobody scores it
            send_frame(self.server, self.jetson, rgb, depth, self.cam_cfg, stamp_s, k)

    def close(self) -> None:
        """Stop everything, each part whatever the others did."""
        if self.server is not None:
            with contextlib.suppress(Exception):
                self.server.close()
            self.server = None
        with contextlib.suppress(Exception):
            self.jetson.shutdown()
        with contextlib.suppress(Exception):
            self.cable.close()
        try:
            self.statuses.append(self.brain.close())
        finally:
            self.log.close()

    def as_dict(self) -> dict[str, Any]:
        """What the match summary shows of it."""
        j = self.jetson
        return {
            "robot": self.hardware.robot.name,
            "jetson_share": round(self.jetson_steps / self.steps, 4) if self.steps else None,
            "latency": percentiles_ms(j.latencies),
            "counters": j.counters.as_dict(),
            "messages": self.cable.as_dict(),
            "partner_link": [[t, s] for t, s in self.links],
            "frames_sent": self.frame_index,
            "exit_status": self.statuses[-1] if self.statuses else None,
        }
