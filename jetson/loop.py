"""The daemon's control loop: the link to the Brain, the handshake, and a Command for each State.

One thread does all the link work (the camera has its own), so the path from a State's bytes to
its Command's bytes has no locks or hand-offs:

    read bytes -> decode -> newest State -> decide (observation + policy) -> write Command

and only then the bookkeeping (latency, log, recording). When several States arrive in one read
the older ones are skipped (counted): answering a State nobody is waiting for only delays the
newest.

`Daemon.service()` is one turn of the loop; `run()` turns it until asked to stop and then sends a
stop Command. A lockstep simulator can instead call `service()` / `pump_until()` itself with a
ManualClock, so that it decides when the daemon reads (see jetson/README.md, "In a simulator").

A port that opens but fails (no Brain behind it, a link that drops before its handshake) is
retried with exponential backoff (`reconnect_poll_s` doubling to `reconnect_max_s`, back to the
start when a link comes up); a port that is absent is looked for every turn. The decision keeps
its memories across a reconnect to the same Brain boot (the Hello's boot id), and so does the
session's recording; a new boot id starts both afresh (a new match is the decider's own call).
"""

from __future__ import annotations

import math
import secrets
import signal
import time
import traceback
from collections import Counter
from collections.abc import Callable
from typing import Any, Protocol

from jetson.camera_feed import PerceptionFeed
from jetson.clock import Clock
from jetson.decide import Decider, Decision, PerceptionInput
from jetson.handshake import Handshake, LinkState
from jetson.link import LinkClosed, LinkOpenError, PortLocator, SerialLink
from jetson.log import EventLog, LatencyStats
from jetson.partner import NOTHING, REPORT_PERIOD_S, PartnerInput, partner_report
from jetson.recorder import CycleRecord, Recorder, RecordingDir
from jetson.settings import LinkConfig
from jetson.stats import Counters, Snapshot, summary_fields, summary_line
from protocol import framing, messages
from protocol.framing import LinkError, Received, TextLine, UplinkDecoder
from protocol.messages import Command, Hello, Log, Partner, PartnerLink, PartnerStatus, State

_LOG_LEVELS = {0: "debug", 1: "info", 2: "warning", 3: "error"}


class StopRequest(Protocol):
    """What run() is stopped by: a threading.Event, or jetson.service.StopFlag (which a signal
    handler sets, and which names the signal in `signum`)."""

    def is_set(self) -> bool: ...

    def wait(self, timeout: float) -> bool: ...


class Backoff:
    """When to try the Brain's port again: at once at first, then after `first_s` doubling on
    every failure up to `max_s`; succeeded() (a link came up) starts again from `first_s`."""

    def __init__(self, first_s: float, max_s: float) -> None:
        self.first_s = first_s
        self.max_s = max(max_s, first_s)
        self.delay_s = first_s
        self.next_s = -math.inf
        self.failures = 0  # in a row

    def ready(self, now: float) -> bool:
        return now >= self.next_s

    def failed(self, now: float) -> None:
        self.failures += 1
        self.next_s = now + self.delay_s
        self.delay_s = min(self.delay_s * 2.0, self.max_s)

    def succeeded(self) -> None:
        self.failures = 0
        self.delay_s = self.first_s
        self.next_s = -math.inf


def software_version() -> str:
    try:
        from importlib.metadata import version

        return version("pacman-pete")
    except Exception:  # not installed (running from a checkout)
        return "0.0.0"


