"""What the daemon counts, and the summary it logs every second (as a `summary` record and one
human line: jetson/README.md, "The log")."""

from __future__ import annotations

from collections import Counter
from dataclasses import dataclass, field
from typing import Any

from protocol.messages import Command, MatchPeriod, State


@dataclass
class Counters:
    states: int = 0  # States answered
    states_skipped: int = 0  # older States in a batch, not answered
    states_unverified: int = 0  # States before the Brain's Hello matched
    commands: int = 0
    stops: int = 0  # Commands that were stops (any reason)
    errors: int = 0  # decisions that hit an exception
    tx_dropped: int = 0
    connects: int = 0
    disconnects: int = 0
    link_errors: Counter[str] = field(default_factory=Counter)  # closed connections only
    lost: int = 0  # closed connections only
    received: int = 0  # closed connections only
    partner_reports: int = 0  # Partner reports sent to the Brain for the alliance partner

    def as_dict(self) -> dict[str, int]:
        return {
            "states": self.states, "states_skipped": self.states_skipped,
            "states_unverified": self.states_unverified, "commands": self.commands,
            "stops": self.stops, "errors": self.errors, "connects": self.connects,
            "disconnects": self.disconnects, "tx_dropped": self.tx_dropped,
            "partner_reports": self.partner_reports,
        }  # fmt: skip


@dataclass(frozen=True)
class Snapshot:
    """Everything one summary says."""

    link: str  # "waiting for port", or the handshake's state: waiting, up, mismatch
    port: str
    waited_s: float  # how long the port has been missing
    brain_boot_id: int | None
    state: State | None  # the last State answered
    rate_hz: float  # States answered per second over the window
    latency: dict[str, float]  # LatencyStats.summary_ms of the window
    received: int
    lost: int
    errors: dict[str, int]  # refused frames by kind, since start
    perception: tuple[int, float] | None  # (rings, age in s) of the newest result
    has_perception: bool
    command: Command | None
    stop_reason: str | None  # why the last Command was a stop
    window: dict[str, int]
    counters: dict[str, int]
    role: str = ""  # the robot's role in its alliance (decision.role: 24in or 15in)


def summary_line(s: Snapshot) -> str:
    parts = []
    if s.link == "waiting for port":
        parts.append(f"waiting for the Brain at {s.port} ({s.waited_s:.0f} s)")
    elif s.link == "mismatch":
        parts.append("SCHEMA MISMATCH: not driving")
    elif s.link != "up":
        parts.append("handshake: waiting for the Brain's Hello")
    else:
        st = s.state
        phase = f"{st.phase.name.lower()} {st.phase_ms / 1000:.1f} s" if st else "no State yet"
        if st is not None and st.period != MatchPeriod.BEFORE:
            phase += f" ({st.period.name.lower()})"
        who = " ".join(w for w in (st.alliance.name.lower() if st else "", s.role) if w)
        parts.append(
            f"up brain {s.brain_boot_id or 0:08X} | {who} | {phase}"
            if who
            else f"up brain {s.brain_boot_id or 0:08X} | {phase}"
        )
        if st is not None:
            fix = st.pose_fix.name.lower()
            parts.append(f"pose {fix} {st.pose_std:.2f} m" if st.pose_fix else "pose lost")
    parts.append(f"{s.rate_hz:.0f} Hz")
    if s.latency["n"]:
        lat = s.latency
        parts.append(
            f"latency p50 {lat['p50_ms']:.2f} p99 {lat['p99_ms']:.2f} max {lat['max_ms']:.2f} ms"
        )
    parts.append(f"rx {s.received} lost {s.lost}")
    parts.append("errors " + (" ".join(f"{k}={v}" for k, v in s.errors.items()) or "none"))
    if s.has_perception:
        if s.perception is None:
            parts.append("no perception")
        else:
            rings, age = s.perception
            parts.append(f"rings {rings} ({age * 1e3:.0f} ms old)")
    c = s.command
    if c is not None and s.link == "up":
        why = f" ({s.stop_reason})" if s.stop_reason else ""
        intake = " intake" if c.intake else ""
        parts.append(f"cmd {c.linear:+.2f} m/s {c.angular:+.2f} rad/s{intake}{why}")
    return " | ".join(parts)


def summary_fields(s: Snapshot) -> dict[str, Any]:
    perception = None
    if s.perception is not None:
        perception = {"rings": s.perception[0], "age_ms": s.perception[1] * 1e3}
    return {
        "link": s.link,
        "rate_hz": round(s.rate_hz, 2),
        "latency": s.latency if s.latency["n"] else None,
        "link_errors": s.errors,
        "received": s.received,
        "lost": s.lost,
        "window": s.window,
        "perception": perception,
        "counters": s.counters,
        "role": s.role or None,
        "alliance": s.state.alliance.name.lower() if s.state is not None else None,
        "period": s.state.period.name.lower() if s.state is not None else None,
        "pose": None
        if s.state is None
        else {"fix": s.state.pose_fix.name.lower(), "std_m": round(s.state.pose_std, 4)},
    }
