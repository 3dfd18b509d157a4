"""Fault scenarios for the full-stack match (`pete-sim match --fault NAME`, or several with
`--faults NAME@S,...`), each with the checks that say whether the robot behaved as promised.

    link-cut         the USB cable is pulled for 2 s: the Brain stops within the Command validity
                     window, the daemon notices, reopens the port when it comes back, and drives on
    corruption       1 % of bytes corrupted in each direction (a random bit of each hit byte): no
                     damaged message is ever acted on, errors are counted, the match goes on
    jetson-killed    the daemon dies (SIGKILL: no stop Command) and stays dead: the Brain stops
                     within the validity window and stays stopped; driver control still works
    schema-mismatch  the Jetson was built from another schema: the robot never moves, and both
                     sides log why
    camera-stops     the camera stops delivering frames: the daemon keeps commanding as the policy
                     was trained to for no rings in view, and logs it
    jetson-sigterm   SIGTERM to the daemon's process at a random moment of its work (systemd's
                     stop): it exits within 1 s having sent a stop Command; systemd starts it
                     again RestartSec later and it drives again within 1 s
    jetson-sigkill   SIGKILL to the daemon's process, then the same restart: the Brain stops
                     within the validity window, the new daemon drives again within 1 s
    disk-full        the daemon's disk fills (every file write fails): the robot keeps driving,
                     the daemon lives on and logs it once or twice, not in a flood
    brain-reboot     the Brain's program restarts (brain_host ends and starts again with a new
                     boot id; the USB port stays): the daemon sees the new boot, starts its
                     memories afresh and drives again within 1 s
    vexlink-lost     the radio between the alliance's two Brains goes silent for good (--partner
                     stack): both Brains call the link lost within its timeout, both daemons say
                     they play alone, and both robots drive on

jetson-sigterm, jetson-sigkill and disk-full need the daemon as its own process (`--daemon
process`, chosen for them by default: sim/fullstack/daemon_process.py). In a schedule
(`--faults`, the soak benchmark) corruption, camera-stops and disk-full last a window (5, 3 and
5 s) instead of to the end of the match, and faults may not overlap.

Every full-stack match, with a fault or without, also checks that nothing the cable delivered
differed from what was sent (a damaged message passing every check would be a protocol bug), and
in lockstep that every step the Jetson drove the motors, it did so by a Command the Brain had
received as sent within its validity (valid_ms).
"""

from __future__ import annotations

import json
import math
import zlib
from pathlib import Path
from typing import TYPE_CHECKING, Any

import numpy as np

from protocol import messages
from sim.errors import MatchError
from sim.fullstack.options import LOOP_MS, MatchOptions, RunningMatch
from sim.fullstack.report import Check

if TYPE_CHECKING:
    from sim.fullstack.brain_host import BrainReport

CUT_S = 2.0
CORRUPTION = 0.01
STICKS_AFTER_KILL_S = 1.0
STICKS_FOR_S = 0.5
OTHER_FINGERPRINT = messages.FINGERPRINT ^ 0x5A5A5A5A
RECONNECT_S = 1.0  # a returning cable, a restarted daemon, a rebooted Brain: driven again within
EXIT_S = 1.0  # a SIGTERM ends the daemon within this (issue 42)
REBOOT_S = 1.0  # the Brain is down this long when its program restarts
SIGTERM_SPREAD_S = 0.002  # a SIGTERM lands up to this long (wall) into the daemon's turn
SETTLE_S = 1.0  # a scheduled fault's checks look this long past its end
UNIT = Path(__file__).resolve().parents[2] / "jetson" / "deploy" / "pete-jetson.service"


def restart_sec(unit: Path = UNIT) -> float:
    """systemd's RestartSec for the daemon (jetson/deploy/pete-jetson.service; 1 s without it):
    how long a dead daemon stays dead before its restart."""
    try:
        for line in unit.read_text().splitlines():
            key, _, value = line.strip().partition("=")
            if key == "RestartSec":
                return float(value.strip().rstrip("s"))
    except (OSError, ValueError):
        pass
    return 1.0


def read_log(path: Path) -> list[dict[str, Any]]:
    """The daemon's JSON-lines log; unparseable lines (none expected) are skipped."""
    out = []
    if not path.exists():
        return out
    for line in path.read_text().splitlines():
        try:
            out.append(json.loads(line))
        except json.JSONDecodeError:
            continue
    return out


def _log(m: RunningMatch) -> list[dict[str, Any]]:
    """The run's daemon log, read once per match for all the scenarios that look at it."""
    path = m.folder / "daemon.jsonl"
    key = (str(path), path.stat().st_size if path.exists() else -1)
    if _LOG_CACHE.get("key") != key:
        _LOG_CACHE["key"] = key
        _LOG_CACHE["log"] = read_log(path)
    return _LOG_CACHE["log"]


_LOG_CACHE: dict[str, Any] = {}


