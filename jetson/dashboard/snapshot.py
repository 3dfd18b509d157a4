"""What the dashboard shows, taken on the daemon's own thread and handed over without a lock.

The daemon (jetson.loop.Daemon) calls `Observer.turn()` at the end of every turn of its loop and
`Observer.brain_line()` for each line the Brain prints. A turn costs one attribute test unless
the dashboard's server has asked for a snapshot (`wanted`, set at the page's update rate while a
browser is connected): then the daemon builds one plain dict (JSON-ready) from its own state,
after its Command is on the wire, and publishes it by replacing one reference (`snapshot`). The
server's thread only ever reads that reference: nothing is shared that either side changes.

`state_snapshot()` and `field_view()` are also what `pete-jetson dashboard --recording` uses to
turn a recording's cycles into the same snapshots (jetson/dashboard/replay.py).
"""

from __future__ import annotations

import bisect
import itertools
import math
import time
from collections import deque
from dataclasses import dataclass
from typing import Any

import numpy as np

from jetson.autonomy.geometry import robot_to_field, to_alliance_frame
from protocol import messages
from protocol.messages import (
    Alliance,
    ClampAction,
    ClampState,
    Fault,
    GpsStatus,
    LiftAction,
    LiftState,
    MatchPeriod,
    MatchPhase,
    PoseFix,
)

FIELD_HALF_M = 1.8288  # half of the 12 ft field's side
LATENCY_WINDOW = 500  # the latest latencies the p50/p99 and the histogram are of (10 s at 50 Hz)
# The latency histogram's bin edges, ms (the last bin is "above 10 ms").
LATENCY_EDGES_MS = (0.0, 0.5, 1.0, 1.5, 2.0, 3.0, 5.0, 10.0)
FORGOTTEN_KEEP_S = 5.0  # how long a forgotten ring stays on the field view
BRAIN_LINES = 30  # the Brain's last lines in each snapshot


def _r(v: float, nd: int = 4) -> float | None:
    v = float(v)
    return round(v, nd) if math.isfinite(v) else None


def _points(xy: Any) -> list[list[float]]:
    a = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
    return [[round(float(x), 4), round(float(y), 4)] for x, y in a]


def percentile(sorted_values: list[float], q: float) -> float:
    if not sorted_values:
        return math.nan
    k = (len(sorted_values) - 1) * q / 100.0
    lo = math.floor(k)
    hi = min(lo + 1, len(sorted_values) - 1)
    return sorted_values[lo] + (sorted_values[hi] - sorted_values[lo]) * (k - lo)


def latency_view(latencies_s: list[float]) -> dict[str, Any]:
    """p50, p99, max (ms) and a histogram over LATENCY_EDGES_MS of the given latencies."""
    ms = sorted(x * 1e3 for x in latencies_s)
    cuts = [bisect.bisect_left(ms, e) for e in LATENCY_EDGES_MS[1:]]
    counts = [b - a for a, b in zip([0, *cuts], [*cuts, len(ms)], strict=True)]
    return {
        "n": len(ms),
        "p50_ms": _r(percentile(ms, 50)),
        "p99_ms": _r(percentile(ms, 99)),
        "max_ms": _r(ms[-1]) if ms else None,
        "edges_ms": list(LATENCY_EDGES_MS),
        "hist": counts,
    }


def alliance_name(state: Any) -> str | None:
    if state is None:
        return None
    return {Alliance.RED: "red", Alliance.BLUE: "blue"}.get(state.alliance)


def who_drives(state: Any, command: Any) -> str:
    """Who the Brain lets drive, as far as its State tells (brain/README.md, "What the robot does
    in each phase"): the Jetson while the Brain applies our newest Commands; in driver control
    otherwise the driver; else nobody."""
    if state is None or state.phase == MatchPhase.DISABLED:
        return "nobody"
    timed_out = bool(state.faults & Fault.COMMAND_TIMEOUT) or bool(
        state.faults & Fault.FINGERPRINT_MISMATCH
    )
    applied = (
        command is not None
        and state.last_command_seq != 0
        and 0 <= command.seq - state.last_command_seq <= 5
    )
    if applied and not timed_out:
        return "jetson"
    return "driver" if state.phase == MatchPhase.DRIVER else "nobody"