class Daemon:
    def __init__(
        self,
        decider: Decider,
        clock: Clock,
        log: EventLog,
        perception: PerceptionFeed | None = None,
        link: LinkConfig | None = None,
        locator: PortLocator | None = None,
        recordings: RecordingDir | None = None,
        header: dict[str, Any] | None = None,
        boot_id: int | None = None,
        fingerprint: int = messages.FINGERPRINT,
        summary_period_s: float = 1.0,
        open_link: Callable[..., SerialLink] = SerialLink.open,
    ) -> None:
        self.decider = decider
        self.clock = clock
        self.log = log
        self.perception = perception
        self.config = link or LinkConfig()
        self.locator = locator or PortLocator(self.config.port)
        self.recordings = recordings
        self._header = dict(header or {})
        self._open_link = open_link
        self.handshake = Handshake(
            secrets.randbits(32) if boot_id is None else boot_id,
            software_version(),
            fingerprint=fingerprint,
            hello_period_s=self.config.hello_period_s,
            mismatch_period_s=self.config.mismatch_hello_period_s,
        )
        self.link: SerialLink | None = None
        self.decoder = UplinkDecoder()
        self.counters = Counters()
        self.latency = LatencyStats()
        self.recorder: Recorder | None = None
        self.last_state: State | None = None
        self.last_command: Command | None = None
        self.last_decision: Decision | None = None
        # The alliance partner as our Brain hears it over VEXlink: its newest report and the
        # link's state (a link that is not up means this robot plays alone).
        self.partner: Partner | None = None
        self.partner_status: PartnerStatus | None = None
        self._next_partner_report: float | None = None
        self._tx_seq = 0
        self._cmd_seq = 0
        self._last_rx_s = 0.0
        self._waiting_since: float | None = None
        self._summary_period = summary_period_s
        self._next_summary = clock.now() + summary_period_s
        self._window_start = clock.now()
        self._window_counts = Counters()
        self._last_error_log: dict[str, float] = {}
        self._mismatch_logged_s: float | None = None
        self._rx_total = 0
        self._tx_total = 0
        self._shut_down = False
        self.backoff = Backoff(self.config.reconnect_poll_s, self.config.reconnect_max_s)
        # The Brain boot whose match the decider's memories (and the recording) belong to.
        self._memory_boot: int | None = None
        self._record_failure_logged = False
        # The dashboard (jetson.dashboard.snapshot.Observer): told of each turn and each line the
        # Brain prints, it builds a snapshot on this thread only when its server asked for one.
        # None without a dashboard.
        self.observer: Any = None
        # Small copies of the camera's frames (jetson.frames.FrameTap) for the recording and the
        # dashboard; None without a camera.
        self.frames: Any = None
        self.last_perceived: Any = None  # the perception result the last State was answered with

    # --- public state ---------------------------------------------------------------------------

    @property
    def state(self) -> str:
        if self.link is None:
            return "waiting for port"
        return self.handshake.state.value

    @property
    def rx_bytes(self) -> int:
        """Bytes read from the Brain, over all connections."""
        return self._rx_total + (self.link.rx_bytes if self.link else 0)

    @property
    def tx_bytes(self) -> int:
        """Bytes written to the Brain, over all connections."""
        return self._tx_total + (self.link.tx_bytes if self.link else 0)

    def link_errors(self) -> dict[str, int]:
        total = Counter(self.counters.link_errors)
        total.update(self.decoder.stats.errors)
        return {k: v for k, v in sorted(total.items()) if v}

    # --- running --------------------------------------------------------------------------------

    def run(self, stop: StopRequest) -> None:
        """Serve until `stop` is set (SIGTERM/SIGINT set it), then send a stop and close."""
        self.log.info(
            "start",
            f"pete-jetson {software_version()} boot {self.handshake.boot_id:08X}, "
            f"Brain at {self.locator.describe()}",
            boot_id=f"{self.handshake.boot_id:08X}",
            fingerprint=f"{self.handshake.fingerprint:08X}",
        )
        try:
            while not stop.is_set():
                try:
                    self.service(0.05)
                except Exception as exc:  # a bug here must not end an event day
                    self._internal_error("loop", exc)
                    stop.wait(0.1)
        finally:
            signum = getattr(stop, "signum", None)
            reason = "stop requested"
            if signum is not None:
                reason = signal.Signals(signum).name
                self.log.info("signal", f"{reason}: stopping", signal=reason)
            self.shutdown(reason)

    def pump_until(self, done: Callable[[], bool], timeout_s: float = 5.0) -> bool:
        """Serve until done() (e.g. every byte a lockstep Brain wrote has been read)."""
        deadline = time.monotonic() + timeout_s
        while not done():
            left = deadline - time.monotonic()
            if left <= 0:
                return False
            self.service(min(left, 0.02))
        return True

    def service(self, timeout_s: float) -> None:
        """One turn: connect if needed, say Hello when due, read and answer, summarise (and,
        with a dashboard, hand it a snapshot when it asked for one)."""
        self._service(timeout_s)
        if self.observer is not None:
            self.observer.turn(self)

    def _service(self, timeout_s: float) -> None:
        now = self.clock.now()
        if self.link is None and not self._connect(now):
            self._maybe_summary(now)
            time.sleep(min(timeout_s, self.config.reconnect_poll_s))
            return
        assert self.link is not None
        try:
            if self.handshake.due(now):
                self._send_hello(now)
            data = self.link.read(min(timeout_s, self.config.hello_period_s / 2))
        except LinkClosed as exc:
            self._disconnect(str(exc))
            return
        now = self.clock.now()
        if data:
            t_rx = time.perf_counter()
            self._last_rx_s = now
            try:
                self._feed(data, t_rx)
            except LinkClosed as exc:
                self._disconnect(str(exc))
                return
        elif now - self._last_rx_s > self.config.silence_timeout_s:
            self._disconnect(f"no bytes from the Brain for {self.config.silence_timeout_s:g} s")
            return
        self._maybe_summary(now)

    def shutdown(self, reason: str, record_wait_s: float = 0.4) -> None:
        """Send a stop (when the link is up), close the port and the recording (waiting at most
        record_wait_s for its writer: the process must exit within a second of SIGTERM), log the
        totals. Only once: a second call does nothing."""
        if self._shut_down:
            return
        self._shut_down = True
        if self.link is not None and self.handshake.up:
            try:
                self._send_command(Decision(0.0, 0.0, False, "shutdown"))
                self.log.info("stop_sent", f"sent a stop before exiting ({reason})")
            except (LinkClosed, OSError) as exc:
                self.log.warning("stop_failed", f"could not send the final stop: {exc}")
        self._summary(self.clock.now())  # the last partial second, while the link is still up
        self._close_link()
        self._end_recording(record_wait_s)
        self.log.close()  # the repeats not written yet
        overall = LatencyStats.summary_ms(self.latency.recent)
        self.log.info(
            "exit",
            f"exiting: {self.counters.states} States answered, latency p50 "
            f"{overall['p50_ms']:.3f} ms p99 {overall['p99_ms']:.3f} ms",
            latency=overall,
            counters=self.counters.as_dict(),
        )

    # --- connection -----------------------------------------------------------------------------

    def _connect(self, now: float) -> bool:
        if not self.backoff.ready(now):
            return False
        try:
            path = self.locator.find()
        except RuntimeError as exc:
            self._error_once("discover", f"cannot look for the Brain: {exc}")
            return False
        if path is None:
            if self._waiting_since is None:
                self._waiting_since = now
                self.log.info("waiting", f"waiting for the Brain at {self.locator.describe()}")
            return False
        try:
            link = self._open_link(path, baud=self.config.baud, exclusive=self.config.exclusive)
        except LinkClosed:
            return False  # it vanished between looking and opening
        except LinkOpenError as exc:
            self.backoff.failed(now)
            self._error_once("open", f"cannot open the Brain's port: {exc}")
            return False
        self.link = link
        self.decoder = UplinkDecoder()
        self.handshake.reset()
        self.counters.connects += 1
        self._last_rx_s = now
        self._waiting_since = None
        self._mismatch_logged_s = None
        self.log.info("port_open", f"opened {path}", port=path, connects=self.counters.connects)
        try:
            self._send_hello(now)
        except LinkClosed as exc:
            self._disconnect(str(exc))
            return False
        return True

    def _disconnect(self, reason: str) -> None:
        """The port closed. The decider and the recording stay as they are: if the same Brain
        boot comes back, its match goes on (a new boot id starts both afresh)."""
        now = self.clock.now()
        self.counters.disconnects += 1
        was = self.handshake.state
        self._close_link()
        self.handshake.reset()
        self.backoff.failed(now)
        if self.recorder is not None:
            self.recorder.event(now, "link_down", reason=reason)
        self.log.warning(
            "link_down", f"link down ({reason}); waiting for the Brain to come back",
            was=was.value, disconnects=self.counters.disconnects,
        )  # fmt: skip

    def _close_link(self) -> None:
        if self.link is None:
            return
        self._rx_total += self.link.rx_bytes
        self._tx_total += self.link.tx_bytes
        self.counters.tx_dropped += self.link.tx_dropped
        self.counters.link_errors.update(self.decoder.stats.errors)
        self.counters.lost += self.decoder.stats.lost
        self.counters.received += self.decoder.stats.received
        self.decoder = UplinkDecoder()
        self.link.close()
        self.link = None

    # --- sending --------------------------------------------------------------------------------

    def _write(self, data: bytes) -> bool:
        assert self.link is not None
        self._tx_seq = (self._tx_seq + 1) & 0xFF
        return self.link.write(data)

    def _send_hello(self, now: float) -> None:
        self._write(framing.encode_downlink(self.handshake.hello(), self._tx_seq))
        self.handshake.sent(now)

    def _send_command(self, d: Decision) -> Command:
        self._cmd_seq = self._cmd_seq % 0xFFFFFFFF + 1  # 1.., never 0 ("no command" on the Brain)
        cmd = Command(
            self._cmd_seq,
            d.linear,
            d.angular,
            d.intake,
            self.decider.config.valid_ms,
            clamp=d.clamp,
            lift=d.lift,
        )
        if not self._write(framing.encode_downlink(cmd, self._tx_seq)):
            self._error_once("tx_dropped", "the Brain is not draining its port: Command dropped")
        self.counters.commands += 1
        self._window_counts.commands += 1
        if not d.drove:
            self.counters.stops += 1
            self._window_counts.stops += 1
        self.last_command = cmd
        return cmd

    def _report_to_partner(self, state: State, decision: Decision, now: float) -> None:
        """Our report for the alliance partner, every REPORT_PERIOD_S (the Brain sends the
        newest over VEXlink; without a radio it goes no further)."""
        if self._next_partner_report is not None and now < self._next_partner_report:
            return
        self._next_partner_report = now + REPORT_PERIOD_S
        link = None if self.partner_status is None else self.partner_status.link
        try:
            claim = self.decider.claim(state)  # nothing unless this State's answer drove
        except Exception as exc:  # a claim that cannot be made is none; the report still goes
            self._error_once("claim", f"cannot name the claimed target: {exc}")
            claim = NOTHING
        report = partner_report(state, decision.drove, link, claim)
        try:
            self._write(framing.encode_downlink(report, self._tx_seq))
        except LinkClosed as exc:
            self._disconnect(str(exc))
            return
        self.counters.partner_reports += 1

    # --- receiving ------------------------------------------------------------------------------

    def _on_partner_status(self, status: PartnerStatus) -> None:
        before = None if self.partner_status is None else self.partner_status.link
        self.partner_status = status
        if status.link == before:
            return
        if status.link is PartnerLink.UP:
            self.log.info("partner_link", "partner link up: playing as an alliance")
        elif status.link is PartnerLink.LOST:
            self.partner = None
            self.log.warning(
                "partner_link", "partner link lost: playing alone", received=status.received
            )

    def _feed(self, data: bytes, t_rx: float) -> None:
        newest: State | None = None
        for ev in self.decoder.feed(data):
            if isinstance(ev, Received):
                msg = ev.message
                if isinstance(msg, State):
                    if self.handshake.up:
                        if newest is not None:
                            self.counters.states_skipped += 1
                        newest = msg
                    else:
                        self.counters.states_unverified += 1
                elif isinstance(msg, Hello):
                    if not self._on_hello(msg):
                        newest = None  # States before a restart or a refusal are not answered
                elif isinstance(msg, Partner):
                    self.partner = msg
                elif isinstance(msg, PartnerStatus):
                    self._on_partner_status(msg)
                elif isinstance(msg, Log):
                    level = _LOG_LEVELS.get(int(msg.level), "info")
                    self.log.event(
                        level, "brain_log", f"brain: {msg.text}", brain_time_ms=msg.time_ms
                    )
                    if self.observer is not None:
                        self.observer.brain_line(self.clock.now(), level, msg.text)
            elif isinstance(ev, TextLine):
                self.log.info("brain_text", f"brain {ev.stream}: {ev.text}", stream=ev.stream)
                if self.observer is not None:
                    self.observer.brain_line(self.clock.now(), ev.stream, ev.text)
            elif isinstance(ev, LinkError):
                self.log.debug(
                    "link_error", f"dropped a frame: {ev.kind}: {ev.detail}", kind=ev.kind
                )
        if newest is not None and self.link is not None:
            self._answer(newest, t_rx)

    def _on_hello(self, hello: Hello) -> bool:
        """Handle a Brain Hello; False when earlier States in the same read must be dropped."""
        now = self.clock.now()
        out = self.handshake.on_hello(hello, now)
        if out.reply:
            self._send_hello(now)
        if out.kind == "refused":
            self._error_once("hello_refused", out.message)
        elif out.kind in ("mismatch", "same") and self.handshake.state is LinkState.MISMATCH:
            self._end_recording()
            last = self._mismatch_logged_s
            if out.kind == "mismatch" or last is None or now - last >= 10.0:
                self._mismatch_logged_s = now
                self.log.error(
                    "fingerprint_mismatch",
                    f"REFUSING TO DRIVE: {out.message}. No Command will be sent.",
                    brain_boot_id=f"{hello.boot_id:08X}",
                    brain_fingerprint=f"{hello.fingerprint:08X}",
                    our_fingerprint=f"{self.handshake.fingerprint:08X}",
                )
            return False
        elif out.kind in ("up", "restart"):
            self.backoff.succeeded()
            # Memories belong to a Brain boot: the same boot back (a cable pulled and returned)
            # is the same match going on; a new boot id is a new start.
            same_boot = hello.boot_id == self._memory_boot
            level = "warning" if out.kind == "restart" else "info"
            kept = "; the same boot: the decision keeps its memories" if same_boot else ""
            self.log.event(
                level, "link_up" if out.kind == "up" else "brain_restart", out.message + kept,
                brain_boot_id=f"{hello.boot_id:08X}", brain_software=hello.software_version,
                memories="kept" if same_boot else "fresh",
            )  # fmt: skip
            if same_boot:
                if self.recorder is not None:
                    self.recorder.event(now, "link_up", brain_boot_id=f"{hello.boot_id:08X}")
            else:
                self._memory_boot = hello.boot_id
                self.decider.reset()
                self._start_recording(hello)
            return out.kind == "up"
        return True

    def _answer(self, state: State, t_rx: float) -> None:
        now = self.clock.now()
        p = None
        try:
            p = self.perception.latest() if self.perception is not None else None
            pin = None if p is None else PerceptionInput.of(p, now - p.stamp_s)
            partner = PartnerInput.of(self.partner, self.partner_status, state.match_ms)
            t0 = time.perf_counter()
            decision = self.decider.decide(state, pin, partner)
        except Exception as exc:  # the decider catches its own; this is for a broken feed
            t0 = time.perf_counter()
            pin = partner = None
            decision = Decision(0.0, 0.0, False, "error", error=f"{type(exc).__name__}: {exc}")
        t1 = time.perf_counter()
        try:
            cmd = self._send_command(decision)
        except LinkClosed as exc:
            self._disconnect(str(exc))
            return
        t_tx = time.perf_counter()
        # The Command is on the wire; everything below is bookkeeping (and the partner report).
        self._report_to_partner(state, decision, now)
        latency = t_tx - t_rx
        self.latency.add(latency)
        self.counters.states += 1
        self._window_counts.states += 1
        self._note_decision(decision)
        self.last_state = state
        self.last_perceived = p
        if self.recorder is not None:
            if p is not None:
                self.recorder.perception(p)
                if self.frames is not None:
                    self.recorder.frame(self.frames.get(p.id))
            self.recorder.cycle(
                CycleRecord(
                    now,
                    state,
                    None if pin is None else pin.id,
                    None if pin is None else pin.age_s,
                    cmd,
                    decision.reason,
                    decision.perception,
                    decision.rings,
                    decision.error,
                    latency * 1e3,
                    (t1 - t0) * 1e3,
                    partner,
                )
            )

    def _note_decision(self, d: Decision) -> None:
        prev = self.last_decision
        self.last_decision = d
        if d.error is not None:
            self.counters.errors += 1
            self._error_once(f"decide:{d.error}", f"decision failed, sent a stop: {d.error}")
        if prev is None or prev.reason != d.reason:
            what = "driving (policy)" if d.drove else f"stopped: {d.reason}"
            self.log.info("decision", what, reason=d.reason)
        if (
            prev is not None
            and d.perception != prev.perception
            and "-" not in (d.perception, prev.perception)
        ):
            if d.perception == "fresh":
                self.log.info("perception", "perception fresh again", status=d.perception)
            else:
                self.log.warning(
                    "perception", f"perception {d.perception}: the policy sees no rings",
                    status=d.perception,
                )  # fmt: skip

    # --- recording ------------------------------------------------------------------------------

    def _start_recording(self, hello: Hello) -> None:
        self._end_recording()
        if self.recordings is None:
            return
        header = {
            **self._header,
            "software": software_version(),
            "jetson_boot_id": f"{self.handshake.boot_id:08X}",
            "brain_boot_id": f"{hello.boot_id:08X}",
            "brain_software": hello.software_version,
            "fingerprint": f"{self.handshake.fingerprint:08X}",
            "decision": self.decider.config.to_dict(),
            "decision_hz": self.decider.decision_hz,
            "observation": self.decider.spec.to_dict(),
            "started": time.strftime("%Y-%m-%dT%H:%M:%S%z"),
        }
        try:
            self.recorder = self.recordings.open(header)
        except OSError as exc:
            self._error_once("record", f"cannot record the session: {exc}")
            return
        self._record_failure_logged = False
        self.recorder.reset(self.clock.now())
        self.log.info(
            "recording", f"recording to {self.recorder.path}", path=str(self.recorder.path)
        )

    def _end_recording(self, wait_s: float = 0.0) -> None:
        """Close the recording; its writer finishes on its own thread (the loop does not wait
        for a disk, except for wait_s)."""
        if self.recorder is not None:
            rec, self.recorder = self.recorder, None
            rec.close(wait_s)
            self._report_record_failure(rec)

    def _check_recording(self) -> None:
        """A recording that failed (a full disk, its budget) is paused: one line says so, and
        the robot drives on. Recording starts again with the next Brain boot's session."""
        rec = self.recorder
        if rec is not None and rec.failed:
            self._end_recording()

    def _report_record_failure(self, rec: Recorder) -> None:
        if rec.failed and not self._record_failure_logged:
            self._record_failure_logged = True
            self.log.error(
                "record_paused",
                f"recording paused: {rec.failed}; the robot drives on, and recording starts "
                f"again with the next Brain session ({rec.records} records in {rec.path})",
                path=str(rec.path),
            )

    # --- logging --------------------------------------------------------------------------------

    def _error_once(self, key: str, msg: str, period_s: float = 10.0) -> None:
        now = time.monotonic()
        last = self._last_error_log.get(key)
        if last is None or now - last >= period_s:
            self._last_error_log[key] = now
            self.log.error(key.split(":", 1)[0], msg)

    def _internal_error(self, where: str, exc: BaseException) -> None:
        self.counters.errors += 1
        text = f"unexpected error in the {where}: {type(exc).__name__}: {exc}"
        now = time.monotonic()
        last = self._last_error_log.get(text)
        if last is None or now - last >= 10.0:  # a bug that repeats must not flood the journal
            self._last_error_log[text] = now
            self.log.error("internal_error", text, traceback=traceback.format_exc(limit=8))
        if self.link is not None and self.handshake.up:
            try:
                self._send_command(Decision(0.0, 0.0, False, "internal error"))
            except Exception:
                self._disconnect("the link failed after an internal error")

    def _maybe_summary(self, now: float) -> None:
        if now >= self._next_summary:
            self._check_recording()
            self.log.flush_repeats()
            self._summary(now)
            self._next_summary += self._summary_period
            if self._next_summary <= now:
                self._next_summary = now + self._summary_period

    def _summary(self, now: float) -> None:
        span = max(now - self._window_start, 1e-9)
        self._window_start = now
        w, self._window_counts = self._window_counts, Counters()
        perception = None
        try:
            p = self.perception.latest() if self.perception is not None else None
        except Exception:  # a broken feed is reported by the decisions; the summary goes on
            p = None
        if p is not None:
            perception = (len(p.rings_robot_xy), now - p.stamp_s)
        d = self.last_decision
        snap = Snapshot(
            link=self.state,
            port=self.locator.describe(),
            waited_s=0.0 if self._waiting_since is None else now - self._waiting_since,
            brain_boot_id=self.handshake.brain_boot_id,
            state=self.last_state,
            rate_hz=w.states / span,
            latency=LatencyStats.summary_ms(self.latency.take_window()),
            received=self.counters.received + self.decoder.stats.received,
            lost=self.counters.lost + self.decoder.stats.lost,
            errors=self.link_errors(),
            perception=perception,
            has_perception=self.perception is not None,
            command=self.last_command,
            stop_reason=None if d is None or d.drove else d.reason,
            window={"states": w.states, "commands": w.commands, "stops": w.stops},
            counters=self.counters.as_dict(),
            role=self.decider.config.role,
        )
        self.log.summary(summary_line(snap), **summary_fields(snap))
