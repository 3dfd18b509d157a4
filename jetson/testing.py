"""Test doubles for the daemon: a fake Brain on a pty, a probe policy, a tiny ONNX policy.

Used by the tests, bench/daemon.py and simulators that want a Brain without brain_host; never by
the daemon itself.

FakeBrain plays a V5 Brain's user port as the firmware does (brain/README.md, "The link to the
Jetson"): Hello every 200 ms until the Jetson's Hello matches, then a State every
`state_period_s`, each Hello from the Jetson answered with one Hello, Commands decoded and kept.
It can corrupt bytes in either direction, vanish (close its pty, as an unplugged cable does) and
come back on a new pty behind the same symlink (as the udev rule's stable name does).
"""

from __future__ import annotations

import contextlib
import itertools
import json
import os
import pty
import select
import threading
import time
import tty
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from jetson.autonomy.spec import ObservationSpec
from protocol import framing, messages
from protocol.framing import DownlinkDecoder, Received
from protocol.messages import (
    Alliance,
    Command,
    Fault,
    GpsStatus,
    Hello,
    Log,
    LogLevel,
    MatchPeriod,
    MatchPhase,
    Partner,
    PoseFix,
    Role,
    State,
)

StateMaker = Callable[[int, float], dict[str, Any]]  # (state seq, seconds since start) -> fields


def plug_pty(link: Path | None) -> tuple[int, int, str]:
    """A raw pty, as a V5 Brain's CDC ACM port behaves (no echo, no CR/LF translation), with its
    master end non-blocking and `link` (when given) swapped atomically to point at it, as the udev
    rule's stable name points at a real port. Returns (master, slave, the pty's path)."""
    master, slave = pty.openpty()
    tty.setraw(slave)
    os.set_blocking(master, False)
    name = os.ttyname(slave)
    if link is not None:
        tmp = link.with_name(link.name + ".new")
        with contextlib.suppress(FileNotFoundError):
            tmp.unlink()
        tmp.symlink_to(name)
        os.replace(tmp, link)
    return master, slave, name


def unplug_pty(link: Path | None, *fds: int | None) -> None:
    """The cable pulled: `link` removed and the pty's ends closed (whatever is already gone)."""
    if link is not None:
        with contextlib.suppress(FileNotFoundError):
            link.unlink()
    for fd in fds:
        if fd is not None:
            with contextlib.suppress(OSError):
                os.close(fd)


def default_state(seq: int, t: float) -> dict[str, Any]:
    """A robot in autonomous moving slowly; x encodes seq so an answer shows which State it
    answered (x = seq mm, within the field for 1800 States)."""
    return {
        "phase": MatchPhase.AUTONOMOUS,
        "phase_ms": int(t * 1000),
        "alliance": Alliance.RED,
        "x": (seq % 1800) * 0.001,
        "y": -0.5,
        "heading": 90.0,
        "gps_error": 0.01,
        "gps_status": GpsStatus.OK,
        "pose_fix": PoseFix.GPS,
        "pose_std": 0.01,
        "heading_std": 0.5,
        "period": MatchPeriod.ISOLATION if t < 15.0 else MatchPeriod.INTERACTION,
        "match_ms": int(t * 1000),
    }


@dataclass
class BrainCommand:
    t: float
    command: Command


