"""A session recording as the dashboard's timeline: `pete-jetson dashboard --recording FILE`.

The recording's cycles go through a fresh decision (jetson.decide.Decider, built from the header
as `pete-jetson replay` builds it), so the ring and goal memories and the chosen skill are
rebuilt exactly as the robot had them; every SAMPLE_S of the daemon's clock the same snapshot a
live dashboard gets is kept (jetson/dashboard/snapshot.py). The recorded camera frames (`frame`
records, a few a second) are shown at their time. Without the policy (another machine, a moved
file) the timeline still has the pose, the Commands, the link and the rings seen, but no memory.

The goals the camera saw (a daemon with the goal detector records them with each perception
result, jetson/recorder.py) go to the decision with the rings, as they went on the robot, and
each snapshot shows the last fresh result's goals as it shows its rings: `field.goals_seen`,
[x, y, colour code] in the field frame (jetson.autonomy.goal_colours), and their count in
`perception.goals` and in the cycles (the report's figures). The robots the camera saw (a daemon
with the robot detector records them the same way) go to the decision too, and show as
`field.robots_seen`, [x, y, alliance code] (jetson.perception.robots: 1 red, 2 blue), with their
count in `perception.robots`.
"""

from __future__ import annotations

import bisect
import itertools
import json
import math
from collections import deque
from pathlib import Path
from types import SimpleNamespace
from typing import Any

import numpy as np

from jetson.dashboard.snapshot import (
    FIELD_HALF_M,
    LATENCY_WINDOW,
    Forgetting,
    field_view,
    goals_field,
    latency_view,
    robots_field,
    state_snapshot,
    who_drives,
)
from jetson.decide import DRIVING_REASONS, Decider, PerceptionInput
from jetson.errors import ReplayError
from jetson.recorder import FORMAT, READABLE_VERSIONS
from jetson.replay import (
    Records,
    recorded_decider,
    recorded_partner,
    recorded_robots,
    recorded_state,
)
from protocol.framing import message_from_dict
from protocol.messages import Command, State

SAMPLE_S = 0.05  # one snapshot per 50 ms of the recording (20 a second, as live)


