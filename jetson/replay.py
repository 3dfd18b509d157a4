"""`pete-jetson replay FILE`: re-run a recorded session through the decision code, offline.

Each recorded State, with the perception result and age it was answered with (its rings, and its
goals for the scripted alliance), goes through a fresh Decider built from the recording's header
(same settings, same control rate) and the same policy (the recorded path, or --policy; its
sha256 is compared with the recorded one), or the scripted alliance it was made with. Every
Command field and the decision's reason are compared with what was sent. A difference means the
decision code, the policy or the libraries under them behave differently from the robot's.

A recording cut off at any byte (power lost while it was written, a full disk) replays up to the
cut: every whole record before it is used, and the report says where it ends (`cut`).
"""

from __future__ import annotations

import json
import math
import zlib
from collections.abc import Iterator
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import MemoryCamera
from jetson.autonomy.policy import OnnxPolicy, Policy
from jetson.decide import Decider, PerceptionInput
from jetson.errors import ReplayError
from jetson.log import LatencyStats
from jetson.partner import PartnerInput
from jetson.recorder import FORMAT, READABLE_VERSIONS
from jetson.settings import DecisionConfig
from protocol.framing import message_from_dict
from protocol.messages import Partner, State


@dataclass(frozen=True)
class Difference:
    cycle: int  # index among the recording's cycles
    state_seq: int
    time_ms: int
    what: str  # linear | angular | intake | reason
    recorded: Any
    replayed: Any


@dataclass
class ReplayReport:
    path: Path
    policy: str
    cycles: int = 0
    identical: int = 0
    differences: list[Difference] = field(default_factory=list)
    differing_cycles: int = 0
    warnings: list[str] = field(default_factory=list)
    latency: dict[str, float] = field(default_factory=dict)
    reasons: dict[str, int] = field(default_factory=dict)
    cut: str | None = None  # where and how a cut-off recording ends (None: it is whole)

    @property
    def ok(self) -> bool:
        return self.cycles > 0 and self.differing_cycles == 0

    def text(self, show: int = 10) -> str:
        lines = [f"replayed {self.path} with {self.policy}"]
        lines += [f"warning: {w}" for w in self.warnings]
        if self.cut is not None:
            lines.append(
                f"the recording is cut off ({self.cut}): the {self.cycles} whole cycles before "
                "the cut were replayed"
            )
        lines.append(
            f"{self.cycles} cycles: {self.identical} identical, {self.differing_cycles} differ"
        )
        if self.latency.get("n"):
            lat = self.latency
            lines.append(
                f"recorded State->Command latency: p50 {lat['p50_ms']:.3f} ms, "
                f"p99 {lat['p99_ms']:.3f} ms, max {lat['max_ms']:.3f} ms"
            )
        if self.reasons:
            lines.append(
                "decisions: " + ", ".join(f"{k} {v}" for k, v in sorted(self.reasons.items()))
            )
        for d in self.differences[:show]:
            lines.append(
                f"  cycle {d.cycle} (State seq {d.state_seq}, t {d.time_ms} ms): {d.what} "
                f"recorded {d.recorded!r}, replayed {d.replayed!r}"
            )
        if len(self.differences) > show:
            lines.append(f"  ... and {len(self.differences) - show} more differences")
        if self.cycles == 0:
            lines.append("the recording has no cycles: nothing was compared")
        return "\n".join(lines)

    def as_dict(self) -> dict[str, Any]:
        return {
            "path": str(self.path),
            "policy": self.policy,
            "cycles": self.cycles,
            "identical": self.identical,
            "differing_cycles": self.differing_cycles,
            "differences": [d.__dict__ for d in self.differences[:1000]],
            "warnings": self.warnings,
            "latency": self.latency,
            "reasons": self.reasons,
            "cut": self.cut,
            "ok": self.ok,
        }


_CHUNK = 1 << 16