@dataclass
class FakeBrain:
    link_path: Path | None = None  # a symlink kept pointing at the current pty (like udev's)
    fingerprint: int = messages.FINGERPRINT
    boot_id: int = 0x5EED0001
    state_period_s: float = 0.02
    hello_period_s: float = 0.2
    make_state: StateMaker = default_state
    corrupt_uplink: float = 0.0  # probability per byte Brain -> Jetson
    corrupt_downlink: float = 0.0  # probability per byte Jetson -> Brain
    states_on_mismatch: bool = False  # a rogue Brain that sends States anyway
    seed: int = 0
    commands: list[BrainCommand] = field(default_factory=list)
    jetson_hellos: list[Hello] = field(default_factory=list)
    partner_reports: list[Partner] = field(default_factory=list)  # the Jetson's, for VEXlink
    states_sent: dict[int, State] = field(default_factory=dict)
    text_sent: int = 0

    def __post_init__(self) -> None:
        self._rng = np.random.default_rng(self.seed)
        self._master: int | None = None
        self._slave: int | None = None
        self.pty_path = ""
        self.decoder = DownlinkDecoder()
        self.connected = False
        self.mismatch = False
        self._tx_seq = 0
        self._state_seq = 0
        self._t0 = time.monotonic()
        self._next_hello = 0.0
        self._next_state = 0.0
        self._last_cmd_seq = 0
        self._stop = threading.Event()
        self._thread: threading.Thread | None = None
        self._lock = threading.RLock()  # the thread and callers both send
        self.appeared_at: float | None = None
        self.first_hello_after_appearing: float | None = None
        self.tx_bytes = 0
        self.open()

    # --- the port ---------------------------------------------------------------------------------

    def open(self) -> str:
        """A new pty (and the symlink pointed at it): the Brain plugged in."""
        self._master, self._slave, self.pty_path = plug_pty(self.link_path)
        self.decoder = DownlinkDecoder()
        self.connected = False
        self.mismatch = False
        self._next_hello = 0.0
        self.appeared_at = time.monotonic()
        self.first_hello_after_appearing = None
        return self.pty_path

    @property
    def path(self) -> str:
        return str(self.link_path) if self.link_path is not None else self.pty_path

    def vanish(self) -> None:
        """Close the pty and remove the symlink: the cable pulled, the Brain powered off."""
        with self._lock:
            unplug_pty(self.link_path, self._master, self._slave)
            self._master = self._slave = None
            self.connected = False

    def reappear(self, boot_id: int | None = None) -> None:
        with self._lock:
            if boot_id is not None:
                self.boot_id = boot_id
            self.open()

    @property
    def present(self) -> bool:
        return self._master is not None

    # --- sending ----------------------------------------------------------------------------------

    def _write(self, frame: bytes) -> None:
        if self._master is None:
            return
        if self.corrupt_uplink > 0:
            frame = self._corrupt(frame, self.corrupt_uplink)
        with contextlib.suppress(BlockingIOError, OSError):
            self.tx_bytes += os.write(self._master, frame)

    def _corrupt(self, data: bytes, p: float) -> bytes:
        hits = np.nonzero(self._rng.random(len(data)) < p)[0]
        if len(hits) == 0:
            return data
        out = bytearray(data)
        for i in hits:
            out[i] ^= 1 << int(self._rng.integers(8))
        return bytes(out)

    def _send(self, msg: Any) -> None:
        frame = framing.encode_uplink(msg, self._tx_seq)
        self._tx_seq = (self._tx_seq + 1) & 0xFF
        self._write(frame)

    def send_hello(self) -> None:
        self._send(
            Hello(self.fingerprint, messages.PROTOCOL_VERSION, Role.BRAIN, self.boot_id, "fake")
        )

    def send_state(self, **overrides: Any) -> State:
        self._state_seq += 1
        t = time.monotonic() - self._t0
        fields = {"seq": self._state_seq, "time_ms": int(t * 1000) & 0xFFFFFFFF}
        fields.update(self.make_state(self._state_seq, t))
        fields.update(overrides)
        fields.setdefault("last_command_seq", self._last_cmd_seq)
        fields.setdefault("faults", Fault(0))
        state = State(**fields)
        self.states_sent[state.seq] = state
        self._send(state)
        return state

    def send_log(self, text: str, level: LogLevel = LogLevel.INFO) -> None:
        with self._lock:
            self._send(Log(level, int((time.monotonic() - self._t0) * 1000), text))

    def send_message(self, msg: Any) -> None:
        """Any uplink message, e.g. the partner's Partner or a PartnerStatus."""
        with self._lock:
            self._send(msg)

    def send_text(self, text: str, stream: bytes = b"sout") -> None:
        with self._lock:
            self.text_sent += 1
            self._write(framing.stream_frame(stream, text.encode() + b"\n"))

    def restart(self, boot_id: int) -> None:
        """The program restarted on the same port (no USB change): new boot id, Hello again."""
        with self._lock:
            self.boot_id = boot_id
            self.connected = False
            self.mismatch = False
            self._next_hello = 0.0

    # --- receiving --------------------------------------------------------------------------------

    def pump(self, timeout_s: float = 0.0) -> list[Any]:
        """Read what the Jetson sent and act on it; returns the decoded events."""
        if self._master is None:
            time.sleep(timeout_s)
            return []
        ready, _, _ = select.select([self._master], [], [], timeout_s)
        if not ready:
            return []
        try:
            data = os.read(self._master, 65536)
        except (BlockingIOError, OSError):
            return []
        if self.corrupt_downlink > 0:
            data = self._corrupt(data, self.corrupt_downlink)
        events = self.decoder.feed(data)
        now = time.monotonic()
        for ev in events:
            if not isinstance(ev, Received):
                continue
            msg = ev.message
            if isinstance(msg, Hello):
                self.jetson_hellos.append(msg)
                if self.first_hello_after_appearing is None:
                    self.first_hello_after_appearing = now
                self.mismatch = msg.fingerprint != self.fingerprint
                self.connected = not self.mismatch
                self.send_hello()  # every Jetson Hello gets one answer
            elif isinstance(msg, Command) and self.connected:
                self.commands.append(BrainCommand(now, msg))
                self._last_cmd_seq = msg.seq
            elif isinstance(msg, Partner) and self.connected:
                self.partner_reports.append(msg)
        return events

    def wait_command(self, timeout_s: float = 1.0) -> Command | None:
        """Pump until a new Command arrives (for step-by-step use without the thread)."""
        n = len(self.commands)
        deadline = time.monotonic() + timeout_s
        while len(self.commands) == n:
            left = deadline - time.monotonic()
            if left <= 0:
                return None
            self.pump(left)
        return self.commands[-1].command

    # --- the automatic Brain ----------------------------------------------------------------------

    def step(self) -> None:
        """What the firmware's loop does on time: Hello while waiting, States once connected."""
        now = time.monotonic()
        if not self.connected and now >= self._next_hello:
            self.send_hello()
            self._next_hello = now + self.hello_period_s
        if (
            self.connected or (self.mismatch and self.states_on_mismatch)
        ) and now >= self._next_state:
            self.send_state()
            self._next_state = max(
                self._next_state + self.state_period_s, now - self.state_period_s
            )

    def start(self) -> FakeBrain:
        self._stop.clear()
        self._thread = threading.Thread(target=self._run, name="fake-brain", daemon=True)
        self._thread.start()
        return self

    def _run(self) -> None:
        while not self._stop.is_set():
            with self._lock:
                present = self._master is not None
            if not present:
                time.sleep(0.005)
                continue
            wait = max(0.0, min(self._next_state, self._next_hello) - time.monotonic())
            with self._lock:
                self.pump(min(wait, 0.005))
                self.step()

    def stop(self) -> None:
        self._stop.set()
        if self._thread is not None:
            self._thread.join(2.0)

    def close(self) -> None:
        self.stop()
        self.vanish()


