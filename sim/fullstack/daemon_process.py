"""The Jetson daemon as its own process, in lockstep: so that it can get real signals.

`pete-sim match --daemon process` (and the faults that need it: jetson-sigterm, jetson-sigkill,
disk-full) runs the daemon in a child process, `python -m sim.fullstack.daemon_process`, instead
of in the simulator's own. The child hosts the same DaemonHost (sim/fullstack/daemon.py: the
daemon `jetson.service.build` builds, its camera thread, the gated feed) on a ManualClock, and the
simulator turns it over a control socket, one request per 10 ms loop step, exactly as it turns
the in-process one. What the process adds:

- signals: the child runs `pete-jetson run`'s own loop (`Service.run()` -> `Daemon.run()`, with
  the handlers `Service.install_signal_handlers` sets), in which only one turn (`Daemon.service`)
  is replaced: it serves the simulator's next request instead of waiting on the port by the wall
  clock. The simulator sends real SIGTERM and SIGKILL with os.kill; a SIGTERM lands at a random
  moment of a turn (the daemon decoding, deciding, logging...), and the daemon leaves its loop
  and exits exactly as `pete-jetson run` does (the stop Command when the Brain is connected, the
  port and the recording closed, the camera thread stopped). The simulator times the exit on the
  wall clock and, like systemd (TimeoutStopSec=5 in jetson/deploy/pete-jetson.service), kills a
  daemon still running 5 s later. A SIGKILL leaves the OS to close what the process held.
  `restart()` starts a new process, as Restart=always does.
- a full disk: the child's file-size limit (RLIMIT_FSIZE) drops to 0, so every write to a file
  fails in the kernel (EFBIG where a full disk says ENOSPC) until the disk is "freed". The log
  goes to a pipe (as to the journal), not a file, so it is not affected.

Each turn's answer carries what the match reads of the daemon (the bytes it wrote on this
connection, its counters, the latencies and camera results since the last turn: each result's
rings and the goals the daemon's goal detector saw), so nothing is lost when a process is
killed. The child's JSON-lines log is its stdout; a thread here copies it into the run folder's
daemon.jsonl.

The simulator's clock is frozen while a process starts (imports, the ONNX sessions, the camera
thread): a restart costs RestartSec of simulated time, not the start-up's wall time, which
`start_wall_s` records.
"""

from __future__ import annotations

import contextlib
import json
import os
import select
import signal
import socket
import subprocess
import sys
import threading
import time
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any, TextIO

import numpy as np

from jetson.camera_feed import Perceived
from jetson.clock import Clock
from jetson.stats import Counters
from sim.errors import DaemonError
from sim.fullstack.daemon import DaemonOptions

STOP_TIMEOUT_S = 5.0  # systemd's TimeoutStopSec in jetson/deploy/pete-jetson.service
START_TIMEOUT_S = 120.0
REPLY_TIMEOUT_S = 30.0  # a turn waits up to 10 s for a camera result inside the child
_COUNTER_KEYS = tuple(Counters().as_dict())


@dataclass
class Exit:
    """How one daemon process ended."""

    how: str  # sigterm | sigkill | quit | crashed
    pid: int
    sim_s: float  # the simulator's clock when it was signalled (or found dead)
    exit_s: float | None = None  # wall time from the signal to the process reaped
    returncode: int | None = None
    forced: bool = False  # still running after STOP_TIMEOUT_S: killed, as systemd would
    answered_turn: bool = False  # it finished the turn the signal landed in
    said_bye: bool = False  # it reported its exit (ran pete-jetson run's shutdown)
    stop_sent: bool = False  # its shutdown wrote a stop Command (the Brain connected)


@dataclass
class _Generation:
    """One process's figures, as its last answer gave them."""

    counters: dict[str, int] = field(default_factory=lambda: dict.fromkeys(_COUNTER_KEYS, 0))
    link_errors: dict[str, int] = field(default_factory=dict)


class _Feed:
    """The child's feed as the match reads it (the GIF and the timeline's perceived rings)."""

    def __init__(self, owner: DaemonProcess) -> None:
        self._owner = owner

    def latest(self) -> Perceived | None:
        return self._owner.latest_perceived()


