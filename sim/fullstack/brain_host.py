"""brain_host (the Brain firmware's core on fake hardware) driven from Python through its side
channel; brain/README.md ("brain_host") documents the process and every command.

    with BrainHost.start(lockstep=True) as brain:
        brain.set_phase("driver")
        brain.set_gps(0.5, -1.2, 90.0, 0.015)
        report = brain.until(10, rx=bytes_written_to_the_pty)
        report.left_mps, report.right_mps          # what the drive motors were told

`brain.pty_path` is the Brain's USB user port: open it and speak the V5 wire protocol. Several
commands can go in one round trip (`run_batch`): the simulator sets the GPS, the encoders and the
clock with one write and one read per loop step. Every error brain_host reports, and a process
that dies or stops answering, raises BrainHostError with brain_host's own words.
"""

from __future__ import annotations

import contextlib
import math
import os
import select
import subprocess
import time
from collections.abc import Sequence
from dataclasses import dataclass, replace
from pathlib import Path
from typing import IO, Literal

from sim.errors import BrainHostError

ROOT = Path(__file__).resolve().parents[2]
DEFAULT_BINARY = ROOT / "build" / "host" / "bin" / "brain_host"
BINARY_ENV = "PETE_BRAIN_HOST"
REPLY_TIMEOUT_S = 10.0  # brain_host waits up to 5 s for rx= bytes itself; this covers that
PHASES = ("disabled", "autonomous", "driver")
RINGS_UNKNOWN = 255  # the State's rings_held when no ring counter is fitted
CLAMP_UNKNOWN = 255  # the State's goal_clamped when no clamp sensor is fitted
GPS_FAILURES = ("calibrating", "error", "absent")
RADIO_TX = "radio tx"  # the side-channel command that reads what the radio wrote

Phase = Literal["disabled", "autonomous", "driver"]


def find_binary(path: str | Path | None = None) -> Path:
    """The brain_host executable: `path`, else $PETE_BRAIN_HOST, else build/host/bin/brain_host."""
    candidate = Path(path or os.environ.get(BINARY_ENV) or DEFAULT_BINARY)
    if not candidate.is_file() or not os.access(candidate, os.X_OK):
        raise BrainHostError(
            f"brain_host not found at {candidate}: build it with `make build` (cmake -S . -B "
            f"build/host && cmake --build build/host) or set {BINARY_ENV}"
        )
    return candidate