class Scenario:
    """No fault. Subclasses hook the match before and after each 10 ms step."""

    name = "none"
    default_at_fraction = 1 / 3
    needs_process = False  # the daemon must be its own process (signals, a full disk)
    needs_record = False  # the daemon must record its sessions
    lockstep_only = False
    window_s: float | None = None  # how long the fault lasts in a schedule (None: its own span)

    def __init__(
        self,
        at_s: float | None,
        match_s: float,
        valid_ms: int = 250,
        seed: int = 0,
        duration_s: float | None = None,
    ) -> None:
        at = match_s * self.default_at_fraction if at_s is None else at_s
        if not 0 <= at < match_s:
            raise ValueError(f"fault time {at:g} s must fall within the match (0 .. {match_s:g} s)")
        if duration_s is not None and not duration_s > 0:
            raise ValueError(f"{self.name}: a fault's duration must be positive, got {duration_s}")
        self.at_ms = round(at * 100) * 10
        self.valid_ms = valid_ms
        self.window_ms = valid_ms + LOOP_MS  # validity, plus the loop step that notices
        self.duration_ms = None if duration_s is None else round(duration_s * 100) * 10
        self.rng = np.random.default_rng((seed, self.at_ms, zlib.crc32(self.name.encode())))
        self.fired = False

    @property
    def label(self) -> str:
        return f"{self.name}@{self.at_ms / 1000:g}s"

    @property
    def span_ms(self) -> int:
        """From the fault to the end of what its checks watch (a schedule spaces faults by it)."""
        return self.duration_ms or 0

    def daemon_mode(self, options: MatchOptions) -> str:
        """inprocess or process: what the options ask for, or what this scenario needs."""
        if options.daemon is None:
            return "process" if self.needs_process else "inprocess"
        if options.daemon == "inprocess" and self.needs_process:
            raise MatchError(
                f"{self.name} needs the daemon as its own process: drop --daemon inprocess"
            )
        return options.daemon

    def jetson_fingerprint(self) -> int:
        return messages.FINGERPRINT

    def due(self, m: RunningMatch, at_ms: int) -> bool:
        return m.match_ms == at_ms

    def before_tick(self, m: RunningMatch) -> None:
        pass

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        pass

    def checks(self, m: RunningMatch) -> list[Check]:
        return self.common_checks(m) + self.own_checks(m)

    def common_checks(self, m: RunningMatch) -> list[Check]:
        up, down = m.cable.up, m.cable.down
        out = [
            Check(
                "integrity",
                up.altered == 0 and down.altered == 0,
                f"messages delivered that were not sent as they arrived: up {up.altered}, "
                f"down {down.altered} (must be 0)",
            )
        ]
        track = m.brain_track
        if track.ledger:
            bad = track.invalid_steps
            out.append(
                Check(
                    "valid_commands",
                    bad == 0,
                    f"steps the Jetson drove by a Command not received as sent or older than "
                    f"{track.valid_ms} ms: {bad} of {track.jetson_steps} (must be 0); the oldest "
                    f"Command driving was {track.max_command_age_ms} ms old"
                    + (f"; e.g. {track.invalid_examples[0]}" if track.invalid_examples else ""),
                )
            )
        return out

    def own_checks(self, m: RunningMatch) -> list[Check]:
        return []

    def records(self, m: RunningMatch) -> list[dict[str, Any]]:
        """What each fault did and measured (MatchResult.faults): none without a fault."""
        if self.name == "none":
            return []
        own = self.own_checks(m)
        return [
            {
                "kind": self.name,
                "at_s": self.at_ms / 1000,
                **self.measures(m),
                "passed": all(c.passed for c in own),
                "failed": [c.name for c in own if not c.passed],
            }
        ]

    def measures(self, m: RunningMatch) -> dict[str, Any]:
        return {}


class _StopWatch:
    """From an event on: when the Jetson stopped driving the motors, read on brain_host's own
    clock (in realtime the simulator's ticks may lag it), and how old the Command it drove by
    last had been (lockstep). The robot counts as stopped at the first step the Jetson does not
    drive its motors, or from the step the Brain acts on a stop Command (it then brakes under its
    acceleration limit: from full speed that takes about 0.3 s, its ramp, not a delay)."""

    def __init__(self) -> None:
        self.event_ms: int | None = None  # brain_host's clock at the event
        self.stopped_ms: int | None = None  # ...at the first step the Jetson did not drive
        self.last_age_ms: int | None = None  # the Command driving the last step before that
        self.driven_at_event: bool | None = None  # the Jetson drove the motors at the event
        self.by_stop_command = False  # it stopped on a stop Command (not by a timeout)
        self.jetson_after_stop = 0  # steps the Jetson drove again afterwards

    def start(self, m: RunningMatch) -> None:
        self.event_ms = m.brain_now_ms()

    def note(
        self, report: BrainReport, age_ms: int | None = None, stop_command: bool = False
    ) -> None:
        if self.event_ms is None or report.last_step_ms < self.event_ms:
            return
        driven = report.source == "jetson" and report.moving
        if self.stopped_ms is None:
            if self.driven_at_event is None:
                self.driven_at_event = driven
            if driven and not stop_command:
                self.last_age_ms = age_ms
            else:
                self.stopped_ms = report.last_step_ms
                self.by_stop_command = driven and stop_command
        elif driven and not stop_command:
            self.jetson_after_stop += 1

    @property
    def took_ms(self) -> int | None:
        if self.event_ms is None or self.stopped_ms is None:
            return None
        return self.stopped_ms - self.event_ms

    def check(self, window_ms: int, what: str, realtime: bool = False) -> Check:
        # In realtime brain_host's own loop runs late now and then on a loaded PC (it is a
        # sanitizer build sharing the cores with the simulator): two more loop periods.
        limit = window_ms + (2 * LOOP_MS if realtime else 0)
        why = "the Command validity window plus one loop step"
        if realtime:
            why += ", plus two for a PC's scheduling in realtime"
        if self.event_ms is None:
            return Check("stops_in_time", False, f"{what} never happened (match too short?)")
        if self.stopped_ms is None:
            return Check("stops_in_time", False, f"the Jetson still drove at the end after {what}")
        took = self.stopped_ms - self.event_ms
        age = "" if self.last_age_ms is None else f"; its last Command drove {self.last_age_ms} ms"
        how = "began braking on the stop Command" if self.by_stop_command else "stopped driving"
        return Check(
            "stops_in_time",
            took <= limit,
            f"the Brain {how} {took} ms after {what} (limit: {limit} ms, {why}){age}",
        )

    def stays_stopped(self, what: str) -> Check:
        return Check(
            "stays_stopped",
            self.jetson_after_stop == 0,
            f"steps the Jetson drove {what}: {self.jetson_after_stop}",
        )

    def measures(self) -> dict[str, Any]:
        return {
            "stop_after_fault_ms": self.took_ms,
            "kept_driving_ms": self.last_age_ms,
            "driven_at_fault": self.driven_at_event,
            "stopped_by_command": self.by_stop_command,
        }


