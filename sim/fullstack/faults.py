"""Fault scenarios for the full-stack match (`pete-sim match --fault NAME`), each with the checks
that say whether the robot behaved as promised.

    link-cut         the USB cable is pulled for 2 s: the Brain stops within the Command validity
                     window, the daemon notices, reopens the port when it comes back, and drives on
    corruption       1 % of bytes corrupted in each direction (a random bit of each hit byte): no
                     damaged message is ever acted on, errors are counted, the match goes on
    jetson-killed    the daemon dies (SIGKILL: no stop Command): the Brain stops within the
                     validity window and stays stopped; driver control still works
    schema-mismatch  the Jetson was built from another schema: the robot never moves, and both
                     sides log why
    camera-stops     the camera stops delivering frames: the daemon keeps commanding as the policy
                     was trained to for no rings in view, and logs it

Every full-stack match, with a fault or without, also checks that nothing the cable delivered
differed from what was sent (a damaged message passing every check would be a protocol bug).
"""

from __future__ import annotations

import json
import math
from pathlib import Path
from typing import TYPE_CHECKING, Any

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


class Scenario:
    """No fault. Subclasses hook the match before and after each 10 ms step."""

    name = "none"
    default_at_fraction = 1 / 3

    def __init__(self, at_s: float | None, match_s: float, valid_ms: int = 250) -> None:
        at = match_s * self.default_at_fraction if at_s is None else at_s
        if not 0 <= at < match_s:
            raise ValueError(f"fault time {at:g} s must fall within the match (0 .. {match_s:g} s)")
        self.at_ms = round(at * 100) * 10
        self.valid_ms = valid_ms
        self.window_ms = valid_ms + LOOP_MS  # validity, plus the loop step that notices
        self.fired = False

    def jetson_fingerprint(self) -> int:
        return messages.FINGERPRINT

    def due(self, m: RunningMatch, at_ms: int) -> bool:
        return m.match_ms == at_ms

    def before_tick(self, m: RunningMatch) -> None:
        pass

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        pass

    def checks(self, m: RunningMatch) -> list[Check]:
        up, down = m.cable.up, m.cable.down
        return [
            Check(
                "integrity",
                up.altered == 0 and down.altered == 0,
                f"messages delivered that were not sent as they arrived: up {up.altered}, "
                f"down {down.altered} (must be 0)",
            )
        ]


class _StopWatch:
    """How long after an event the Brain stopped driving from the Jetson, both read on
    brain_host's own clock (in realtime the simulator's ticks may lag it)."""

    def __init__(self) -> None:
        self.event_ms: int | None = None  # brain_host's clock at the event
        self.stopped_ms: int | None = None  # ...at the first step not driven by the Jetson
        self.jetson_after_stop = 0  # steps the Jetson drove again afterwards

    def start(self, m: RunningMatch) -> None:
        self.event_ms = m.brain_now_ms()

    def note(self, report: BrainReport) -> None:
        if self.event_ms is None or report.last_step_ms < self.event_ms:
            return
        if self.stopped_ms is None:
            if report.source != "jetson":
                self.stopped_ms = report.last_step_ms
        elif report.source == "jetson":
            self.jetson_after_stop += 1

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
        return Check(
            "stops_in_time",
            took <= limit,
            f"the Brain stopped driving {took} ms after {what} (limit: {limit} ms, {why})",
        )