class DaemonProcess:
    """The daemon in a child process, turned in lockstep; signalled and restarted like a unit."""

    def __init__(
        self,
        options: DaemonOptions,
        clock: Clock,
        port_path: Path,
        frames_address: str | None,
        log_stream: TextIO,
        stderr_path: Path,
        realtime: bool = False,
    ) -> None:
        if realtime:
            raise DaemonError("the daemon as a process runs in lockstep only (drop --realtime)")
        self.options = options
        self.clock = clock
        self.port_path = Path(port_path)
        self.frames_address = frames_address
        self.stderr_path = stderr_path
        self._log_stream = log_stream
        self._log_lock = threading.Lock()
        self.results: dict[int, Perceived] = {}
        self.failed_frames: set[int] = set()
        self.feed = _Feed(self) if options.camera else None
        self.exits: list[Exit] = []
        self.start_wall_s: list[float] = []
        self.generation = 0
        self._latencies: list[float] = []
        self._done: list[_Generation] = []
        self._now = _Generation()
        self._proc: subprocess.Popen[bytes] | None = None
        self._ctl: socket.socket | None = None
        self._buf = b""
        self._log_thread: threading.Thread | None = None
        self._sigterm_delay_s: float | None = None
        self._disk_full = False
        self.alive = False
        self.tx_on_connection = 0
        self.connected = False
        self.last_command_seq = 0
        self.link_state = "waiting for port"
        self.pid: int | None = None
        self._spawn()

    # --- the process ------------------------------------------------------------------------------

    def _spawn(self) -> None:
        self.generation += 1
        options = asdict(self.options)
        options["boot_id"] = (self.options.boot_id + (self.generation - 1) * 0x100) & 0xFFFFFFFF
        spec = {
            "options": {k: (str(v) if isinstance(v, Path) else v) for k, v in options.items()},
            "port": str(self.port_path),
            "frames": self.frames_address,
            "t": self.clock.now(),
            "disk_full": self._disk_full,
        }
        ours, theirs = socket.socketpair()
        spec["ctl_fd"] = theirs.fileno()
        self.stderr_path.parent.mkdir(parents=True, exist_ok=True)
        t0 = time.perf_counter()
        with self.stderr_path.open("ab") as err:
            proc = subprocess.Popen(
                [sys.executable, "-m", "sim.fullstack.daemon_process", json.dumps(spec)],
                stdin=subprocess.DEVNULL,
                stdout=subprocess.PIPE,
                stderr=err,
                pass_fds=(theirs.fileno(),),
                close_fds=True,
            )
        theirs.close()
        self._proc, self._ctl, self._buf = proc, ours, b""
        self.pid = proc.pid
        assert proc.stdout is not None
        self._log_thread = threading.Thread(
            target=self._copy_log, args=(proc.stdout,), name="pete-daemon-log", daemon=True
        )
        self._log_thread.start()
        ready = self._reply(START_TIMEOUT_S)
        if ready is None or not ready.get("ready"):
            self._reap(1.0)
            raise DaemonError(
                f"the daemon process did not start ({ready or 'it exited'}); its stderr is in "
                f"{self.stderr_path}"
            )
        self.start_wall_s.append(time.perf_counter() - t0)
        self._now = _Generation()
        self.alive = True
        self.connected = False
        self.tx_on_connection = 0
        self.last_command_seq = 0

    def _copy_log(self, stream: Any) -> None:
        for line in iter(stream.readline, b""):
            text = line.decode("utf-8", "replace")
            with self._log_lock, contextlib.suppress(OSError, ValueError):
                self._log_stream.write(text if text.endswith("\n") else text + "\n")
        with self._log_lock, contextlib.suppress(OSError, ValueError):
            self._log_stream.flush()

    def _send(self, request: dict[str, Any]) -> None:
        assert self._ctl is not None
        with contextlib.suppress(OSError):  # it died: the answer's end of file says so
            self._ctl.sendall((json.dumps(request) + "\n").encode())

    def _reply(self, timeout_s: float = REPLY_TIMEOUT_S) -> dict[str, Any] | None:
        """The child's next answer; None at its end of file (it exited)."""
        assert self._ctl is not None
        deadline = time.monotonic() + timeout_s
        while b"\n" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0:
                raise DaemonError(
                    f"the daemon process {self.pid} did not answer within {timeout_s:g} s"
                )
            ready, _, _ = select.select([self._ctl], [], [], left)
            if not ready:
                continue
            try:
                chunk = self._ctl.recv(1 << 20)
            except OSError:
                chunk = b""
            if not chunk:
                return None
            self._buf += chunk
        line, self._buf = self._buf.split(b"\n", 1)
        reply = json.loads(line)
        if "error" in reply:
            raise DaemonError(f"the daemon process failed: {reply['error']}")
        return reply

    def _reap(self, timeout_s: float) -> tuple[int | None, bool]:
        """Wait for the process to end; kill it after timeout_s. (returncode, forced)."""
        assert self._proc is not None
        forced = False
        try:
            code = self._proc.wait(timeout=timeout_s)
        except subprocess.TimeoutExpired:
            forced = True
            self._proc.kill()
            code = self._proc.wait()
        if self._ctl is not None:
            self._ctl.close()
            self._ctl = None
        if self._log_thread is not None:
            self._log_thread.join(5.0)
        if self._proc.stdout is not None:
            with contextlib.suppress(OSError):
                self._proc.stdout.close()
        return code, forced

    def _gone(self, ex: Exit) -> None:
        self.exits.append(ex)
        self._done.append(self._now)
        self._now = _Generation()
        self.alive = False
        self.connected = False
        self.tx_on_connection = 0
        self.link_state = "dead"

    # --- turning it -------------------------------------------------------------------------------

    def start(self) -> None:
        """Started when built (the child starts its camera thread itself)."""

    def start_thread(self, stop: threading.Event) -> threading.Thread:
        raise DaemonError("the daemon as a process runs in lockstep only")

    def service(self, rx_total: int, timeout_s: float = 5.0) -> None:
        """One turn at the clock's time (see DaemonHost.service); a SIGTERM armed by `sigterm`
        lands during it."""
        if not self.alive:
            return
        self._send({"op": "turn", "t": self.clock.now(), "rx": rx_total, "timeout": timeout_s})
        delay = self._sigterm_delay_s
        if delay is None:
            reply = self._reply()
            if reply is None:
                self._crashed()
                return
            self._take(reply)
            return
        self._sigterm_delay_s = None
        _spin(delay)
        self._terminate()

    def _take(self, r: dict[str, Any]) -> None:
        self.tx_on_connection = int(r["tx"])
        self.connected = bool(r["conn"])
        self.last_command_seq = int(r["seq"])
        self.link_state = str(r["state"])
        self._now.counters = r["counters"]
        self._now.link_errors = r["link_errors"]
        self._latencies.extend(r.get("lat", ()))
        for row in r.get("res", ()):
            index, perceived = result_of_row(row)
            self.results[index] = perceived
        self.failed_frames.update(int(i) for i in r.get("fail", ()))

    def _crashed(self) -> None:
        assert self._proc is not None
        pid = self._proc.pid
        code, _ = self._reap(1.0)
        self._gone(Exit("crashed", pid, self.clock.now(), returncode=code))

    # --- faults -----------------------------------------------------------------------------------

    def sigterm(self, delay_s: float = 0.0) -> None:
        """Arm a SIGTERM: it is sent `delay_s` (wall) after the next turn's request, so it lands
        while the daemon works on that turn."""
        if self.alive:
            self._sigterm_delay_s = max(0.0, delay_s)

    def _terminate(self) -> None:
        assert self._proc is not None
        pid = self._proc.pid
        ex = Exit("sigterm", pid, self.clock.now())
        t0 = time.perf_counter()
        os.kill(pid, signal.SIGTERM)
        # Its answers, until its end of file: the turn's, then its goodbye.
        deadline = time.monotonic() + STOP_TIMEOUT_S
        while True:
            try:
                r = self._reply(max(0.01, deadline - time.monotonic()))
            except DaemonError:
                break  # silent past the stop timeout: killed below
            if r is None:
                break
            if "bye" in r:
                ex.said_bye = True
                ex.stop_sent = bool(r.get("stop_sent"))
                self._now.counters = r["counters"]
                self._now.link_errors = r["link_errors"]
            else:
                ex.answered_turn = True
                self._take(r)
        code, forced = self._reap(max(0.0, deadline - time.monotonic()))
        ex.exit_s = time.perf_counter() - t0
        ex.returncode, ex.forced = code, forced
        self._gone(ex)

    def kill(self) -> None:
        """SIGKILL: dead at once; the OS closes its port and its camera connection."""
        if not self.alive or self._proc is None:
            return
        pid = self._proc.pid
        ex = Exit("sigkill", pid, self.clock.now())
        t0 = time.perf_counter()
        os.kill(pid, signal.SIGKILL)
        ex.returncode, _ = self._reap(STOP_TIMEOUT_S)
        ex.exit_s = time.perf_counter() - t0
        self._gone(ex)

    def restart(self) -> None:
        """A new process (a new Jetson boot id), as systemd's Restart=always starts one."""
        if self.alive:
            raise DaemonError("the daemon process is still running")
        self._spawn()

    def set_disk_full(self, full: bool) -> None:
        """Every file write of the daemon fails (full) or works again; kept across restarts."""
        self._disk_full = full
        if self.alive:
            self._send({"op": "disk", "full": full})
            if self._reply() is None:
                self._crashed()

    # --- the camera -------------------------------------------------------------------------------

    def frame_sent(self, index: int, frame_time_s: float) -> None:
        if self.alive and self.options.camera:
            self._send({"op": "frame", "index": index, "t": frame_time_s})
            if self._reply() is None:
                self._crashed()

    def drop_pending_frames(self) -> None:
        if self.alive:
            self._send({"op": "drop"})
            if self._reply() is None:
                self._crashed()

    def latest_perceived(self) -> Perceived | None:
        if not self.alive:
            return None
        self._send({"op": "latest"})
        r = self._reply()
        if r is None:
            self._crashed()
            return None
        index = r.get("index")
        return None if index is None else self.results.get(int(index))

    # --- what the match reads ---------------------------------------------------------------------

    @property
    def counters(self) -> Counters:
        """Over every process so far."""
        total = dict.fromkeys(_COUNTER_KEYS, 0)
        for g in (*self._done, self._now):
            for k in _COUNTER_KEYS:
                total[k] += int(g.counters.get(k, 0))
        return Counters(**total)

    @property
    def latencies(self) -> list[float]:
        return list(self._latencies)

    def link_errors(self) -> dict[str, int]:
        total: dict[str, int] = {}
        for g in (*self._done, self._now):
            for k, v in g.link_errors.items():
                total[k] = total.get(k, 0) + int(v)
        return dict(sorted(total.items()))

    # --- ending -----------------------------------------------------------------------------------

    def shutdown(self) -> None:
        """The match is over: the daemon sends a stop and exits cleanly."""
        if not self.alive or self._proc is None:
            return
        pid = self._proc.pid
        self._send({"op": "quit"})
        ex = Exit("quit", pid, self.clock.now())
        with contextlib.suppress(DaemonError):
            r = self._reply(STOP_TIMEOUT_S)
            if r is not None and "bye" in r:
                ex.said_bye = True
                ex.stop_sent = bool(r.get("stop_sent"))
                self._now.counters = r["counters"]
                self._now.link_errors = r["link_errors"]
        ex.returncode, ex.forced = self._reap(STOP_TIMEOUT_S)
        self._gone(ex)

    def close(self) -> None:
        """Whatever state it is in: no process left behind."""
        if self._proc is not None and self._proc.poll() is None:
            self._proc.kill()
            self._reap(STOP_TIMEOUT_S)