class _Return:
    """After something came back (the cable, the daemon, the Brain): when the Brain first
    obeyed the Jetson again."""

    def __init__(self, since_ms: int, what: str) -> None:
        self.since_ms = since_ms  # match time
        self.what = what
        self.at_ms: int | None = None

    def note(self, m: RunningMatch, t_ms: int, report: BrainReport) -> None:
        if self.at_ms is None and t_ms >= self.since_ms and report.source == "jetson":
            self.at_ms = t_ms
            m.replay.event(t_ms / 1000, "the Brain obeys the Jetson again")

    @property
    def took_ms(self) -> int | None:
        return None if self.at_ms is None else self.at_ms - self.since_ms

    def check(self, limit_s: float = RECONNECT_S) -> Check:
        took = self.took_ms
        return Check(
            "back_in_time",
            took is not None and took <= limit_s * 1000,
            f"the Jetson never drove again after {self.what}"
            if took is None
            else f"the Brain obeyed the Jetson again {took} ms after {self.what} "
            f"(limit {limit_s * 1000:.0f} ms)",
        )


def _share(steps: int, jetson: int) -> float:
    return jetson / steps if steps else 0.0


class LinkCut(Scenario):
    name = "link-cut"

    def __init__(self, *args: Any, **kw: Any) -> None:
        super().__init__(*args, **kw)
        self.back_ms = self.at_ms + round(CUT_S * 1000)
        self.watch = _StopWatch()
        self.back = _Return(self.back_ms, "the cable came back")

    @property
    def span_ms(self) -> int:
        return round((CUT_S + RECONNECT_S + SETTLE_S) * 1000)

    def before_tick(self, m: RunningMatch) -> None:
        if self.due(m, self.at_ms):
            m.cable.unplug()
            self.watch.start(m)  # after: in realtime the daemon may write until the cut
            m.replay.event(self.at_ms / 1000, "USB cable pulled")
        elif self.due(m, self.back_ms):
            m.cable.plug_in()
            m.replay.event(self.back_ms / 1000, "USB cable back")

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        t = m.step_match_ms(report)
        if t < self.back_ms:
            self.watch.note(
                report, m.brain_track.age_ms(report), m.brain_track.applies_stop(report)
            )
        else:
            self.back.note(m, t, report)

    def own_checks(self, m: RunningMatch) -> list[Check]:
        d = m.jetson.counters
        took = self.back.took_ms
        return [
            self.watch.check(self.window_ms, "the cable was pulled", m.realtime),
            self.watch.stays_stopped("while the cable was out"),
            Check(
                "daemon_reconnects",
                d.disconnects >= 1 and d.connects >= 2,
                f"the daemon saw the port go {d.disconnects} time(s) and opened it "
                f"{d.connects} time(s)",
            ),
            Check(
                "match_goes_on",
                took is not None and m.world.time_s * 1000 >= m.match_len_ms - 10,
                "the Jetson never drove again"
                if took is None
                else f"the Jetson drove again {took} ms after the cable came back; the match "
                f"ran to {m.world.time_s:.1f} s",
            ),
            self.back.check(RECONNECT_S + (0.1 if m.realtime else 0.0)),
        ]

    def measures(self, m: RunningMatch) -> dict[str, Any]:
        return {**self.watch.measures(), "reconnect_ms": self.back.took_ms}