@dataclass(frozen=True)
class BrainReport:
    """brain_host's report after a step (`advance`, `until`, `get`): see brain/README.md."""

    t_ms: int
    last_step_ms: int
    phase: str
    phase_ms: int
    link: str  # waiting | connected | mismatch
    source: str  # none | jetson | driver
    stopped: bool
    left_rpm: float
    right_rpm: float
    left_mps: float  # wheel surface speeds the motors were told: what a simulator applies
    right_mps: float
    linear: float
    angular: float  # rad/s clockwise
    intake: bool
    gps: str
    faults: tuple[str, ...]
    last_command_seq: int
    steps: int
    timeouts: int
    rx: int  # downlink bytes brain_host has read, in total
    tx: int  # uplink bytes it has written, in total
    rings: int = RINGS_UNKNOWN  # the intake's ring counter as the State reports it
    clamp: int = CLAMP_UNKNOWN  # the State's goal_clamped: 1 holding a goal, 0 not, 255 no sensor
    clamp_closed: bool = False  # what the Brain told the goal clamp (its piston)
    lift_up: bool = False  # what the Brain told the lift
    pose: str = "lost"  # the State's pose_fix: gps | odometry | lost
    pose_x: float = 0.0  # the Brain's pose (its filter: GPS + odometry + IMU), field frame
    pose_y: float = 0.0
    pose_heading: float = 0.0
    pose_std: float = 0.0  # m, along the position's worst axis
    period: str = "before"  # the State's match period
    match_ms: int = 0
    alliance: str = "unknown"  # the State's alliance
    partner: str = "absent"  # the VEXlink partner link: absent | connecting | up | lost

    @classmethod
    def parse(cls, fields: dict[str, str]) -> BrainReport:
        try:
            faults = fields["faults"]
            return cls(
                t_ms=int(fields["t"]),
                last_step_ms=int(fields["last_step_ms"]),
                phase=fields["phase"],
                phase_ms=int(fields["phase_ms"]),
                link=fields["link"],
                source=fields["source"],
                stopped=fields["stopped"] == "1",
                left_rpm=float(fields["left_rpm"]),
                right_rpm=float(fields["right_rpm"]),
                left_mps=float(fields["left_mps"]),
                right_mps=float(fields["right_mps"]),
                linear=float(fields["linear"]),
                angular=float(fields["angular"]),
                intake=fields["intake"] == "1",
                gps=fields["gps"],
                faults=() if faults == "none" else tuple(faults.split(",")),
                last_command_seq=int(fields["last_command_seq"]),
                steps=int(fields["steps"]),
                timeouts=int(fields["timeouts"]),
                rx=int(fields["rx"]),
                tx=int(fields["tx"]),
                rings=int(fields.get("rings", RINGS_UNKNOWN)),
                clamp=int(fields.get("clamp", CLAMP_UNKNOWN)),
                clamp_closed=fields.get("clamp_closed", "0") == "1",
                lift_up=fields.get("lift_up", "0") == "1",
                pose=fields.get("pose", "lost"),
                pose_x=float(fields.get("pose_x", 0.0)),
                pose_y=float(fields.get("pose_y", 0.0)),
                pose_heading=float(fields.get("pose_heading", 0.0)),
                pose_std=float(fields.get("pose_std", 0.0)),
                period=fields.get("period", "before"),
                match_ms=int(fields.get("match_ms", 0)),
                alliance=fields.get("alliance", "unknown"),
                partner=fields.get("partner", "absent"),
            )
        except (KeyError, ValueError) as exc:
            raise BrainHostError(
                f"brain_host report is missing or garbles {exc}: {fields}"
            ) from exc

    @property
    def moving(self) -> bool:
        """The motors were told to turn (not stopped, and some wheel speed)."""
        return not self.stopped and (abs(self.left_mps) > 1e-6 or abs(self.right_mps) > 1e-6)

    def shifted(self, offset_ms: int) -> BrainReport:
        """The same report with its times moved by offset_ms (a brain_host started later than
        the match: its clock starts at zero)."""
        return replace(self, t_ms=self.t_ms + offset_ms, last_step_ms=self.last_step_ms + offset_ms)

    @classmethod
    def off(cls, t_ms: int) -> BrainReport:
        """A Brain that is not running (rebooting): nobody drives, the motors are off."""
        return cls(
            t_ms=t_ms, last_step_ms=t_ms, phase="disabled", phase_ms=0, link="off",
            source="none", stopped=True, left_rpm=0.0, right_rpm=0.0, left_mps=0.0,
            right_mps=0.0, linear=0.0, angular=0.0, intake=False, gps="off", faults=(),
            last_command_seq=0, steps=0, timeouts=0, rx=0, tx=0,
        )  # fmt: skip


@dataclass(frozen=True)
class Ready:
    """brain_host's first line: where its pty is and who it is."""

    pty: str
    mode: str
    period_ms: int
    boot_id: int
    fingerprint: int


def _fields(words: Sequence[str]) -> dict[str, str]:
    return dict(w.split("=", 1) for w in words if "=" in w)


def _number(value: float, what: str) -> str:
    if not math.isfinite(value):
        raise ValueError(f"{what} must be a finite number, got {value!r}")
    return repr(float(value))


