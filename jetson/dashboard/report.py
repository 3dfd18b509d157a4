"""`pete-jetson report RECORDING`: plots of a session, as the simulator's match plots are drawn.

    report.png     the Commands against the wheels' measured speeds, who drove (with the phase
                   and the link's events), the rings in view and in the decision, the State ->
                   Command latency over time and as a histogram
    report.json    the figures behind them: cycles, time driven by whom, latency percentiles,
                   decisions by reason, frames kept

matplotlib draws them (installed with the sim extra, or `pip install matplotlib`); it is imported
only here, never by the daemon.
"""

from __future__ import annotations

import json
from collections import Counter
from pathlib import Path
from typing import Any

import numpy as np

from jetson.dashboard.replay import Timeline
from jetson.dashboard.snapshot import latency_view

DRIVERS = ("nobody", "driver", "jetson")


def summary(tl: Timeline) -> dict[str, Any]:
    cycles = tl.cycles
    t = np.array([c["t"] for c in cycles])
    dt = np.diff(t, append=t[-1]) if len(t) else np.zeros(0)
    driven: Counter[str] = Counter()
    for c, d in zip(cycles, dt, strict=True):
        driven[c["driver"]] += float(d)
    lat = [c["latency_ms"] / 1e3 for c in cycles if c["latency_ms"] is not None]
    view = latency_view(lat)
    return {
        "recording": str(tl.path),
        "cycles": len(cycles),
        "seconds": round(float(t[-1] - t[0]), 3) if len(t) else 0.0,
        "driven_s": {k: round(v, 2) for k, v in sorted(driven.items())},
        "reasons": dict(Counter(c["reason"] for c in cycles).most_common()),
        "latency_ms": {k: view[k] for k in ("n", "p50_ms", "p99_ms", "max_ms")},
        "rings_in_view_max": max((c["rings"] for c in cycles), default=0),
        "frames_kept": len(tl.frames),
        "events": [[round(a, 3), b] for a, b in tl.events],
        "warnings": tl.warnings,
        "cut": tl.cut,
    }


def plot(tl: Timeline, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    cycles = tl.cycles
    t0 = cycles[0]["t"]
    t = np.array([c["t"] - t0 for c in cycles])
    fig, axes = plt.subplots(5, 1, figsize=(9, 12))
    ax = axes[0]
    ax.plot(t, [c["linear"] for c in cycles], label="Command linear (m/s)")
    wheels = [(c["left"] + c["right"]) / 2 for c in cycles]
    ax.plot(t, wheels, label="wheels, mean measured (m/s)", alpha=0.7)
    ax.plot(t, [c["angular"] / 4 for c in cycles], label="Command angular / 4 (rad/s)", alpha=0.7)
    ax.set_ylabel("speed")
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(f"{tl.path.name}: {len(cycles)} cycles")
    ax = axes[1]
    ax.step(t, [DRIVERS.index(c["driver"]) for c in cycles], where="post", label="who drove")
    phases = ["disabled", "autonomous", "driver"]
    ax.step(t, [phases.index(c["phase"]) - 0.1 for c in cycles], ":", where="post",
            label="phase (disabled, autonomous, driver)", alpha=0.7)  # fmt: skip
    ax.set_yticks(range(len(DRIVERS)), DRIVERS)
    for when, what in tl.events:
        ax.axvline(when - t0, color="r", alpha=0.5)
        ax.text(when - t0, 1.0, what, fontsize=7, rotation=90, va="center")
    ax.set_ylabel("who drove")
    ax.legend(loc="upper left", fontsize=8)
    ax = axes[2]
    ax.step(t, [c["rings"] for c in cycles], where="post", label="rings seen, in the decision")
    stale = [c["t"] - t0 for c in cycles if c["perception"] in ("stale", "none")]
    if stale:
        ax.plot(stale, [-0.3] * len(stale), "|", color="r", label="no fresh camera result")
    ax.set_ylabel("rings")
    ax.legend(loc="upper left", fontsize=8)
    lat = np.array([c["latency_ms"] for c in cycles if c["latency_ms"] is not None], dtype=float)
    lat_t = np.array([c["t"] - t0 for c in cycles if c["latency_ms"] is not None])
    ax = axes[3]
    if len(lat):
        ax.plot(lat_t, lat, ".", markersize=2)
        ax.axhline(5.0, color="r", alpha=0.5, label="5 ms target")
        ax.legend(loc="upper left", fontsize=8)
    ax.set_ylabel("State -> Command (ms)")
    ax.set_xlabel("time in the session (s)")
    ax = axes[4]
    if len(lat):
        ax.hist(lat, bins=60)
        ax.axvline(float(np.percentile(lat, 99)), color="r", label="p99")
        ax.axvline(float(np.percentile(lat, 50)), color="g", label="p50")
        ax.legend(fontsize=8)
    ax.set_xlabel("State -> Command latency (ms, the Jetson's)")
    ax.set_ylabel("count")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def write_report(recording: Path, out: Path | None = None, policy: Any = None) -> dict[str, Any]:
    """report.png and report.json for a recording, in `out` (default: beside it, in a folder
    named after it). Returns the summary with the files' paths."""
    tl = Timeline(recording, policy, memories=False)
    name = Path(recording).name.split(".")[0]
    folder = Path(out) if out is not None else Path(recording).with_name(name + "-report")
    folder.mkdir(parents=True, exist_ok=True)
    info = summary(tl)
    info["files"] = {"plots": str(plot(tl, folder / "report.png"))}
    path = folder / "report.json"
    info["files"]["summary"] = str(path)
    path.write_text(json.dumps(info, indent=1) + "\n")
    return info