class Corruption(Scenario):
    name = "corruption"
    default_at_fraction = 0.0
    window_s = 5.0

    def __init__(self, *args: Any, **kw: Any) -> None:
        super().__init__(*args, **kw)
        self.end_ms = None if self.duration_ms is None else self.at_ms + self.duration_ms
        self.steps_after = 0
        self.jetson_steps_after = 0
        self.link_error_steps = 0
        self.rejected_at: tuple[int, int] | None = None
        self.rejected_end: tuple[int, int] | None = None

    @property
    def span_ms(self) -> int:
        return (self.duration_ms or 0) + round(SETTLE_S * 1000)

    def before_tick(self, m: RunningMatch) -> None:
        if self.due(m, self.at_ms):
            m.cable.set_corruption(CORRUPTION, CORRUPTION)
            self.rejected_at = (m.cable.up.rejected, m.cable.down.rejected)
            m.replay.event(self.at_ms / 1000, f"{CORRUPTION:.0%} of bytes corrupted both ways")
        elif self.end_ms is not None and self.due(m, self.end_ms):
            m.cable.set_corruption(0.0, 0.0)
            self.rejected_end = (m.cable.up.rejected, m.cable.down.rejected)
            m.replay.event(self.end_ms / 1000, "no more corruption")

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        t = m.step_match_ms(report)
        if self.end_ms is not None and t >= self.end_ms:
            return
        if t >= self.at_ms + 1000:  # a second to settle: then the Jetson must keep driving
            self.steps_after += 1
            self.jetson_steps_after += report.source == "jetson"
        if t >= self.at_ms and "link_errors" in report.faults:
            self.link_error_steps += 1

    def _rejected(self, m: RunningMatch) -> tuple[int, int]:
        start = self.rejected_at or (0, 0)
        end = self.rejected_end or (m.cable.up.rejected, m.cable.down.rejected)
        return end[0] - start[0], end[1] - start[1]

    def own_checks(self, m: RunningMatch) -> list[Check]:
        up, down = self._rejected(m)
        share = _share(self.steps_after, self.jetson_steps_after)
        return [
            Check(
                "errors_counted",
                up > 0 and down > 0 and self.link_error_steps > 0,
                f"frames refused: Brain -> Jetson {up}, Jetson -> Brain {down}; "
                f"the Brain reported link_errors in {self.link_error_steps} steps",
            ),
            Check(
                "match_goes_on",
                self.steps_after > 0 and share >= 0.9,
                f"the Jetson drove {share:.0%} of the time after the first second of corruption "
                "(at least 90 %)",
            ),
        ]

    def measures(self, m: RunningMatch) -> dict[str, Any]:
        up, down = self._rejected(m)
        return {
            "rejected_up": up,
            "rejected_down": down,
            "jetson_share": _share(self.steps_after, self.jetson_steps_after),
        }


class JetsonKilled(Scenario):
    name = "jetson-killed"

    def __init__(self, *args: Any, **kw: Any) -> None:
        super().__init__(*args, **kw)
        self.sticks_on_ms = self.at_ms + round(STICKS_AFTER_KILL_S * 1000)
        self.sticks_off_ms = self.sticks_on_ms + round(STICKS_FOR_S * 1000)
        self.watch = _StopWatch()
        self.driver_steps = 0
        self.pose_at_sticks: tuple[float, float] | None = None
        self.driver_moved_m = 0.0

    @property
    def span_ms(self) -> int:
        return 10**9  # the daemon stays dead: nothing can follow it

    def before_tick(self, m: RunningMatch) -> None:
        if self.due(m, self.at_ms):
            m.jetson.kill()
            self.watch.start(m)  # after: in realtime the daemon may write until it dies
            m.replay.event(self.at_ms / 1000, "Jetson killed")
        elif self.due(m, self.sticks_on_ms):
            from sim.fullstack.brain_host import BrainHost

            m.extra_lines.append(BrainHost.sticks_line(0.6, 0.0))
            r = m.world.robots[m.ia]
            self.pose_at_sticks = (r.x, r.y)
            m.replay.event(self.sticks_on_ms / 1000, "driver pushes the stick")
        elif self.due(m, self.sticks_off_ms):
            m.extra_lines.append("sticks off")
            r = m.world.robots[m.ia]
            if self.pose_at_sticks is not None:
                self.driver_moved_m = math.hypot(
                    r.x - self.pose_at_sticks[0], r.y - self.pose_at_sticks[1]
                )
            m.replay.event(self.sticks_off_ms / 1000, "driver lets go")

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        t = m.step_match_ms(report)
        if t < self.sticks_on_ms:
            self.watch.note(
                report, m.brain_track.age_ms(report), m.brain_track.applies_stop(report)
            )
        if self.sticks_on_ms <= t < self.sticks_off_ms and report.source == "driver":
            self.driver_steps += report.moving

    def own_checks(self, m: RunningMatch) -> list[Check]:
        driver_ok = self.driver_steps > 0 and self.driver_moved_m > 0.05
        return [
            self.watch.check(self.window_ms, "the Jetson died", m.realtime),
            self.watch.stays_stopped("by the dead Jetson's Commands"),
            Check(
                "driver_control_works",
                driver_ok,
                f"with the stick pushed the Brain drove {self.driver_steps} steps and the robot "
                f"moved {self.driver_moved_m:.2f} m",
            ),
        ]

    def measures(self, m: RunningMatch) -> dict[str, Any]:
        return self.watch.measures()


class SchemaMismatch(Scenario):
    name = "schema-mismatch"
    default_at_fraction = 0.0

    def __init__(self, *args: Any, **kw: Any) -> None:
        super().__init__(*args, **kw)
        self.start: tuple[float, float] | None = None
        self.moving_steps = 0

    @property
    def span_ms(self) -> int:
        return 10**9  # the whole match

    def jetson_fingerprint(self) -> int:
        return OTHER_FINGERPRINT

    def before_tick(self, m: RunningMatch) -> None:
        if self.start is None:
            r = m.world.robots[m.ia]
            self.start = (r.x, r.y)

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        self.moving_steps += report.moving

    def own_checks(self, m: RunningMatch) -> list[Check]:
        r = m.world.robots[m.ia]
        assert self.start is not None
        moved = math.hypot(r.x - self.start[0], r.y - self.start[1])
        log = _log(m)
        jetson_says = [e for e in log if e.get("event") == "fingerprint_mismatch"]
        brain_says = [
            e
            for e in log
            if e.get("event") == "brain_log" and "fingerprint mismatch" in str(e.get("msg", ""))
        ]
        links = m.brain_track.link_states
        return [
            Check(
                "never_moves",
                self.moving_steps == 0 and moved < 0.01,
                f"steps with the motors driven: {self.moving_steps}; the robot moved {moved:.3f} m",
            ),
            Check(
                "brain_refuses",
                "mismatch" in links and "fingerprint_mismatch" in m.brain_track.faults_seen,
                f"Brain link states seen: {sorted(links)}",
            ),
            Check(
                "both_sides_log_why",
                bool(jetson_says) and bool(brain_says),
                f"daemon log: {len(jetson_says)} fingerprint_mismatch error(s), "
                f"{len(brain_says)} Brain log line(s) saying why"
                + (f"; e.g. {jetson_says[0]['msg'][:120]!r}" if jetson_says else ""),
            ),
        ]