class LinkCut(Scenario):
    name = "link-cut"

    def __init__(self, at_s: float | None, match_s: float, valid_ms: int = 250) -> None:
        super().__init__(at_s, match_s, valid_ms)
        self.back_ms = self.at_ms + round(CUT_S * 1000)
        self.watch = _StopWatch()
        self.resumed_ms: int | None = None

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
            self.watch.note(report)
        elif self.resumed_ms is None and report.source == "jetson":
            self.resumed_ms = t
            m.replay.event(t / 1000, "Jetson drives again")

    def checks(self, m: RunningMatch) -> list[Check]:
        d = m.jetson.daemon.counters
        out = [
            *super().checks(m),
            self.watch.check(self.window_ms, "the cable was pulled", m.realtime),
        ]
        out.append(
            Check(
                "stays_stopped",
                self.watch.jetson_after_stop == 0,
                f"steps the Jetson drove while the cable was out: {self.watch.jetson_after_stop}",
            )
        )
        out.append(
            Check(
                "daemon_reconnects",
                d.disconnects >= 1 and d.connects >= 2,
                f"the daemon saw the port go {d.disconnects} time(s) and opened it {d.connects} "
                "time(s)",
            )
        )
        resumed = self.resumed_ms
        took = None if resumed is None else resumed - self.back_ms
        out.append(
            Check(
                "match_goes_on",
                resumed is not None and m.world.time_s * 1000 >= m.match_len_ms - 10,
                "the Jetson never drove again"
                if took is None
                else f"the Jetson drove again {took} ms after the cable came back; the match "
                f"ran to {m.world.time_s:.1f} s",
            )
        )
        return out


class Corruption(Scenario):
    name = "corruption"
    default_at_fraction = 0.0

    def __init__(self, at_s: float | None, match_s: float, valid_ms: int = 250) -> None:
        super().__init__(at_s, match_s, valid_ms)
        self.steps_after = 0
        self.jetson_steps_after = 0
        self.link_error_steps = 0

    def before_tick(self, m: RunningMatch) -> None:
        if self.due(m, self.at_ms):
            m.cable.set_corruption(CORRUPTION, CORRUPTION)
            m.replay.event(self.at_ms / 1000, f"{CORRUPTION:.0%} of bytes corrupted both ways")

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        t = m.step_match_ms(report)
        if t >= self.at_ms + 1000:  # a second to settle: then the Jetson must keep driving
            self.steps_after += 1
            self.jetson_steps_after += report.source == "jetson"
        if "link_errors" in report.faults:
            self.link_error_steps += 1

    def checks(self, m: RunningMatch) -> list[Check]:
        up, down = m.cable.up, m.cable.down
        share = self.jetson_steps_after / self.steps_after if self.steps_after else 0.0
        return [
            *super().checks(m),
            Check(
                "errors_counted",
                up.rejected > 0 and down.rejected > 0 and self.link_error_steps > 0,
                f"frames refused: Brain -> Jetson {up.rejected}, Jetson -> Brain {down.rejected}; "
                f"the Brain reported link_errors in {self.link_error_steps} steps",
            ),
            Check(
                "match_goes_on",
                self.steps_after > 0 and share >= 0.9,
                f"the Jetson drove {share:.0%} of the time after the first second of corruption "
                "(at least 90 %)",
            ),
        ]


class JetsonKilled(Scenario):
    name = "jetson-killed"

    def __init__(self, at_s: float | None, match_s: float, valid_ms: int = 250) -> None:
        super().__init__(at_s, match_s, valid_ms)
        self.sticks_on_ms = self.at_ms + round(STICKS_AFTER_KILL_S * 1000)
        self.sticks_off_ms = self.sticks_on_ms + round(STICKS_FOR_S * 1000)
        self.watch = _StopWatch()
        self.driver_steps = 0
        self.pose_at_sticks: tuple[float, float] | None = None
        self.driver_moved_m = 0.0

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
            self.watch.note(report)
        if self.sticks_on_ms <= t < self.sticks_off_ms and report.source == "driver":
            self.driver_steps += report.moving

    def checks(self, m: RunningMatch) -> list[Check]:
        driver_ok = self.driver_steps > 0 and self.driver_moved_m > 0.05
        return [
            *super().checks(m),
            self.watch.check(self.window_ms, "the Jetson died", m.realtime),
            Check(
                "stays_stopped",
                self.watch.jetson_after_stop == 0,
                f"steps the dead Jetson's Commands drove: {self.watch.jetson_after_stop}",
            ),
            Check(
                "driver_control_works",
                driver_ok,
                f"with the stick pushed the Brain drove {self.driver_steps} steps and the robot "
                f"moved {self.driver_moved_m:.2f} m",
            ),
        ]