def state_snapshot(state: Any, command: Any, decision: Any) -> dict[str, Any]:
    """The match, the pose and the last Command (from one cycle's State, Command, Decision)."""
    out: dict[str, Any] = {"pose": None, "match": None, "command": None, "speeds": None}
    if state is not None:
        out["pose"] = {
            "x": _r(state.x), "y": _r(state.y), "heading": _r(state.heading, 2),
            "gps_status": GpsStatus(state.gps_status).name.lower(),
            "gps_error": _r(state.gps_error),
            # What the Brain's pose filter rests on, and how far it trusts it.
            "fix": PoseFix(state.pose_fix).name.lower(),
            "std": _r(state.pose_std), "heading_std": _r(state.heading_std, 2),
        }  # fmt: skip
        out["match"] = {
            "phase": MatchPhase(state.phase).name.lower(),
            "phase_ms": int(state.phase_ms),
            "period": MatchPeriod(state.period).name.lower(),
            "match_ms": int(state.match_ms),
            "time_ms": int(state.time_ms),
            "seq": int(state.seq),
            "alliance": alliance_name(state) or "unknown",
            "driver": who_drives(state, command),
            "faults": [f.name.lower() for f in Fault if f in Fault(state.faults)],
            "rings_held": int(state.rings_held),
            "goal_clamped": int(state.goal_clamped),
            "clamp": ClampState(state.clamp).name.lower(),
            "lift": LiftState(state.lift).name.lower(),
        }
        out["speeds"] = {"left": _r(state.left_speed), "right": _r(state.right_speed)}
    if command is not None:
        out["command"] = {
            "seq": int(command.seq),
            "linear": _r(command.linear),
            "angular": _r(command.angular),
            "intake": bool(command.intake),
            "clamp": ClampAction(command.clamp).name.lower(),
            "lift": LiftAction(command.lift).name.lower(),
            "valid_ms": int(command.valid_ms),
            "reason": getattr(decision, "reason", None),
            "perception": getattr(decision, "perception", None),
            "rings": getattr(decision, "rings", None),
        }
    return out


def _slot(f: np.ndarray, offset: int, unit: float) -> np.ndarray | None:
    s = f[offset : offset + 3]
    return None if s.size < 3 or s[2] <= 0 else s[:2] * unit


@dataclass(frozen=True)
class DecisionView:
    """References to what the decision knows after a cycle (arrays the decision replaces, never
    changes in place), taken on the daemon's thread and drawn anywhere (field_view)."""

    spec: Any
    skills: Any
    known_rings: Any  # alliance frame
    known_goals: Any
    holding: bool
    obs: Any
    action: Any
    commit: Any  # a committed goal manoeuvre's point, alliance frame
    # The option the skill controller drove and its target (SkillDriver.driven and .target:
    # kind, robot-frame point); None: not known (the scores' best is shown).
    driven: Any = None
    target: Any = None

    @classmethod
    def of(cls, decider: Any) -> DecisionView:
        driver = decider.skill_driver
        return cls(
            decider.spec, getattr(decider.policy, "skills", None), decider.ring_memory.known,
            decider.goal_memory.known, decider.goal_memory.holding, decider.last_obs,
            decider.last_action, getattr(driver, "_commit_point", None),
            getattr(driver, "driven", None), getattr(driver, "target", None),
        )  # fmt: skip