class CameraStops(Scenario):
    name = "camera-stops"
    window_s = 3.0

    def __init__(self, *args: Any, **kw: Any) -> None:
        super().__init__(*args, **kw)
        self.back_ms = None if self.duration_ms is None else self.at_ms + self.duration_ms
        self.applied_at_stop: int | None = None
        self.at_clock: float | None = None
        self.back_clock: float | None = None
        self.steps_after = 0
        self.jetson_steps_after = 0

    @property
    def span_ms(self) -> int:
        return (self.duration_ms or 0) + round(SETTLE_S * 1000)

    def before_tick(self, m: RunningMatch) -> None:
        if self.due(m, self.at_ms) and m.server is not None:
            # The daemon's clock when it happened (its log's `t`): in lockstep the previous
            # step's time, in realtime the wall clock's.
            self.at_clock = m.clock.now()
            m.stop_camera()
            self.applied_at_stop = m.brain_track.applied
            m.replay.event(self.at_ms / 1000, "camera stops")
        elif self.back_ms is not None and self.due(m, self.back_ms):
            self.back_clock = m.clock.now()
            m.start_camera()
            m.replay.event(self.back_ms / 1000, "camera back")

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        t = m.step_match_ms(report)
        if self.back_ms is not None and t >= self.back_ms:
            return
        if self.applied_at_stop is not None and t > self.at_ms:
            self.steps_after += 1
            self.jetson_steps_after += report.source == "jetson"

    def own_checks(self, m: RunningMatch) -> list[Check]:
        at = self.at_clock if self.at_clock is not None else math.inf
        end = math.inf if self.back_clock is None else self.back_clock + SETTLE_S
        during = [e for e in _log(m) if at - 1e-9 <= float(e.get("t") or 0.0) <= end]
        blind = [
            e for e in during if e.get("event") == "perception" and e.get("level") == "warning"
        ]
        camera = [e for e in during if e.get("event") in ("camera_end", "camera_error")]
        applied = m.brain_track.applied - (self.applied_at_stop or 0)
        share = _share(self.steps_after, self.jetson_steps_after)
        out = [
            Check(
                "keeps_commanding",
                self.applied_at_stop is not None and applied > 0 and share >= 0.95,
                f"after the camera stopped the Brain applied {applied} new Commands and the "
                f"Jetson drove {share:.0%} of the time",
            ),
            Check(
                "logs_it",
                bool(blind) and bool(camera),
                f"daemon log after the stop: {len(blind)} perception warning(s) "
                + (f"({blind[0]['msg']!r})" if blind else "")
                + f", {len(camera)} camera event(s)",
            ),
        ]
        if self.back_clock is not None:
            seen = self._frames_after(m)
            out.append(
                Check(
                    "sees_again",
                    seen > 0,
                    f"frames perceived in the {SETTLE_S:g} s after the camera came back: {seen}",
                )
            )
        return out

    def _frames_after(self, m: RunningMatch) -> int:
        if self.back_clock is None:
            return 0
        lo, hi = self.back_clock, self.back_clock + SETTLE_S
        return sum(lo <= p.stamp_s <= hi for p in m.jetson.results.values())

    def measures(self, m: RunningMatch) -> dict[str, Any]:
        return {
            "jetson_share": _share(self.steps_after, self.jetson_steps_after),
            "frames_after_return": self._frames_after(m) if self.back_clock is not None else None,
        }


class _Restart(Scenario):
    """A signal to the daemon's process, then systemd's restart RestartSec later."""

    needs_process = True
    lockstep_only = True
    signal_name = "?"

    def __init__(self, *args: Any, **kw: Any) -> None:
        super().__init__(*args, **kw)
        self.restart_ms = self.at_ms + round(restart_sec() * 1000)
        self.watch = _StopWatch()
        self.back = _Return(self.restart_ms, "the daemon restarted")
        self.exits_before: int | None = None
        self.exit: Any = None  # sim.fullstack.daemon_process.Exit

    @property
    def span_ms(self) -> int:
        return self.restart_ms - self.at_ms + round((RECONNECT_S + SETTLE_S) * 1000)

    def signal(self, m: RunningMatch) -> None:
        raise NotImplementedError

    def before_tick(self, m: RunningMatch) -> None:
        if self.due(m, self.at_ms):
            self.exits_before = len(m.jetson.exits)
            self.signal(m)
            self.watch.start(m)
            m.replay.event(self.at_ms / 1000, f"{self.signal_name} to the daemon")
        elif self.due(m, self.restart_ms):
            m.restart_daemon()
            m.replay.event(self.restart_ms / 1000, "systemd restarts the daemon")

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        t = m.step_match_ms(report)
        before = self.exits_before
        if self.exit is None and before is not None and len(m.jetson.exits) > before:
            self.exit = m.jetson.exits[before]
        if t < self.restart_ms:
            self.watch.note(
                report, m.brain_track.age_ms(report), m.brain_track.applies_stop(report)
            )
        else:
            self.back.note(m, t, report)

    def own_checks(self, m: RunningMatch) -> list[Check]:
        return [
            self.watch.check(self.window_ms, f"the {self.signal_name}"),
            self.watch.stays_stopped("while the daemon was down"),
            self.back.check(),
        ]

    def measures(self, m: RunningMatch) -> dict[str, Any]:
        ex = self.exit
        return {
            **self.watch.measures(),
            "reconnect_ms": self.back.took_ms,
            "exit_s": None if ex is None else ex.exit_s,
        }