def result_row(index: int, p: Perceived) -> list[Any]:
    """A camera result as a turn's answer carries it (JSON): the frame's index, the result's id,
    stamp, rings, frame index and error, the goals the goal detector saw (x, y, colour code
    rows; none without one) and the robots the robot detector saw (x, y, alliance code rows)."""
    return [
        index, p.id, p.stamp_s, p.rings_robot_xy.tolist(), p.frame_index, p.error,
        p.goals_robot.tolist(), p.robots_robot.tolist(),
    ]  # fmt: skip


def result_of_row(row: list[Any]) -> tuple[int, Perceived]:
    """result_row's inverse: (the frame's index, the result)."""
    index, rid, stamp, rings, frame, error, goals, robots = row
    return int(index), Perceived(
        int(rid), float(stamp), np.asarray(rings, dtype=np.float64).reshape(-1, 2), int(frame),
        error=error, goals_robot=np.asarray(goals, dtype=np.float64).reshape(-1, 3),
        robots_robot=np.asarray(robots, dtype=np.float64).reshape(-1, 3),
    )  # fmt: skip


def _spin(seconds: float) -> None:
    """Wait a short while precisely (sleep's resolution is too coarse below a millisecond)."""
    end = time.perf_counter() + seconds
    while time.perf_counter() < end:
        pass