class Timeline:
    """A recording read whole: `snapshots` (with their times `times`), `frames` (stamp, id,
    message), the header, and what could not be rebuilt (`warnings`)."""

    def __init__(self, path: Path, policy: Any = None, memories: bool = True) -> None:
        self.path = Path(path)
        self.memories = memories  # rebuild the memories (runs the decision: seconds a match)
        self.warnings: list[str] = []
        self.snapshots: list[dict[str, Any]] = []
        self.times: list[float] = []
        self.frames: list[tuple[float, int, str]] = []
        self.cycles: list[dict[str, Any]] = []  # the cycles' plain values, for the report
        self.events: list[tuple[float, str]] = []
        self.cut: str | None = None
        self._read(policy)

    # --- reading ---------------------------------------------------------------------------

    def _decider(self, header: dict[str, Any], policy: Any) -> Any:
        try:
            return recorded_decider(self.path, header, policy)[0]
        except Exception as exc:
            self.warnings.append(f"the ring and goal memories are not shown: {exc}")
            return None

    def _read(self, policy: Any) -> None:
        reader = Records(self.path)
        records = iter(reader)
        header = next(records, None)
        if not header or header.get("kind") != "header" or header.get("format") != FORMAT:
            raise ReplayError(f"{self.path}: not a pete-jetson session recording (no header)")
        if header.get("version") not in READABLE_VERSIONS:
            raise ReplayError(f"{self.path}: recording version {header.get('version')}")
        self.header = header
        decider = self._decider(header, policy) if self.memories else None
        forgetting = Forgetting(decider.spec.memory_merge_m if decider else 0.12)
        rings: dict[int, tuple[np.ndarray, str | None]] = {}
        goals: dict[int, np.ndarray] = {}
        robots: dict[int, np.ndarray] = {}
        perceptions: dict[int, dict[str, Any]] = {}
        latencies: deque[float] = deque(maxlen=LATENCY_WINDOW)
        lines: deque[list[Any]] = deque(maxlen=30)
        n_lines = itertools.count(1)
        counts = {"states": 0, "stops": 0}
        next_sample = -math.inf
        pending: tuple[Any, ...] | None = None
        for rec in records:
            kind = rec.get("kind")
            if kind == "reset":
                if decider is not None:
                    decider.reset()
                forgetting.reset()
            elif kind == "perception":
                xy = np.asarray(rec["rings"], dtype=np.float64).reshape(-1, 2)
                rings[int(rec["id"])] = (xy, rec.get("error"))
                goals[int(rec["id"])] = recorded_goals(rec)
                robots[int(rec["id"])] = recorded_robots(rec)
                perceptions[int(rec["id"])] = rec
            elif kind == "frame":
                msg = {"kind": "frame", **{k: v for k, v in rec.items() if k != "kind"}}
                self.frames.append((float(rec["stamp"]), int(rec["id"]), json.dumps(msg)))
            elif kind == "event":
                t = float(rec.get("t", 0.0))
                text = rec.get("event", "?") + " " + str(rec.get("reason", "") or "")
                self.events.append((t, text.strip()))
                lines.append([round(t, 3), "event", text.strip(), next(n_lines)])
            elif kind == "cycle":
                t = float(rec["t"])
                state = recorded_state(rec["state"])
                cmd = message_from_dict(Command, rec["cmd"])
                pin = None
                pid = rec.get("p")
                if pid is not None and int(pid) in rings:
                    xy, error = rings[int(pid)]
                    pin = PerceptionInput(
                        int(pid), float(rec["age"]), xy, error, goals[int(pid)], robots[int(pid)]
                    )
                if decider is not None:
                    decider.decide(state, pin, recorded_partner(rec))
                latency = rec.get("latency_ms")
                if latency is not None:
                    latencies.append(float(latency) / 1e3)
                counts["states"] += 1
                counts["stops"] += rec.get("reason") not in DRIVING_REASONS
                decision = SimpleNamespace(
                    reason=rec.get("reason"), perception=rec.get("perception"),
                    rings=rec.get("rings"),
                )  # fmt: skip
                self.cycles.append(
                    {
                        "t": t, "linear": cmd.linear, "angular": cmd.angular,
                        "left": state.left_speed, "right": state.right_speed,
                        "phase": state.phase.name.lower(), "reason": rec.get("reason"),
                        "rings": rec.get("rings") or 0, "perception": rec.get("perception"),
                        "goals": len(goals_seen(pin, rec.get("perception"))),
                        "latency_ms": latency, "x": state.x, "y": state.y,
                        "driver": who_drives(state, cmd),
                    }
                )  # fmt: skip
                seen = pin.rings_robot_xy if pin and rec.get("perception") == "fresh" else None
                pending = (
                    t, state, cmd, decision, decider, seen, forgetting, latencies, counts,
                    lines, perceptions.get(int(pid)) if pid is not None else None, pin,
                )  # fmt: skip
                if t >= next_sample:
                    next_sample = t + SAMPLE_S
                    self._snapshot(*pending)
                    pending = None
        if pending is not None:  # the last cycle, between two samples
            self._snapshot(*pending)
        self.cut = reader.cut
        if not self.snapshots:
            raise ReplayError(f"{self.path}: the recording has no cycles")
        self.frames.sort(key=lambda f: f[0])
        self._frame_times = [f[0] for f in self.frames]

    def _snapshot(
        self, t: float, state: State, cmd: Command, decision: Any, decider: Decider | None,
        seen: Any, forgetting: Forgetting, latencies: deque[float], counts: dict[str, int],
        lines: deque[list[Any]], perception: dict[str, Any] | None, pin: Any,
    ) -> None:  # fmt: skip
        field = field_view(decider, state, seen)
        field["forgotten"] = forgetting.update(t, field)
        field["goals_seen"] = goals_field(goals_seen(pin, decision.perception), state)
        field["robots_seen"] = robots_field(robots_seen(pin, decision.perception), state)
        h = self.header
        snap = {
            "kind": "state",
            "n": len(self.snapshots) + 1,
            "t": round(t, 4),
            "link": {
                "state": "up", "connected": True, "up": True, "port": "(recording)",
                "ours": h.get("fingerprint"), "brain": h.get("fingerprint"),
                "jetson_boot": h.get("jetson_boot_id"), "brain_boot": h.get("brain_boot_id"),
                "rx_bytes": None, "tx_bytes": None,
                "received": counts["states"], "lost": 0, "states": counts["states"],
                "commands": counts["states"], "stops": counts["stops"], "skipped": 0,
                "unverified": 0, "connects": 1, "disconnects": 0, "tx_dropped": 0,
                "decision_errors": 0, "errors": {}, "latency": latency_view(list(latencies)),
            },
            **state_snapshot(state, cmd, decision),
            "perception": None if perception is None else {
                "id": perception["id"],
                "age_ms": None if pin is None else round(pin.age_s * 1e3, 1),
                "rings": len(perception.get("rings") or ()),
                "goals": len(perception.get("goals") or ()),
                "robots": len(perception.get("robots") or ()),
                "detections": perception.get("detections", 0),
                "process_ms": perception.get("process_ms"), "error": perception.get("error"),
            },
            "has_camera": bool((h.get("camera") or {}).get("enabled")),
            "field": field,
            "brain_lines": list(lines),
            "recording": str(self.path),
        }  # fmt: skip
        self.snapshots.append(snap)
        self.times.append(t)

    # --- looking up ------------------------------------------------------------------------

    @property
    def start_t(self) -> float:
        return self.times[0]

    @property
    def end_t(self) -> float:
        return self.times[-1]

    def index_at(self, t: float) -> int:
        return max(0, bisect.bisect_right(self.times, t) - 1)

    def snapshot_at(self, t: float) -> dict[str, Any]:
        return self.snapshots[self.index_at(t)]

    def frame_at(self, t: float) -> tuple[int, str] | None:
        """The newest recorded frame taken at or before t: (its index, its message)."""
        i = bisect.bisect_right(self._frame_times, t) - 1
        if i < 0:
            return None
        return i, self.frames[i][2]