def field_view(decider: Any, state: Any, seen_robot_xy: Any = None) -> dict[str, Any]:
    """The decision's picture of the field, in the field frame (GPS, metres): the rings seen in
    the last camera result, the rings remembered, the goals remembered, the chosen skill and its
    target, and the path (robot -> target, and the route's stops). `decider`: a DecisionView
    (or a jetson.decide.Decider, read at once)."""
    out: dict[str, Any] = {
        "seen": [], "remembered": [], "goals": [], "holding": False, "memory": False,
        "goal_memory": False, "skill": None, "target": None, "path": [], "route": [],
    }  # fmt: skip
    alliance = alliance_name(state)
    if decider is None or state is None or alliance is None:
        return out
    if not isinstance(decider, DecisionView):
        decider = DecisionView.of(decider)
    spec = decider.spec
    pose = (float(state.x), float(state.y))
    heading = float(state.heading)
    seen = np.zeros((0, 2))
    if seen_robot_xy is not None and len(seen_robot_xy):
        seen = robot_to_field(np.asarray(seen_robot_xy, dtype=np.float64), pose, heading)
    out["seen"] = _points(seen)
    if spec.ring_memory:
        out["memory"] = True
        known = to_alliance_frame(decider.known_rings, None, alliance)[0]
        if len(seen) and len(known):
            d = np.linalg.norm(known[:, None, :] - seen[None, :, :], axis=2)
            known = known[d.min(axis=1) > spec.memory_merge_m]
        out["remembered"] = _points(known)
    if spec.goal_memory:
        out["goal_memory"] = True
        out["goals"] = _points(to_alliance_frame(decider.known_goals, None, alliance)[0])
        out["holding"] = bool(decider.holding)
    obs, action = decider.obs, decider.action
    if obs is None:
        return out
    f = np.asarray(obs, dtype=np.float64)[: spec.frame_size]
    unit = spec.length_unit_m
    stops = []
    for i in range(spec.route_slots):
        local = _slot(f, spec.route_offset + 3 * i, unit)
        if local is not None:
            stops.append(local)
    if stops:
        out["route"] = _points(robot_to_field(np.array(stops), pose, heading))
    skills = decider.skills
    if skills is None or action is None:
        out["skill"] = "direct drive"
        return out
    a = np.asarray(action, dtype=np.float64).reshape(-1)
    names = skills.option_names()
    # Not np.argmax: it lets go of the interpreter lock, and taking it back behind the camera
    # thread costs the daemon's thread up to a switch interval.
    scores = a[: skills.n_options].tolist()
    k = scores.index(max(scores)) if decider.driven is None else decider.driven
    name = names[k]
    target = None
    commit = decider.commit
    if commit is not None:
        name = "goal (committed)"
        target = to_alliance_frame(np.asarray(commit), None, alliance)[0]
    elif decider.target is not None and decider.driven is not None:
        # Where the controller drove (a platform lane's point, a ring left to the partner).
        target = robot_to_field(np.array([decider.target[1]]), pose, heading)[0]
    elif name == "route":
        local = _slot(f, spec.route_offset, unit)
        target = None if local is None else robot_to_field(local[None, :], pose, heading)[0]
    elif name.startswith("ring"):
        local = _slot(f, spec.ring_offset + 3 * int(name[4:]), unit)
        target = None if local is None else robot_to_field(local[None, :], pose, heading)[0]
    elif name.startswith("goal"):
        local = _slot(f, spec.goal_offset + 3 * int(name[4:]), unit)
        target = None if local is None else robot_to_field(local[None, :], pose, heading)[0]
    elif name == "platform":
        cx, cy = skills.platform_box[:2]
        target = to_alliance_frame(np.array([cx, cy]), None, alliance)[0]
    out["skill"] = name
    if target is not None:
        out["target"] = _points(target)[0]
        path = [list(pose), out["target"]]
        if name == "route" and len(out["route"]) > 1:
            path += out["route"][1:]
        out["path"] = [[round(x, 4), round(y, 4)] for x, y in path]
    return out