class JetsonSigterm(_Restart):
    name = "jetson-sigterm"
    signal_name = "SIGTERM"

    def signal(self, m: RunningMatch) -> None:
        self.delay_s = float(self.rng.uniform(0.0, SIGTERM_SPREAD_S))
        m.jetson.sigterm(self.delay_s)

    def own_checks(self, m: RunningMatch) -> list[Check]:
        ex = self.exit
        if ex is None:
            exit_check = Check("exits_in_time", False, "the daemon never exited")
            stop_check = Check("sends_stop", False, "the daemon never exited")
        else:
            how = "killed by the stop timeout, as systemd would" if ex.forced else "exited"
            exit_check = Check(
                "exits_in_time",
                not ex.forced and ex.exit_s is not None and ex.exit_s <= EXIT_S,
                f"the daemon {how} {ex.exit_s:.3f} s after the SIGTERM (limit {EXIT_S:g} s; "
                f"status {ex.returncode})",
            )
            stop_check = Check(
                "sends_stop",
                ex.said_bye and ex.stop_sent,
                "it sent a stop Command to the connected Brain before exiting"
                if ex.stop_sent
                else "it exited without sending a stop Command"
                + ("" if ex.said_bye else " (it never ran its shutdown)"),
            )
        return [exit_check, stop_check, *super().own_checks(m)]

    def measures(self, m: RunningMatch) -> dict[str, Any]:
        ex = self.exit
        return {
            **super().measures(m),
            "signal_delay_ms": round(self.delay_s * 1e3, 3) if hasattr(self, "delay_s") else None,
            "stop_sent": None if ex is None else ex.stop_sent,
            "forced": None if ex is None else ex.forced,
            "answered_turn": None if ex is None else ex.answered_turn,
        }


class JetsonSigkill(_Restart):
    name = "jetson-sigkill"
    signal_name = "SIGKILL"

    def signal(self, m: RunningMatch) -> None:
        m.jetson.kill()


class DiskFull(Scenario):
    name = "disk-full"
    needs_process = True
    needs_record = True
    lockstep_only = True
    window_s = 5.0

    def __init__(self, *args: Any, **kw: Any) -> None:
        super().__init__(*args, **kw)
        self.end_ms = None if self.duration_ms is None else self.at_ms + self.duration_ms
        self.at_clock: float | None = None
        self.end_clock: float | None = None
        self.steps = 0
        self.jetson_steps = 0

    @property
    def span_ms(self) -> int:
        return (self.duration_ms or 0) + round(SETTLE_S * 1000)

    def before_tick(self, m: RunningMatch) -> None:
        if self.due(m, self.at_ms):
            self.at_clock = m.clock.now()
            m.jetson.set_disk_full(True)
            m.replay.event(self.at_ms / 1000, "the daemon's disk is full")
        elif self.end_ms is not None and self.due(m, self.end_ms):
            self.end_clock = m.clock.now()
            m.jetson.set_disk_full(False)
            m.replay.event(self.end_ms / 1000, "disk space freed")

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        t = m.step_match_ms(report)
        if t > self.at_ms and (self.end_ms is None or t < self.end_ms):
            self.steps += 1
            self.jetson_steps += report.source == "jetson"

    def _lines(self, m: RunningMatch) -> list[dict[str, Any]]:
        """The daemon's log lines about its recording or its disk while the disk was full."""
        if self.at_clock is None:
            return []
        hi = math.inf if self.end_ms is None else self.at_clock + self.span_ms / 1000
        out = []
        for e in _log(m):
            t = float(e.get("t") or 0.0)
            text = f"{e.get('event', '')} {e.get('msg', '')}".lower()
            if self.at_clock - 1e-9 <= t <= hi and ("record" in text or "disk" in text):
                out.append(e)
        return out

    def _recording_before(self, m: RunningMatch) -> bool:
        """Whether the daemon was recording when the disk filled: a recording paused by an
        earlier failure starts again only with the next Brain session, so there is nothing to
        fail (nor to say) until then."""
        state = False
        for e in _log(m):
            if self.at_clock is not None and float(e.get("t") or 0.0) >= self.at_clock:
                break
            if e.get("event") in ("recording", "start"):
                state = e.get("event") == "recording"  # a new process records afresh
            elif e.get("event") == "record_paused":
                state = False
        return state

    def own_checks(self, m: RunningMatch) -> list[Check]:
        share = _share(self.steps, self.jetson_steps)
        lo = math.inf if self.at_clock is None else self.at_clock
        hi = math.inf if self.end_clock is None else self.end_clock
        died = sum(lo <= e.sim_s <= hi for e in m.jetson.exits if e.how != "quit")
        lines = self._lines(m)
        recording = self._recording_before(m)
        return [
            Check(
                "keeps_driving",
                self.steps > 0 and share >= 0.95,
                f"the Brain obeyed the Jetson {share:.0%} of the time with the disk full "
                "(at least 95 %)",
            ),
            Check(
                "daemon_lives",
                self.at_clock is not None and died == 0,
                f"daemon processes that ended while the disk was full: {died}",
            ),
            Check(
                "logs_it",
                (1 if recording else 0) <= len(lines) <= 3,
                f"daemon log lines about the recording or the disk: {len(lines)} "
                + ("(1 to 3)" if recording else "(at most 3: its recording was already paused)")
                + (f"; e.g. {lines[0].get('msg', '')[:120]!r}" if lines else ""),
            ),
        ]

    def measures(self, m: RunningMatch) -> dict[str, Any]:
        share = _share(self.steps, self.jetson_steps)
        lines = len(self._lines(m))
        return {
            "jetson_share": share,
            "log_lines": lines,
            "was_recording": self._recording_before(m),
        }