def recorded_goals(record: dict[str, Any]) -> np.ndarray:
    """A perception record's goals, (N, 3) x, y robot frame and colour code: none when the
    record has no `goals` (a daemon without the goal detector, or none seen)."""
    return np.asarray(record.get("goals") or (), dtype=np.float64).reshape(-1, 3)


def goals_seen(pin: PerceptionInput | None, perception: str | None) -> np.ndarray:
    """The goals of the cycle's perception result when the decision took it fresh (the rings'
    rule), else none."""
    if pin is None or perception != "fresh":
        return np.zeros((0, 3))
    return pin.goals_robot


def robots_seen(pin: PerceptionInput | None, perception: str | None) -> np.ndarray:
    """The robots of the cycle's perception result when the decision took it fresh (the rings'
    rule), else none."""
    if pin is None or perception != "fresh":
        return np.zeros((0, 3))
    return pin.robots_robot


class ReplaySource:
    """The server's view of a Timeline (jetson.dashboard.server: mode "replay")."""

    mode = "replay"

    def __init__(self, timeline: Timeline) -> None:
        self.timeline = timeline
        self.start_t = timeline.start_t
        self.end_t = timeline.end_t
        self.index_at = timeline.index_at
        self.snapshot_at = timeline.snapshot_at
        self.frame_at = timeline.frame_at

    def info(self) -> dict[str, Any]:
        tl = self.timeline
        return {
            "kind": "hello", "mode": self.mode, "title": tl.path.name, "read_only": True,
            "field_half_m": FIELD_HALF_M, "fingerprint": tl.header.get("fingerprint"),
            "camera": bool(tl.frames), "start_t": self.start_t, "end_t": self.end_t,
            "warnings": tl.warnings, "cut": tl.cut,
        }  # fmt: skip