def coded_field(rows_robot: np.ndarray, state: Any) -> list[list[float]]:
    """Points with a code, (N, 3) x, y robot frame and code -> [x, y, code] in the field frame
    (GPS, metres), from the State's pose."""
    if not len(rows_robot):
        return []
    xy = robot_to_field(rows_robot[:, :2], (float(state.x), float(state.y)), float(state.heading))
    return [
        [round(float(x), 3), round(float(y), 3), int(c)]
        for (x, y), c in zip(xy, rows_robot[:, 2], strict=True)
    ]


def goals_field(goals_robot: np.ndarray, state: Any) -> list[list[float]]:
    """Goals (robot frame, colour code) -> [x, y, colour code] in the field frame (GPS, metres)."""
    return coded_field(goals_robot, state)


def robots_field(robots_robot: np.ndarray, state: Any) -> list[list[float]]:
    """Robots the camera saw (robot frame, alliance code: jetson.perception.robots) -> [x, y,
    alliance code] in the field frame (GPS, metres)."""
    return coded_field(robots_robot, state)


def claim_view(claim: Any) -> dict[str, Any] | None:
    """The target this robot claims for its partner (jetson.partner.Claim): its kind and where
    (field frame); None when it claims nothing."""
    if claim is None or claim.target == messages.TargetKind.NOTHING:
        return None
    return {
        "target": messages.TargetKind(claim.target).name.lower(),
        "xy": [round(float(claim.xy[0]), 3), round(float(claim.xy[1]), 3)],
    }


def partner_view(partner: Any, status: Any, match_ms: int | None) -> dict[str, Any] | None:
    """The alliance partner as this robot hears it over VEXlink (jetson.partner): the link's
    state and counts (the Brain's PartnerStatus), and the partner's newest report: its pose,
    what it holds and carries, and the target it claims (field frame, metres). None when the
    Brain has reported no partner link at all."""
    if status is None and partner is None:
        return None
    out: dict[str, Any] = {"link": None, "age_ms": None, "report": None}
    if status is not None:
        out.update(
            link=status.link.name.lower(),
            age_ms=None if status.age_ms == 0xFFFF else int(status.age_ms),
            received=int(status.received),
            sent=int(status.sent),
            busy=int(status.busy),
            lost=int(status.lost),
            errors=int(status.errors),
        )
    if partner is not None:
        flags = messages.PartnerFlags(partner.flags)
        posed = messages.PartnerFlags.POSE_OK in flags
        target = messages.TargetKind(partner.target)
        out["report"] = {
            "pose": [partner.x_mm / 1000.0, partner.y_mm / 1000.0, partner.heading_cdeg / 100.0]
            if posed
            else None,
            "holding": messages.PartnerFlags.HOLDING_GOAL in flags,
            "on_platform": messages.PartnerFlags.ON_PLATFORM in flags,
            "driving": messages.PartnerFlags.DRIVING in flags,
            "alone": messages.PartnerFlags.ALONE in flags,
            "rings": None if partner.rings == 255 else int(partner.rings),
            "target": target.name.lower(),
            "target_xy": None
            if target == messages.TargetKind.NOTHING
            else [partner.target_x_mm / 1000.0, partner.target_y_mm / 1000.0],
            # How old the report is by the two robots' match clocks (both follow field control).
            "delay_ms": None if match_ms is None else int(match_ms) - int(partner.match_ms),
        }
    return out


class Forgetting:
    """Rings the memory knew at the last snapshot and no longer does: shown fading for
    FORGOTTEN_KEEP_S. Fed each snapshot's remembered and seen rings."""

    def __init__(self, merge_m: float = 0.12) -> None:
        self.merge_m = merge_m
        self._known = np.zeros((0, 2))
        self.forgotten: deque[tuple[float, float, float]] = deque(maxlen=200)

    def reset(self) -> None:
        self._known = np.zeros((0, 2))
        self.forgotten.clear()

    def update(self, t: float, field: dict[str, Any]) -> list[list[float]]:
        now = np.asarray(field["remembered"] + field["seen"], dtype=np.float64).reshape(-1, 2)
        prev = self._known
        if len(prev):
            if len(now):
                d = np.linalg.norm(prev[:, None, :] - now[None, :, :], axis=2).min(axis=1)
                gone = prev[d > self.merge_m]
            else:
                gone = prev
            for x, y in gone:
                self.forgotten.append((t, float(x), float(y)))
        self._known = now
        while self.forgotten and (t - self.forgotten[0][0] > FORGOTTEN_KEEP_S or t < 0):
            self.forgotten.popleft()
        return [[round(x, 4), round(y, 4), round(t - t0, 2)] for t0, x, y in self.forgotten]