class BrainReboot(Scenario):
    name = "brain-reboot"
    lockstep_only = True

    def __init__(self, *args: Any, **kw: Any) -> None:
        super().__init__(*args, **kw)
        self.boot_ms = self.at_ms + round(REBOOT_S * 1000)
        self.boot_id = int(self.rng.integers(1, 2**32))
        self.back = _Return(self.boot_ms, "the Brain came back")
        self.boot_clock: float | None = None
        self.moving_while_off = 0

    @property
    def span_ms(self) -> int:
        return round((REBOOT_S + RECONNECT_S + SETTLE_S) * 1000)

    def before_tick(self, m: RunningMatch) -> None:
        if self.due(m, self.at_ms):
            m.power_off_brain()
            m.replay.event(self.at_ms / 1000, "the Brain reboots")
        elif self.due(m, self.boot_ms):
            m.boot_brain(self.boot_id)
            self.boot_clock = m.clock.now()
            m.replay.event(self.boot_ms / 1000, f"the Brain is back (boot {self.boot_id:08X})")

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        t = m.step_match_ms(report)
        if self.at_ms <= t < self.boot_ms:
            self.moving_while_off += report.moving
        self.back.note(m, t, report)

    def own_checks(self, m: RunningMatch) -> list[Check]:
        boot = f"{self.boot_id:08X}"
        seen = [
            e
            for e in _log(m)
            if e.get("brain_boot_id") == boot and e.get("event") in ("brain_restart", "link_up")
        ]
        return [
            Check(
                "stops",
                self.moving_while_off == 0,
                f"steps the motors were driven while the Brain was down: {self.moving_while_off}",
            ),
            Check(
                "daemon_sees_new_boot",
                bool(seen),
                f"the daemon logged the Brain's new boot {boot}: "
                + (f"{seen[0]['event']} ({seen[0].get('msg', '')[:80]!r})" if seen else "no"),
            ),
            self.back.check(),
        ]

    def measures(self, m: RunningMatch) -> dict[str, Any]:
        return {"reconnect_ms": self.back.took_ms}


VEXLINK_NOTICE_S = 1.5  # the Brain's partner timeout (1 s) and status period (0.2 s), and slack


class VexlinkLost(Scenario):
    """The VEXlink radio between our Brain and the partner's stops carrying anything."""

    name = "vexlink-lost"
    lockstep_only = True

    def __init__(self, *args: Any, **kw: Any) -> None:
        super().__init__(*args, **kw)
        self.at_clock: float | None = None
        self.steps = [0, 0]  # match steps after the cut: ours, the partner's
        self.jetson_steps = [0, 0]

    @property
    def span_ms(self) -> int:
        return round((VEXLINK_NOTICE_S + SETTLE_S) * 1000)

    def before_tick(self, m: RunningMatch) -> None:
        if self.due(m, self.at_ms):
            if m.vexlink is None:
                raise MatchError("vexlink-lost cuts the radio between two Brains: --partner stack")
            m.vexlink.cut = True
            self.at_clock = m.clock.now()
            m.replay.event(self.at_ms / 1000, "VEXlink lost")

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        if self.at_clock is None or m.match_ms <= self.at_ms or m.partner is None:
            return
        for k, r in enumerate((report, m.partner.last_report)):
            if r is not None:
                self.steps[k] += 1
                self.jetson_steps[k] += r.source == "jetson"

    def _alone_after_s(self, log: list[dict[str, Any]]) -> float | None:
        """How long after the cut a daemon's log said it plays alone (None: it never did)."""
        if self.at_clock is None:
            return None
        for e in log:
            t = float(e.get("t") or 0.0)
            if (
                e.get("event") == "partner_link"
                and "playing alone" in str(e.get("msg"))
                and t >= self.at_clock - 1e-9
            ):
                return t - self.at_clock
        return None

    def _alone(self, m: RunningMatch) -> tuple[float | None, float | None]:
        return (
            self._alone_after_s(_log(m)),
            self._alone_after_s(read_log(Path(m.partner.log.name)) if m.partner else []),
        )

    def own_checks(self, m: RunningMatch) -> list[Check]:
        ours, theirs = self._alone(m)
        shares = [_share(n, j) for n, j in zip(self.steps, self.jetson_steps, strict=True)]
        said = ours is not None and theirs is not None
        late = said and max(ours or 0.0, theirs or 0.0) > VEXLINK_NOTICE_S
        return [
            Check(
                "both_play_alone",
                said and not late,
                "after the radio went silent: our daemon said it plays alone "
                + ("never" if ours is None else f"{ours:.2f} s later")
                + ", the partner's "
                + ("never" if theirs is None else f"{theirs:.2f} s later")
                + f" (within {VEXLINK_NOTICE_S:g} s)",
            ),
            Check(
                "both_drive_on",
                min(self.steps) > 0 and min(shares) >= 0.95,
                f"after the cut the Jetsons drove {shares[0]:.0%} (ours) and {shares[1]:.0%} "
                "(the partner's) of the time",
            ),
        ]

    def measures(self, m: RunningMatch) -> dict[str, Any]:
        ours, theirs = self._alone(m)
        pairs = zip(self.steps, self.jetson_steps, strict=True)
        return {"alone_after_s": [ours, theirs], "jetson_share": [_share(n, j) for n, j in pairs]}