# --- the child ------------------------------------------------------------------------------------


class _Child:
    """The daemon's side: `pete-jetson run`'s own Service.run() -> Daemon.run() loop, with one
    thing replaced: a turn of that loop (Daemon.service) serves the simulator's next request
    instead of waiting on the port by the wall clock. The signal handlers, the loop's look at
    the stop flag, and everything `pete-jetson run` does on its way out are its own."""

    def __init__(self, spec: dict[str, Any]) -> None:
        from jetson.clock import ManualClock
        from sim.fullstack.daemon import DaemonHost

        o = dict(spec["options"])
        for key in ("policy", "detector_model", "camera_config", "record_dir"):
            if o.get(key) is not None:
                o[key] = Path(o[key])
        self.options = DaemonOptions(**o)
        self.clock = ManualClock(float(spec["t"]))
        self.ctl = socket.socket(fileno=int(spec["ctl_fd"]))
        self._buf = b""
        if spec.get("disk_full"):
            self._disk(True)
        # The log to stdout, a pipe the simulator copies into daemon.jsonl (the journal, on a
        # Jetson): a full disk does not silence it.
        self.host = DaemonHost(
            self.options, self.clock, Path(spec["port"]), spec["frames"], sys.stdout
        )
        self.service = self.host.service_
        self.service.camera = self.host.camera  # Service.run starts and stops it
        self.daemon = self.host.daemon
        self.daemon.service = self._lockstep_turn  # type: ignore[method-assign]
        self._lat_sent = 0
        self._res_sent: set[int] = set()
        self._fail_sent: set[int] = set()
        self._stops = 0

    def answer(self, r: dict[str, Any]) -> None:
        self.ctl.sendall((json.dumps(r, separators=(",", ":")) + "\n").encode())

    def figures(self) -> dict[str, Any]:
        d = self.daemon
        return {"counters": d.counters.as_dict(), "link_errors": d.link_errors()}

    def run(self) -> int:
        # What cmd_run does once the daemon is built: the handlers, then Service.run().
        self.service.install_signal_handlers()
        self.answer({"ready": True, "pid": os.getpid()})
        code = self.service.run()
        with contextlib.suppress(OSError):
            stop_sent = self.daemon.counters.stops > self._stops
            self.answer({"bye": True, "stop_sent": stop_sent, **self.figures()})
        return code

    def _lockstep_turn(self, timeout_s: float) -> None:
        """Daemon.service's stand-in: the simulator's next request, if one comes within
        timeout_s (Daemon.run looks at its stop flag between two)."""
        line = self._next_line(timeout_s)
        if line is None:
            return
        try:
            reply = self.handle(json.loads(line))
        except Exception as exc:  # the simulator raises it with this text
            reply = {"error": f"{type(exc).__name__}: {exc}"}
        if reply is not None:
            self.answer(reply)

    def _next_line(self, timeout_s: float) -> bytes | None:
        deadline = time.monotonic() + timeout_s
        while b"\n" not in self._buf:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            ready, _, _ = select.select([self.ctl], [], [], left)
            if not ready:
                return None
            chunk = self.ctl.recv(1 << 16)
            if not chunk:
                self.service.stop_event.set()  # the simulator is gone: stop as at a SIGTERM
                return None
            self._buf += chunk
        line, self._buf = self._buf.split(b"\n", 1)
        return line

    def turn(self, t: float, rx: int, timeout_s: float) -> dict[str, Any]:
        self.clock.set(t)
        self.host.service(rx, timeout_s)
        d = self.daemon
        self._stops = d.counters.stops
        out: dict[str, Any] = {
            "tx": self.host.tx_on_connection,
            "conn": self.host.connected,
            "seq": self.host.last_command_seq,
            "state": d.state,
            **self.figures(),
        }
        lat = d.latency
        if lat.count > self._lat_sent:
            n = min(lat.count - self._lat_sent, len(lat.recent))
            out["lat"] = list(lat.recent)[-n:]
            self._lat_sent = lat.count
        new = [k for k in self.host.results if k not in self._res_sent]
        if new:
            out["res"] = []
            for k in new:
                out["res"].append(result_row(k, self.host.results[k]))
                self._res_sent.add(k)
        failed = self.host.failed_frames - self._fail_sent
        if failed:
            out["fail"] = sorted(failed)
            self._fail_sent |= failed
        return out

    @staticmethod
    def _disk(full: bool) -> None:
        import resource

        _, hard = resource.getrlimit(resource.RLIMIT_FSIZE)
        resource.setrlimit(resource.RLIMIT_FSIZE, (0 if full else hard, hard))

    def handle(self, r: dict[str, Any]) -> dict[str, Any] | None:
        op = r["op"]
        if op == "turn":
            return self.turn(float(r["t"]), int(r["rx"]), float(r["timeout"]))
        if op == "frame":
            self.host.frame_sent(int(r["index"]), float(r["t"]))
            return {}
        if op == "drop":
            self.host.drop_pending_frames()
            return {}
        if op == "latest":
            feed = self.host.feed
            p = feed.latest() if feed is not None else None
            return {"index": None if p is None else p.frame_index}
        if op == "disk":
            self._disk(bool(r["full"]))
            return {}
        if op == "quit":
            self._stops = self.daemon.counters.stops
            self.service.stop_event.set()  # the match is over: pete-jetson run's own way out
            return None
        raise ValueError(f"unknown request {op!r}")


def main(argv: list[str]) -> int:
    if len(argv) != 1:
        print("usage: python -m sim.fullstack.daemon_process SPEC_JSON", file=sys.stderr)
        return 2
    child = _Child(json.loads(argv[0]))
    return child.run()


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