class BrainHost:
    """One brain_host process. Create it with BrainHost.start(); close() (or `with`) ends it."""

    def __init__(self, proc: subprocess.Popen[bytes], stderr: IO[bytes]) -> None:
        """Use BrainHost.start(); this wraps a process that was started with pipes."""
        self.proc = proc
        self._stderr = stderr
        assert proc.stdin is not None and proc.stdout is not None
        self._in = proc.stdin.fileno()
        self._out = proc.stdout.fileno()
        self._buf = bytearray()
        self.round_trips = 0
        self.ready = Ready("", "", 10, 0, 0)

    @classmethod
    def start(
        cls,
        *,
        lockstep: bool = True,
        alliance: str = "red",
        boot_id: int | None = None,
        phase: Phase | None = None,
        binary: str | Path | None = None,
        stderr_path: Path | None = None,
        extra_args: Sequence[str] = (),
        append_stderr: bool = False,
        track_width_m: float | None = None,
    ) -> BrainHost:
        """Start brain_host with its link on a new pty and its side channel on pipes
        (`append_stderr`: add to stderr_path, as a restarted one does; `track_width_m`: the
        drive's track instead of the Brain's configuration header's, for a robot of another
        size)."""
        exe = find_binary(binary)
        args = [str(exe), "--link", "pty", "--lockstep" if lockstep else "--realtime"]
        args += ["--alliance", alliance]
        if boot_id is not None:
            args += ["--boot-id", f"{boot_id & 0xFFFFFFFF:08X}"]
        if phase is not None:
            if phase not in PHASES:
                raise ValueError(f"phase must be one of {PHASES}, got {phase!r}")
            args += ["--phase", phase]
        if track_width_m is not None:
            args += ["--track-width-m", f"{track_width_m:g}"]
        args += list(extra_args)
        # stderr goes to a file: ASan's report or a crash message must survive the process, and a
        # pipe nobody drains could stall it.
        err: IO[bytes]
        if stderr_path is not None:
            stderr_path.parent.mkdir(parents=True, exist_ok=True)
            err = stderr_path.open("ab" if append_stderr else "wb")
        else:
            err = open(os.devnull, "wb")  # noqa: SIM115 - closed by close()
        proc = subprocess.Popen(
            args, stdin=subprocess.PIPE, stdout=subprocess.PIPE, stderr=err, close_fds=True
        )
        host = cls(proc, err)
        line = ""
        try:
            line = host._readline()
            words = line.split()
            if not words or words[0] != "ready":
                raise BrainHostError(f"brain_host started with {line!r}, expected 'ready ...'")
            f = _fields(words[1:])
            host.ready = Ready(
                f["pty"], f["mode"], int(f["period_ms"]), int(f["boot_id"], 16),
                int(f["fingerprint"], 16),
            )  # fmt: skip
        except (BrainHostError, KeyError, ValueError) as exc:
            host.close()
            if isinstance(exc, BrainHostError):
                raise
            raise BrainHostError(f"brain_host's ready line lacks {exc}: {line!r}") from exc
        return host

    # --- the side channel -----------------------------------------------------------------------

    @property
    def pty_path(self) -> str:
        return self.ready.pty

    @property
    def period_ms(self) -> int:
        return self.ready.period_ms

    def _readline(self, timeout_s: float = REPLY_TIMEOUT_S) -> str:
        deadline = time.monotonic() + timeout_s
        while (nl := self._buf.find(b"\n")) < 0:
            left = deadline - time.monotonic()
            if left <= 0:
                raise BrainHostError(f"brain_host did not answer within {timeout_s:g} s")
            ready, _, _ = select.select([self._out], [], [], left)
            if not ready:
                continue
            chunk = os.read(self._out, 65536)
            if not chunk:
                try:  # its stdout closed as it ends: wait for the status it ends with
                    code: int | None = self.proc.wait(timeout=1.0)
                except subprocess.TimeoutExpired:
                    code = None
                raise BrainHostError(
                    f"brain_host exited (status {code}) instead of answering" + self._stderr_hint()
                )
            self._buf += chunk
        line = bytes(self._buf[:nl]).decode("utf-8", "replace")
        del self._buf[: nl + 1]
        return line

    def _stderr_hint(self) -> str:
        name = getattr(self._stderr, "name", None)
        if isinstance(name, str) and name != os.devnull:
            return f"; its stderr is in {name}"
        return ""

    def run_batch(self, lines: Sequence[str]) -> list[dict[str, str]]:
        """Send several commands in one write and read their replies; the first error raises
        (brain_host changes nothing on an error, but later commands in the batch did run)."""
        self.send_batch(lines)
        return self.read_batch(lines)

    def send_batch(self, lines: Sequence[str]) -> None:
        """The first half of run_batch: the commands written, their replies not yet read (two
        Brains stepped side by side: both sent, then both read)."""
        if not lines:
            return
        for line in lines:
            if "\n" in line:
                raise ValueError(f"a side-channel command is one line: {line!r}")
        data = ("\n".join(lines) + "\n").encode()
        try:
            view = memoryview(data)
            while view:
                n = os.write(self._in, view)
                view = view[n:]
        except (BrokenPipeError, OSError) as exc:
            raise BrainHostError(
                f"brain_host is gone (status {self.proc.poll()}): {exc}" + self._stderr_hint()
            ) from exc
        self.round_trips += 1

    def read_batch(self, lines: Sequence[str]) -> list[dict[str, str]]:
        """The second half of run_batch: the replies to `lines`, sent by send_batch."""
        replies = [self._readline() for _ in lines]
        out = []
        for line, reply in zip(lines, replies, strict=True):
            words = reply.split()
            if not words or words[0] != "ok":
                raise BrainHostError(f"brain_host refused {line!r}: {reply}")
            out.append(_fields(words[1:]))
        return out

    def command(self, line: str) -> dict[str, str]:
        return self.run_batch([line])[0]

    # --- commands -------------------------------------------------------------------------------

    @staticmethod
    def phase_line(phase: str) -> str:
        if phase not in PHASES:
            raise ValueError(f"phase must be one of {PHASES}, got {phase!r}")
        return f"phase {phase}"

    @staticmethod
    def gps_line(x: float, y: float, heading_deg: float, error_m: float = 0.01) -> str:
        return (
            f"gps {_number(x, 'gps x')} {_number(y, 'gps y')} "
            f"{_number(heading_deg, 'gps heading')} {_number(error_m, 'gps error')}"
        )

    @staticmethod
    def gps_failure_line(status: str) -> str:
        if status not in GPS_FAILURES:
            raise ValueError(f"a GPS failure is one of {GPS_FAILURES}, got {status!r}")
        return f"gps {status}"

    @staticmethod
    def measured_line(left_mps: float, right_mps: float) -> str:
        return f"measured {_number(left_mps, 'left speed')} {_number(right_mps, 'right speed')}"

    @staticmethod
    def imu_line(rotation_deg: float | None) -> str:
        """The inertial sensor's cumulative clockwise rotation in degrees, or None for no
        reading (none fitted, or calibrating)."""
        if rotation_deg is None:
            return "imu off"
        return f"imu {_number(rotation_deg, 'imu rotation')}"

    @staticmethod
    def rings_line(count: int | None) -> str:
        """The intake's ring counter: `count` rings held, or None for no counter fitted."""
        if count is None:
            return "rings unknown"
        if not 0 <= int(count) <= 254 or int(count) != count:
            raise ValueError(f"the ring counter holds 0..254 rings, got {count!r}")
        return f"rings {int(count)}"

    @staticmethod
    def clamp_line(goal_at_back: bool | None) -> str:
        """The goal clamp's sensor: a goal is (True) or is not (False) at the robot's back, or
        None for no sensor fitted (the State then says goal_clamped = 255)."""
        if goal_at_back is None:
            return "clamp unknown"
        return f"clamp {int(bool(goal_at_back))}"

    @staticmethod
    def sticks_line(
        forward: float, turn: float, intake: bool = False, clamp: bool = False, lift: bool = False
    ) -> str:
        for v, name in ((forward, "forward"), (turn, "turn")):
            if not (math.isfinite(v) and -1.0 <= v <= 1.0):
                raise ValueError(f"stick {name} must be in [-1, 1], got {v!r}")
        return (
            f"sticks {forward!r} {turn!r}"
            + (" intake" if intake else "")
            + (" clamp" if clamp else "")
            + (" lift" if lift else "")
        )

    @staticmethod
    def step_line(verb: str, ms: int, rx: int | None) -> str:
        if verb not in ("advance", "until"):
            raise ValueError(f"verb must be advance or until, got {verb!r}")
        if ms < 0 or (rx is not None and rx < 0):
            raise ValueError(f"{verb}: times and byte counts are never negative ({ms}, {rx})")
        return f"{verb} {int(ms)}" + ("" if rx is None else f" rx={int(rx)}")

    def set_phase(self, phase: Phase) -> None:
        self.command(self.phase_line(phase))

    def set_gps(self, x: float, y: float, heading_deg: float, error_m: float = 0.01) -> None:
        self.command(self.gps_line(x, y, heading_deg, error_m))

    def set_gps_failure(self, status: str) -> None:
        self.command(self.gps_failure_line(status))

    def set_measured(self, left_mps: float, right_mps: float) -> None:
        self.command(self.measured_line(left_mps, right_mps))

    def measured_auto(self) -> None:
        self.command("measured auto")

    def set_imu(self, rotation_deg: float | None) -> None:
        self.command(self.imu_line(rotation_deg))

    def set_rings(self, count: int | None) -> None:
        self.command(self.rings_line(count))

    def set_clamp(self, goal_at_back: bool | None) -> None:
        self.command(self.clamp_line(goal_at_back))

    def set_sticks(
        self,
        forward: float,
        turn: float,
        intake: bool = False,
        clamp: bool = False,
        lift: bool = False,
    ) -> None:
        self.command(self.sticks_line(forward, turn, intake, clamp, lift))

    def sticks_off(self) -> None:
        self.command("sticks off")

    def set_motor_fault(self, fault: bool) -> None:
        self.command(f"motor_fault {int(bool(fault))}")

    def set_radio(self, state: str) -> None:
        """The VEXlink radio: "off" (none fitted), "on" (linked to the partner's) or "unlinked"
        (fitted, but the partner's radio is out of reach)."""
        if state not in ("off", "on", "unlinked"):
            raise ValueError(f"radio must be off, on or unlinked, got {state!r}")
        self.command(f"radio {state}")

    def radio_rx(self, data: bytes) -> bool:
        """Hand bytes from the partner's radio to this Brain's; False when its radio is not
        linked (the bytes are lost, as on the field)."""
        if not data:
            return True
        return self.command(self.radio_rx_line(data)).get("delivered") == "1"

    def radio_tx(self) -> bytes:
        """The bytes this Brain has written to its radio since the last call."""
        return self.radio_tx_bytes(self.command(RADIO_TX))

    @staticmethod
    def radio_rx_line(data: bytes) -> str:
        """The command that hands `data` to the radio (one line in a batch)."""
        return f"radio rx {data.hex()}"

    @staticmethod
    def radio_tx_bytes(reply: dict[str, str]) -> bytes:
        """The radio's bytes from the reply to RADIO_TX."""
        hexed = reply.get("bytes", "-")
        return b"" if hexed == "-" else bytes.fromhex(hexed)

    def advance(self, ms: int, rx: int | None = None) -> BrainReport:
        """Lockstep: run the loop for `ms` of simulated time, once brain_host has read `rx`
        downlink bytes in total (pass everything written to the pty: deterministic)."""
        return BrainReport.parse(self.command(self.step_line("advance", ms, rx)))

    def until(self, t_ms: int, rx: int | None = None) -> BrainReport:
        """Lockstep: run the loop up to the absolute time `t_ms`."""
        return BrainReport.parse(self.command(self.step_line("until", t_ms, rx)))

    def get(self) -> BrainReport:
        return BrainReport.parse(self.command("get"))

    # --- lifetime -------------------------------------------------------------------------------

    @property
    def alive(self) -> bool:
        return self.proc.poll() is None

    def close(self, timeout_s: float = 5.0) -> int | None:
        """Ask brain_host to quit, wait for it (kill it if it hangs); returns its exit status."""
        if self.proc.poll() is None:
            with contextlib.suppress(OSError, BrainHostError):
                os.write(self._in, b"quit\n")
            try:
                self.proc.wait(timeout=timeout_s)
            except subprocess.TimeoutExpired:
                self.proc.kill()
                self.proc.wait()
        for stream in (self.proc.stdin, self.proc.stdout):
            if stream is not None:
                with contextlib.suppress(OSError):
                    stream.close()
        with contextlib.suppress(OSError):
            self._stderr.close()
        return self.proc.returncode

    def __enter__(self) -> BrainHost:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