class Observer:
    """The daemon's side of the dashboard (see the module docstring).

    On the daemon's thread, take() copies references and numbers only (a few microseconds: no
    geometry, no JSON); render() turns that into the page's snapshot on the server's thread.
    Written by the daemon's thread: `snapshot` (replaced whole), `brain_lines`. Written by the
    server's thread: `wanted`. Each is one reference or one bool: no lock is needed or taken."""

    def __init__(self, bridge: Any = None) -> None:
        # `bridge`: the dashboard's process's shared slots (jetson/dashboard/bridge.py); None
        # when the server runs in this process and reads `snapshot` itself.
        self.bridge = bridge
        self.wanted = False
        self.snapshot: dict[str, Any] | None = None  # the newest taken (not yet rendered)
        self.snapshots = 0
        self.errors = 0
        self.last_error: str | None = None
        self.build_s = 0.0  # daemon-thread time spent taking snapshots, in total
        self.post_s = 0.0  # ... and taking and handing them to the dashboard's process
        self.brain_lines: deque[list[Any]] = deque(maxlen=BRAIN_LINES)
        self.lines_total = 0
        self._forgetting: Forgetting | None = None
        self._boot: int | None = None

    # --- called by the daemon's thread -----------------------------------------------------

    def turn(self, daemon: Any) -> None:
        """The end of one turn of the daemon's loop: a snapshot if one is wanted."""
        bridge = self.bridge
        if self.wanted or (bridge is not None and bridge.wanted.take()):
            self.wanted = False
            self.publish(daemon)

    def publish(self, daemon: Any) -> dict[str, Any] | None:
        """Take and publish a snapshot now (on the daemon's thread: a lockstep simulator or a
        test may call it between two turns). Never raises."""
        t0 = time.perf_counter()
        try:
            snap = self.take(daemon)
        except Exception as exc:  # the dashboard must never cost the robot a Command
            self.errors += 1
            self.last_error = f"{type(exc).__name__}: {exc}"
            return None
        finally:
            self.build_s += time.perf_counter() - t0
        self.snapshot = snap
        if self.bridge is not None:
            snap["observer"] = self.counters()
            try:
                self.bridge.post_snapshot(snap)
            except Exception as exc:  # a snapshot that cannot be pickled is a dashboard bug
                self.errors += 1
                self.last_error = f"{type(exc).__name__}: {exc}"
            self.post_s += time.perf_counter() - t0
        return snap

    def counters(self) -> dict[str, Any]:
        """What the dashboard reports of the daemon's side (the page's Jetson panel)."""
        return {
            "snapshots": self.snapshots,
            "errors": self.errors,
            "build_ms_total": round(self.build_s * 1e3, 2),
            "post_ms_total": round(self.post_s * 1e3, 2),
        }

    def brain_line(self, t: float, level: str, text: str) -> None:
        self.lines_total += 1
        self.brain_lines.append([round(t, 3), level, text[:300], self.lines_total])

    def take(self, daemon: Any) -> dict[str, Any]:
        """References and numbers, on the daemon's thread."""
        c = daemon.counters
        decoder = daemon.decoder.stats
        hs = daemon.handshake
        frames = daemon.frames
        newest = frames.newest if frames is not None else None
        recorder = daemon.recorder
        self.snapshots += 1
        return {
            "n": self.snapshots,
            "t": daemon.clock.now(),
            "wall": time.time(),
            "state": daemon.last_state,
            "command": daemon.last_command,
            "decision": daemon.last_decision,
            "view": DecisionView.of(daemon.decider),
            "perceived": daemon.last_perceived,
            "has_camera": daemon.perception is not None,
            "frame_id": None if newest is None else newest.id,
            "recording": None if recorder is None else str(recorder.path),
            "latencies": list(itertools.islice(reversed(daemon.latency.recent), LATENCY_WINDOW)),
            "brain_lines": list(self.brain_lines),
            "partner": daemon.partner,
            "partner_status": daemon.partner_status,
            # What our robot claims for its partner now (jetson.partner): cheap, on this thread.
            "claim": None if daemon.last_state is None else daemon.decider.claim(daemon.last_state),
            "link": {
                "state": daemon.state,
                "connected": daemon.link is not None,
                "up": hs.up,
                "port": daemon.locator.describe(),
                "ours": hs.fingerprint,
                "brain": hs.brain_fingerprint,
                "jetson_boot": hs.boot_id,
                "brain_boot": hs.brain_boot_id,
                "rx_bytes": daemon.rx_bytes,
                "tx_bytes": daemon.tx_bytes,
                "received": c.received + decoder.received,
                "lost": c.lost + decoder.lost,
                "states": c.states,
                "commands": c.commands,
                "stops": c.stops,
                "skipped": c.states_skipped,
                "unverified": c.states_unverified,
                "connects": c.connects,
                "disconnects": c.disconnects,
                "tx_dropped": c.tx_dropped,
                "decision_errors": c.errors,
                "errors": daemon.link_errors(),
            },
        }

    # --- called by the server's thread -----------------------------------------------------

    def render(self, raw: dict[str, Any]) -> dict[str, Any]:
        """The page's snapshot (JSON-ready) from one take(); call it once per snapshot, in
        order (it follows which rings were forgotten from one to the next)."""
        link = dict(raw["link"])
        for key in ("ours", "brain", "jetson_boot", "brain_boot"):
            link[key] = None if link[key] is None else f"{link[key]:08X}"
        link["latency"] = latency_view(raw["latencies"])
        view: DecisionView = raw["view"]
        if link["brain_boot"] != self._boot or self._forgetting is None:
            self._boot = link["brain_boot"]
            self._forgetting = Forgetting(view.spec.memory_merge_m)
        state, decision, p = raw["state"], raw["decision"], raw["perceived"]
        now = raw["t"]
        fresh = decision is not None and decision.perception == "fresh"
        usable = p is not None and fresh and p.error is None
        seen = p.rings_robot_xy if usable else None
        field = field_view(view, state, seen)
        field["forgotten"] = self._forgetting.update(now, field)
        # The goal detector's goals of the same result (jetson/perception/goals.py), when on.
        field["goals_seen"] = (
            goals_field(p.goals_robot, state) if p is not None and usable and state else []
        )
        # The robot detector's robots of the same result (jetson/perception/robots.py), when on.
        field["robots_seen"] = (
            robots_field(p.robots_robot, state) if p is not None and usable and state else []
        )
        field["claim"] = claim_view(raw["claim"])
        perception = None
        if p is not None:
            perception = {
                "id": int(p.id),
                "age_ms": _r((now - p.stamp_s) * 1e3, 1),
                "rings": len(p.rings_robot_xy),
                "detections": int(p.detections),
                "process_ms": _r(p.process_ms, 2),
                "error": p.error,
            }
        return {
            "kind": "state",
            "n": raw["n"],
            "t": round(now, 4),
            "wall": round(raw["wall"], 3),
            "link": link,
            **state_snapshot(state, raw["command"], decision),
            "perception": perception,
            "has_camera": raw["has_camera"],
            "frame_id": raw["frame_id"],
            "field": field,
            "partner": partner_view(
                raw["partner"],
                raw["partner_status"],
                None if state is None else state.match_ms,
            ),
            "brain_lines": raw["brain_lines"],
            "recording": raw["recording"],
        }


def fingerprint() -> str:
    return f"{messages.FINGERPRINT:08X}"