# --- policies -----------------------------------------------------------------------------------


class ProbePolicy:
    """A policy whose answer shows what it was given: linear = x / length unit (the current frame's
    own x, clipped), angular = the number of visible rings / 10, no intake action. `fail` makes a
    call raise (to test the stop on exceptions)."""

    action_names = ("linear", "angular")
    action_scale = (0.5, 2.0)
    description = "probe policy"
    skills = None

    def __init__(self, spec: ObservationSpec | None = None, control_hz: float = 12.0) -> None:
        self.spec = spec or ObservationSpec()
        self.control_hz = control_hz
        self.fail: Callable[[np.ndarray], bool] | None = None
        self.calls = 0
        self.observations: list[np.ndarray] = []
        self.keep_observations = False

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        self.calls += 1
        if self.keep_observations:
            self.observations.append(np.array(obs))
        if self.fail is not None and self.fail(obs):
            raise RuntimeError("probe policy told to fail")
        ok = obs[self.spec.ring_offset + 2 : self.spec.frame_size : 3]
        return np.array([np.clip(obs[1], -1, 1), ok.sum() / 10.0], dtype=np.float32)

    def expected(self, state: State, rings: int) -> tuple[float, float]:
        """The (linear, angular) it answers a red-alliance State with."""
        wire_x = float(np.float32(state.x))  # what the State carries: an f32
        x = float(np.float32(wire_x / self.spec.length_unit_m))
        return float(np.clip(x, -1, 1)) * 0.5, rings / 10.0 * 2.0