class Records:
    """A recording's records, as far as they are whole. Iterating yields each record (a dict);
    afterwards `cut` says where a cut-off recording ends, or is None when it is whole.

    A cut is the end of the file inside a line (the daemon lost power, or was killed, mid-write),
    a gzip stream without its end marker, or bytes that do not decompress (a crash can leave a
    file's tail zeroed). A line that is not JSON before the last one is damage, not a cut: a
    ReplayError."""

    def __init__(self, path: Path) -> None:
        self.path = path
        self.cut: str | None = None
        self.lines = 0

    def __iter__(self) -> Iterator[dict[str, Any]]:
        pending = b""
        try:
            for data in self._data():
                pending += data
                *whole, pending = pending.split(b"\n")
                for line in whole:
                    record = self._parse(line)
                    if record is not None:
                        yield record
        except OSError as exc:
            raise ReplayError(f"{self.path}: cannot be read: {exc}") from exc
        if pending.strip():
            # The last line has no newline: a whole record whose newline was lost, or the cut.
            try:
                record = json.loads(pending.decode("utf-8"))
            except (UnicodeDecodeError, json.JSONDecodeError):
                record = None
            if isinstance(record, dict):
                self.lines += 1
                yield record
            else:
                self._cut(f"line {self.lines + 1} ends after {len(pending)} bytes")

    def _cut(self, what: str) -> None:
        self.cut = what if self.cut is None else f"{what}; {self.cut}"

    def _parse(self, line: bytes) -> dict[str, Any] | None:
        self.lines += 1
        if not line.strip():
            return None
        try:
            record = json.loads(line.decode("utf-8"))
        except (UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise ReplayError(f"{self.path}:{self.lines}: not a JSON line ({exc})") from exc
        if not isinstance(record, dict):
            raise ReplayError(f"{self.path}:{self.lines}: not a record (a JSON object)")
        return record

    def _data(self) -> Iterator[bytes]:
        """The file's bytes, decompressed when it is gzip: as far as they go."""
        with self.path.open("rb") as f:
            if self.path.suffix != ".gz":
                empty = True
                while chunk := f.read(_CHUNK):
                    empty = False
                    yield chunk
                if empty:
                    self._cut("the file is empty")
                return
            d = zlib.decompressobj(wbits=31)  # gzip
            fed = False  # d has been given bytes
            read = 0
            while chunk := f.read(_CHUNK):
                read += len(chunk)
                while chunk:
                    try:
                        out = d.decompress(chunk)
                    except zlib.error as exc:
                        self._cut(f"the data is damaged within its first {read} bytes ({exc})")
                        return
                    fed = True
                    yield out
                    chunk = b""
                    if d.eof:  # another gzip member may follow
                        chunk, d, fed = d.unused_data, zlib.decompressobj(wbits=31), False
            if not read:
                self._cut("the file is empty")
            elif fed and not d.eof:
                self._cut("the gzip stream stops without its end marker")


def recorded_decision(header: dict[str, Any]) -> DecisionConfig:
    """The decision settings a recording was made with. A recording from before a setting
    existed gets the behaviour the daemon had then, not today's default."""
    data = dict(header["decision"])
    data.setdefault("frame_pose", False)  # rings were placed from the newest pose
    return replace(DecisionConfig.from_dict(data), decision_hz=float(header["decision_hz"]))


def _recorded_policy(
    path: Path, header: dict[str, Any], policy: Policy | None, warnings: list[str]
) -> Policy:
    """The policy to replay with: the one given, or the recorded file; a differing file or
    observation spec is a warning."""
    recorded_policy = header.get("policy") or {}
    if policy is None:
        where = recorded_policy.get("path")
        if not where:
            raise ReplayError(f"{path}: the header names no policy file; give --policy")
        policy = OnnxPolicy(where)
    sha = getattr(policy, "sha256", None)
    if recorded_policy.get("sha256") and sha and sha != recorded_policy["sha256"]:
        warnings.append(
            f"the policy's sha256 {sha[:12]} differs from the recorded "
            f"{recorded_policy['sha256'][:12]}: differences are expected"
        )
    if header.get("observation") and header["observation"] != policy.spec.to_dict():
        warnings.append("the policy's observation spec differs from the recorded one")
    return policy


def recorded_decider(
    path: Path,
    header: dict[str, Any],
    policy: Policy | None = None,
    warnings: list[str] | None = None,
) -> tuple[Any, str]:
    """The decision-maker a recording was made with, and its description: the scripted
    alliance (`[decision] player = "alliance"`), or a Decider over the policy given or the
    recorded file (differences from the recorded one are added to `warnings`)."""
    try:
        config = recorded_decision(header)
    except (KeyError, TypeError, ValueError) as exc:
        raise ReplayError(f"{path}: bad decision settings in the header: {exc}") from exc
    if config.player == "alliance":  # the scripted alliance decided, not a policy
        from jetson.scripted import ScriptedDecider

        scripted = ScriptedDecider(config)
        return scripted, scripted.description
    policy = _recorded_policy(path, header, policy, [] if warnings is None else warnings)
    cam = header.get("memory_camera")
    try:
        camera = MemoryCamera(**cam) if cam else None
    except (TypeError, ValueError) as exc:
        raise ReplayError(f"{path}: bad memory_camera in the header: {exc}") from exc
    description = getattr(policy, "description", type(policy).__name__)
    return Decider(policy, config, camera), description


def replay(path: str | Path, policy: Policy | None = None, tolerance: float = 1e-6) -> ReplayReport:
    path = Path(path)
    reader = Records(path)
    records = iter(reader)
    header = next(records, None)
    if not header or header.get("kind") != "header" or header.get("format") != FORMAT:
        if header is None and reader.cut is not None:
            raise ReplayError(f"{path}: cut off before its header was whole ({reader.cut})")
        raise ReplayError(f"{path}: not a pete-jetson session recording (no header)")
    version = header.get("version")
    if version not in READABLE_VERSIONS:
        raise ReplayError(
            f"{path}: recording version {version}, this replay reads {list(READABLE_VERSIONS)}"
        )
    warnings: list[str] = []
    decider, description = recorded_decider(path, header, policy, warnings)
    report = ReplayReport(path, description)
    report.warnings = warnings
    perceived: dict[int, PerceptionInput] = {}
    latencies = []
    end = None
    for rec in records:
        kind = rec.get("kind")
        if kind == "end":
            end = rec
        elif kind == "reset":
            decider.reset()
        elif kind == "perception":
            try:
                perceived[int(rec["id"])] = recorded_perception(rec)
            except (KeyError, TypeError, ValueError) as exc:
                raise ReplayError(f"{path}: a perception record is malformed: {exc}") from exc
        elif kind == "cycle":
            _compare(report, decider, rec, perceived, tolerance, path)
            latencies.append(float(rec.get("latency_ms", math.nan)) / 1e3)
    report.latency = LatencyStats.summary_ms(x for x in latencies if math.isfinite(x))
    report.cut = reader.cut
    if end is None and version != 1 and report.cut is None:
        # Cut exactly between two lines: every line is whole, but the file was never closed.
        report.cut = f"it stops after line {reader.lines} without its end record"
    if end is not None and end.get("stopped"):
        report.warnings.append(f"the recording stopped early: {end['stopped']}")
    return report


def recorded_perception(rec: dict[str, Any]) -> PerceptionInput:
    """A recording's perception record as the decision reads it (its age comes with each cycle
    that uses it); a record without goals or robots (none seen, or recorded before either) has
    none."""
    xy = np.asarray(rec["rings"], dtype=np.float64).reshape(-1, 2)
    goals = np.asarray(rec.get("goals") or [], dtype=np.float64).reshape(-1, 3)
    robots = recorded_robots(rec)
    return PerceptionInput(int(rec["id"]), 0.0, xy, rec.get("error"), goals, robots)


def recorded_robots(rec: dict[str, Any]) -> NDArray[np.float64]:
    """A perception record's robots, (N, 3) x, y robot frame and alliance code: none when the
    record has no `robots` (a daemon without the robot detector, or none seen)."""
    return np.asarray(rec.get("robots") or [], dtype=np.float64).reshape(-1, 3)


def recorded_partner(cycle: dict[str, Any]) -> PartnerInput | None:
    """The partner's report a recorded cycle's decision was given (none: the link was not up,
    or the recording predates partner reports). ReplayError for one that cannot be read."""
    if cycle.get("partner") is None:
        return None
    try:
        report = message_from_dict(Partner, cycle["partner"])
        return PartnerInput(report, float(cycle["partner_age"]))
    except (KeyError, ValueError, TypeError) as exc:
        raise ReplayError(f"a cycle's partner report is malformed: {exc!r}") from exc


def recorded_state(data: dict[str, Any]) -> State:
    """A recording's State (its JSON form), from any protocol version this replay reads."""
    return message_from_dict(State, _protocol_v3_pose(data))


def _protocol_v3_pose(state: dict[str, Any]) -> dict[str, Any]:
    """A State recorded before protocol v4 has no pose_fix: its x, y, heading were the GPS's,
    valid while gps_status was ok. Give it the v4 fields that mean the same, so an old recording
    replays as it was decided."""
    if "pose_fix" in state:
        return state
    ok = state.get("gps_status", "ok") in ("ok", 0)
    return {
        **state,
        "pose_fix": "gps" if ok else "lost",
        "pose_std": float(state.get("gps_error", 0.0)) if ok else 0.0,
    }


def _compare(
    report: ReplayReport,
    decider: Decider,
    rec: dict[str, Any],
    perceived: dict[int, PerceptionInput],
    tolerance: float,
    path: Path,
) -> None:
    index = report.cycles
    report.cycles += 1
    try:
        state = recorded_state(rec["state"])
        cmd = rec["cmd"]
    except (KeyError, ValueError, TypeError) as exc:
        raise ReplayError(f"{path}: cycle {index} is malformed: {exc}") from exc
    pin = None
    if rec.get("p") is not None:
        pid = int(rec["p"])
        if pid not in perceived:
            raise ReplayError(f"{path}: cycle {index} uses perception {pid}, never recorded")
        pin = replace(perceived[pid], age_s=float(rec["age"]))
    d = decider.decide(state, pin, recorded_partner(rec))
    report.reasons[d.reason] = report.reasons.get(d.reason, 0) + 1
    diffs = []
    for what, got in (("linear", d.linear), ("angular", d.angular)):
        want = float(cmd[what])
        if not abs(got - want) <= tolerance:
            diffs.append((what, want, got))
    if bool(cmd["intake"]) != d.intake:
        diffs.append(("intake", bool(cmd["intake"]), d.intake))
    if rec.get("reason") != d.reason:
        diffs.append(("reason", rec.get("reason"), d.reason))
    if diffs:
        report.differing_cycles += 1
        for what, want, got in diffs:
            report.differences.append(Difference(index, state.seq, state.time_ms, what, want, got))
    else:
        report.identical += 1