class SchemaMismatch(Scenario):
    name = "schema-mismatch"
    default_at_fraction = 0.0

    def __init__(self, at_s: float | None, match_s: float, valid_ms: int = 250) -> None:
        super().__init__(at_s, match_s, valid_ms)
        self.start: tuple[float, float] | None = None
        self.moving_steps = 0

    def jetson_fingerprint(self) -> int:
        return OTHER_FINGERPRINT

    def before_tick(self, m: RunningMatch) -> None:
        if self.start is None:
            r = m.world.robots[m.ia]
            self.start = (r.x, r.y)

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        self.moving_steps += report.moving

    def checks(self, m: RunningMatch) -> list[Check]:
        r = m.world.robots[m.ia]
        assert self.start is not None
        moved = math.hypot(r.x - self.start[0], r.y - self.start[1])
        log = read_log(m.folder / "daemon.jsonl")
        jetson_says = [e for e in log if e.get("event") == "fingerprint_mismatch"]
        brain_says = [
            e
            for e in log
            if e.get("event") == "brain_log" and "fingerprint mismatch" in str(e.get("msg", ""))
        ]
        links = m.brain_track.link_states
        return [
            *super().checks(m),
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

    def __init__(self, at_s: float | None, match_s: float, valid_ms: int = 250) -> None:
        super().__init__(at_s, match_s, valid_ms)
        self.applied_at_stop: int | None = None
        self.at_clock: float | None = None
        self.steps_after = 0
        self.jetson_steps_after = 0

    def before_tick(self, m: RunningMatch) -> None:
        if self.due(m, self.at_ms) and m.server is not None:
            # The daemon's clock when it happened (its log's `t`): in lockstep the previous
            # step's time, in realtime the wall clock's.
            self.at_clock = m.clock.now()
            m.camera_stopped = True
            m.server.close()
            m.jetson.drop_pending_frames()
            self.applied_at_stop = m.brain_track.applied
            m.replay.event(self.at_ms / 1000, "camera stops")

    def after_tick(self, m: RunningMatch, report: BrainReport) -> None:
        t = m.step_match_ms(report)
        if self.applied_at_stop is not None and t > self.at_ms:
            self.steps_after += 1
            self.jetson_steps_after += report.source == "jetson"

    def checks(self, m: RunningMatch) -> list[Check]:
        log = read_log(m.folder / "daemon.jsonl")
        at = self.at_clock if self.at_clock is not None else math.inf
        after = [e for e in log if float(e.get("t") or 0.0) >= at - 1e-9]
        blind = [e for e in after if e.get("event") == "perception" and e.get("level") == "warning"]
        camera = [e for e in after if e.get("event") in ("camera_end", "camera_error")]
        applied = m.brain_track.applied - (self.applied_at_stop or 0)
        share = self.jetson_steps_after / self.steps_after if self.steps_after else 0.0
        return [
            *super().checks(m),
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


FAULTS: dict[str, type[Scenario]] = {
    c.name: c for c in (LinkCut, Corruption, JetsonKilled, SchemaMismatch, CameraStops)
}


def make_scenario(name: str | None, at_s: float | None, options: MatchOptions) -> Scenario:
    """The scenario for --fault NAME (None: no fault) in a match of these options."""
    match_s = options.seconds if options.seconds is not None else 105.0
    match_s = min(match_s, 105.0)
    try:
        if name is None:
            return Scenario(at_s, match_s)
        if name not in FAULTS:
            raise MatchError(f"unknown fault {name!r}; choose from {', '.join(FAULTS)}")
        if name == "camera-stops" and not options.camera:
            raise MatchError("the camera-stops fault needs the camera (drop --no-camera)")
        return FAULTS[name](at_s, match_s)
    except ValueError as exc:
        raise MatchError(str(exc)) from exc