class Schedule(Scenario):
    """Several faults in one match, in time order, none overlapping another's span."""

    name = "schedule"

    def __init__(self, parts: list[Scenario], match_s: float, valid_ms: int = 250) -> None:
        super().__init__(0.0, match_s, valid_ms)
        self.parts = sorted(parts, key=lambda p: p.at_ms)
        for p in self.parts:
            if isinstance(p, SchemaMismatch | JetsonKilled | VexlinkLost):
                raise MatchError(f"{p.name} lasts the whole match: it cannot be in a schedule")
        for a, b in zip(self.parts, self.parts[1:], strict=False):
            if a.at_ms + a.span_ms > b.at_ms:
                raise MatchError(
                    f"faults overlap: {a.label} lasts until {(a.at_ms + a.span_ms) / 1000:g} s, "
                    f"{b.label} starts before"
                )
        self.needs_process = any(p.needs_process for p in self.parts)
        self.needs_record = any(p.needs_record for p in self.parts)
        self.lockstep_only = any(p.lockstep_only for p in self.parts)

    def before_tick(self, m: RunningMatch) -> None:
        for p in self.parts:
            p.before_tick(m)

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        for p in self.parts:
            p.after_tick(m, report)

    def own_checks(self, m: RunningMatch) -> list[Check]:
        return [
            Check(f"{p.label} {c.name}", c.passed, c.detail) for p in self.parts
            for c in p.own_checks(m)
        ]  # fmt: skip

    def records(self, m: RunningMatch) -> list[dict[str, Any]]:
        return [r for p in self.parts for r in p.records(m)]


FAULTS: dict[str, type[Scenario]] = {
    c.name: c
    for c in (
        LinkCut, Corruption, JetsonKilled, SchemaMismatch, CameraStops, JetsonSigterm,
        JetsonSigkill, DiskFull, BrainReboot, VexlinkLost,
    )
}  # fmt: skip


def parse_schedule(text: str) -> tuple[tuple[str, float], ...]:
    """`--faults link-cut@10,jetson-sigterm@25.5` -> (("link-cut", 10.0), ...)."""
    out = []
    for item in text.split(","):
        name, sep, at = item.strip().partition("@")
        try:
            t = float(at)
        except ValueError:
            t = math.nan
        if not sep or not name or not math.isfinite(t):
            raise MatchError(f"a scheduled fault is NAME@SECONDS (e.g. link-cut@10), got {item!r}")
        out.append((name, t))
    return tuple(out)


def make_scenario(name: str | None, at_s: float | None, options: MatchOptions) -> Scenario:
    """The scenario for --fault NAME (None: no fault), or for the schedule options.faults, in a
    match of these options."""
    match_s = options.seconds if options.seconds is not None else 105.0
    match_s = min(match_s, 105.0)
    try:
        if options.faults:
            if name is not None:
                raise MatchError("give one --fault or a --faults schedule, not both")
            parts = [_make(n, t, options, match_s, scheduled=True) for n, t in options.faults]
            scenario: Scenario = Schedule(parts, match_s)
        elif name is None:
            return Scenario(at_s, match_s, seed=options.seed)
        else:
            scenario = _make(name, at_s, options, match_s, scheduled=False)
    except ValueError as exc:
        raise MatchError(str(exc)) from exc
    if scenario.needs_record and not options.record:
        raise MatchError("the disk-full fault fills the recording's disk: add --record")
    if scenario.lockstep_only and options.realtime:
        raise MatchError(f"{scenario.name}: this fault runs in lockstep only (drop --realtime)")
    scenario.daemon_mode(options)  # refuses a daemon in this process for a fault that needs one
    return scenario


def _make(
    name: str, at_s: float | None, options: MatchOptions, match_s: float, scheduled: bool
) -> Scenario:
    if name not in FAULTS:
        raise MatchError(f"unknown fault {name!r}; choose from {', '.join(FAULTS)}")
    if name == "camera-stops" and not options.camera:
        raise MatchError("the camera-stops fault needs the camera (drop --no-camera)")
    if name == "vexlink-lost" and options.partner != "stack":
        raise MatchError(
            "the vexlink-lost fault cuts the radio between our Brain and the partner's: "
            "--world tipping_point_2v2 --partner stack"
        )
    cls = FAULTS[name]
    duration = cls.window_s if scheduled else None
    return cls(at_s, match_s, seed=options.seed, duration_s=duration)
