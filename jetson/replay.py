"""`pete-jetson replay FILE`: re-run a recorded session through the decision code, offline.

Each recorded State, with the perception result and age it was answered with, goes through a
fresh Decider built from the recording's header (same settings, same control rate) and the same
policy (the recorded path, or --policy; its sha256 is compared with the recorded one). Every
Command field and the decision's reason are compared with what was sent. A difference means the
decision code, the policy or the libraries under them behave differently from the robot's.
"""

from __future__ import annotations

import json
import math
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from jetson.autonomy.camera import MemoryCamera
from jetson.autonomy.policy import OnnxPolicy, Policy
from jetson.decide import Decider, PerceptionInput
from jetson.errors import ReplayError
from jetson.log import LatencyStats
from jetson.recorder import FORMAT, VERSION, open_recording
from jetson.settings import DecisionConfig
from protocol.framing import message_from_dict
from protocol.messages import State


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

    @property
    def ok(self) -> bool:
        return self.cycles > 0 and self.differing_cycles == 0

    def text(self, show: int = 10) -> str:
        lines = [f"replayed {self.path} with {self.policy}"]
        lines += [f"warning: {w}" for w in self.warnings]
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
            "ok": self.ok,
        }


def _records(path: Path):
    try:
        with open_recording(path) as f:
            for n, line in enumerate(f, 1):
                if not line.strip():
                    continue
                try:
                    yield json.loads(line)
                except json.JSONDecodeError as exc:
                    # The daemon may have been killed mid-line: the last line can be cut.
                    raise ReplayError(f"{path}:{n}: not a JSON line ({exc})") from exc
    except (OSError, EOFError) as exc:
        raise ReplayError(f"{path}: cannot be read: {exc}") from exc


def recorded_decision(header: dict[str, Any]) -> DecisionConfig:
    """The decision settings a recording was made with. A recording from before a setting
    existed gets the behaviour the daemon had then, not today's default."""
    data = dict(header["decision"])
    data.setdefault("frame_pose", False)  # rings were placed from the newest pose
    return replace(DecisionConfig.from_dict(data), decision_hz=float(header["decision_hz"]))


def replay(path: str | Path, policy: Policy | None = None, tolerance: float = 1e-6) -> ReplayReport:
    path = Path(path)
    records = _records(path)
    header = next(records, None)
    if not header or header.get("kind") != "header" or header.get("format") != FORMAT:
        raise ReplayError(f"{path}: not a pete-jetson session recording (no header)")
    if header.get("version") != VERSION:
        raise ReplayError(f"{path}: recording version {header.get('version')}, need {VERSION}")
    warnings = []
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
    try:
        config = recorded_decision(header)
    except (KeyError, TypeError, ValueError) as exc:
        raise ReplayError(f"{path}: bad decision settings in the header: {exc}") from exc
    if header.get("observation") and header["observation"] != policy.spec.to_dict():
        warnings.append("the policy's observation spec differs from the recorded one")
    cam = header.get("memory_camera")
    try:
        camera = MemoryCamera(**cam) if cam else None
    except (TypeError, ValueError) as exc:
        raise ReplayError(f"{path}: bad memory_camera in the header: {exc}") from exc
    decider = Decider(policy, config, camera)
    report = ReplayReport(path, getattr(policy, "description", type(policy).__name__))
    report.warnings = warnings
    rings: dict[int, tuple[np.ndarray, str | None]] = {}
    latencies = []
    for rec in records:
        kind = rec.get("kind")
        if kind == "reset":
            decider.reset()
        elif kind == "perception":
            xy = np.asarray(rec["rings"], dtype=np.float64).reshape(-1, 2)
            rings[int(rec["id"])] = (xy, rec.get("error"))
        elif kind == "cycle":
            _compare(report, decider, rec, rings, tolerance, path)
            latencies.append(float(rec.get("latency_ms", math.nan)) / 1e3)
    report.latency = LatencyStats.summary_ms(x for x in latencies if math.isfinite(x))
    return report


def _compare(
    report: ReplayReport,
    decider: Decider,
    rec: dict[str, Any],
    rings: dict[int, tuple[np.ndarray, str | None]],
    tolerance: float,
    path: Path,
) -> None:
    index = report.cycles
    report.cycles += 1
    try:
        state = message_from_dict(State, rec["state"])
        cmd = rec["cmd"]
    except (KeyError, ValueError, TypeError) as exc:
        raise ReplayError(f"{path}: cycle {index} is malformed: {exc}") from exc
    pin = None
    if rec.get("p") is not None:
        pid = int(rec["p"])
        if pid not in rings:
            raise ReplayError(f"{path}: cycle {index} uses perception {pid}, never recorded")
        xy, error = rings[pid]
        pin = PerceptionInput(pid, float(rec["age"]), xy, error)
    d = decider.decide(state, pin)
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