def write_mlp_policy(
    folder: Path,
    spec: ObservationSpec | None = None,
    hidden: tuple[int, ...] = (128, 128),
    seed: int = 0,
    scale: tuple[float, float] = (0.904, 4.8),
    intake: bool = False,
    control_hz: float = 12.0,
) -> Path:
    """A random-weight MLP with the shipped policy's shape (tanh hidden layers, tanh output) as
    policy.onnx + policy.json in the format sim.training.export writes. Needs the `onnx`
    package (the sim extra). Returns the .onnx path."""
    import hashlib

    import onnx
    from onnx import TensorProto, helper, numpy_helper

    spec = spec or ObservationSpec()
    rng = np.random.default_rng(seed)
    n_out = 3 if intake else 2
    sizes = [spec.size, *hidden, n_out]
    nodes, inits = [], []
    x = "obs"
    for i, (a, b) in enumerate(itertools.pairwise(sizes)):
        w = (rng.standard_normal((a, b)) / np.sqrt(a)).astype(np.float32)
        bias = (0.1 * rng.standard_normal(b)).astype(np.float32)
        inits += [numpy_helper.from_array(w, f"w{i}"), numpy_helper.from_array(bias, f"b{i}")]
        nodes.append(helper.make_node("MatMul", [x, f"w{i}"], [f"m{i}"]))
        nodes.append(helper.make_node("Add", [f"m{i}", f"b{i}"], [f"a{i}"]))
        out = "action" if i == len(sizes) - 2 else f"h{i}"
        nodes.append(helper.make_node("Tanh", [f"a{i}"], [out]))
        x = out
    graph = helper.make_graph(
        nodes,
        "mlp_policy",
        [helper.make_tensor_value_info("obs", TensorProto.FLOAT, ["batch", spec.size])],
        [helper.make_tensor_value_info("action", TensorProto.FLOAT, ["batch", n_out])],
        inits,
    )
    model = helper.make_model(graph, opset_imports=[helper.make_opsetid("", 17)])
    model.ir_version = 8
    onnx.checker.check_model(model)
    folder.mkdir(parents=True, exist_ok=True)
    path = folder / "policy.onnx"
    path.write_bytes(model.SerializeToString())
    names = ["linear", "angular"] + (["intake"] if intake else [])
    meta = {
        "format": "pacman-pete-policy",
        "format_version": 1,
        "onnx": path.name,
        "onnx_sha256": hashlib.sha256(path.read_bytes()).hexdigest(),
        "input": {"name": "obs", "size": spec.size, "dtype": "float32"},
        "output": {"name": "action", "size": n_out, "dtype": "float32"},
        "observation": spec.to_dict(),
        "observation_fingerprint": spec.fingerprint(),
        "actions": {
            "names": names,
            "scale": [*scale, 1.0][:n_out],
            "units": ["m/s forward", "rad/s clockwise (heading increasing)", "on when > 0"][:n_out],
            "range": [-1.0, 1.0],
        },
        "control_hz": control_hz,
        "training": {"note": "random weights, for tests and benchmarks"},
    }
    path.with_suffix(".json").write_text(json.dumps(meta, indent=1) + "\n")
    return path
