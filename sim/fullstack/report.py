"""What a match leaves behind in its run folder: the summary, the replay GIF, the plots.

summary.txt / summary.json   the table: rings, score, messages sent/received/lost/rejected per
                             direction, loop latency p50/p99, perception precision/recall/F1
                             against the simulator's ground truth, fault checks
replay.gif                   top-down view with the robot's camera inset (perceived rings
                             circled in the inset, the true ones outlined on the field)
replay.png                   one frame of it, for a README
plots.png                    rings and score, commanded vs actual speed, who drove, latency,
                             perception over time
timeline.csv                 the samples behind the plots, every 100 ms
daemon.jsonl                 the Jetson daemon's own log (full stack)
brain_host.stderr            brain_host's stderr (full stack; empty when all is well)
"""

from __future__ import annotations

import csv
import json
import math
from dataclasses import asdict, dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from PIL import Image, ImageDraw

from jetson.autonomy.camera import project_points, robot_to_camera_rotation
from sim.config import CameraConfig

MATCH_RADIUS_M = 0.15  # a perceived ring within this of a true one is that ring


@dataclass
class Sample:
    """The match every 100 ms of simulated time."""

    t_s: float
    x: float  # the robot's true pose (field frame, m, heading deg clockwise)
    y: float
    heading: float
    rings: int  # collected so far
    held: int  # in the intake now
    score: int
    opponent_rings: int
    opponent_score: int
    v_cmd: float  # what the Brain told the motors, as a twist (full stack) or the policy (sim)
    w_cmd: float
    v_actual: float  # what the robot did
    w_actual: float
    source: str  # who drove: jetson | driver | none | policy
    link: str  # the Brain's link state, or "-"
    faults: str
    perceived: int  # rings in the newest perception result the daemon had, -1: none
    visible: int  # rings the camera could see (ground truth)


@dataclass(frozen=True)
class Check:
    """One thing a fault scenario promises, and whether this match kept it."""

    name: str
    passed: bool
    detail: str


@dataclass
class PerceptionScore:
    frames: int = 0
    tp: int = 0
    fp: int = 0
    fn: int = 0
    errors_m: list[float] = field(default_factory=list)

    def add(self, perceived: np.ndarray, truth: np.ndarray, radius: float = MATCH_RADIUS_M) -> None:
        """Greedy nearest matching of perceived to true robot-frame positions."""
        p = np.asarray(perceived, dtype=np.float64).reshape(-1, 2)
        t = np.asarray(truth, dtype=np.float64).reshape(-1, 2)
        self.frames += 1
        if len(p) == 0 or len(t) == 0:
            self.fp += len(p)
            self.fn += len(t)
            return
        d = np.linalg.norm(p[:, None, :] - t[None, :, :], axis=2)
        matched = 0
        used_p = np.zeros(len(p), dtype=bool)
        used_t = np.zeros(len(t), dtype=bool)
        for flat in np.argsort(d, axis=None, kind="stable"):
            i, j = divmod(int(flat), len(t))
            if d[i, j] > radius:
                break
            if used_p[i] or used_t[j]:
                continue
            used_p[i] = used_t[j] = True
            matched += 1
            self.errors_m.append(float(d[i, j]))
        self.tp += matched
        self.fp += len(p) - matched
        self.fn += len(t) - matched

    @property
    def precision(self) -> float:
        n = self.tp + self.fp
        return self.tp / n if n else math.nan

    @property
    def recall(self) -> float:
        n = self.tp + self.fn
        return self.tp / n if n else math.nan

    @property
    def f1(self) -> float:
        p, r = self.precision, self.recall
        if math.isnan(p) or math.isnan(r) or p + r == 0:
            return math.nan if math.isnan(p) and math.isnan(r) else 0.0
        return 2 * p * r / (p + r)

    def as_dict(self) -> dict[str, Any]:
        err = np.asarray(self.errors_m)
        return {
            "frames": self.frames,
            "tp": self.tp,
            "fp": self.fp,
            "fn": self.fn,
            "precision": _finite(self.precision),
            "recall": _finite(self.recall),
            "f1": _finite(self.f1),
            "match_radius_m": MATCH_RADIUS_M,
            "error_median_m": float(np.median(err)) if err.size else None,
            "error_p90_m": float(np.quantile(err, 0.9)) if err.size else None,
        }


def _finite(x: float) -> float | None:
    return x if math.isfinite(x) else None


def percentiles_ms(values_s: list[float]) -> dict[str, Any]:
    if not values_s:
        return {"n": 0, "p50_ms": None, "p99_ms": None, "max_ms": None}
    a = np.asarray(values_s) * 1e3
    return {
        "n": int(a.size),
        "p50_ms": float(np.percentile(a, 50)),
        "p99_ms": float(np.percentile(a, 99)),
        "max_ms": float(a.max()),
    }


@dataclass
class MatchResult:
    stack: str
    seed: int
    mode: str  # lockstep | realtime
    fault: str | None
    policy: str
    opponent: str
    sim_s: float
    wall_s: float
    rings: int
    score: int
    opponent_rings: int
    opponent_score: int
    latency: dict[str, Any]  # the daemon's State -> Command time (full), or policy time (sim)
    messages: dict[str, Any] | None = None
    perception: dict[str, Any] | None = None
    brain: dict[str, Any] | None = None
    daemon: dict[str, Any] | None = None
    settings: dict[str, Any] = field(default_factory=dict)
    checks: list[Check] = field(default_factory=list)
    files: dict[str, str] = field(default_factory=dict)
    # Each fault injected: what happened and what was measured (sim.fullstack.faults).
    faults: list[dict[str, Any]] = field(default_factory=list)
    # The whole game: each alliance's score by element and its fouls
    # (sim.evaluate.element_breakdown); None in the ring race.
    game: dict[str, Any] | None = None
    # --partner stack: the partner's full stack (sim.fullstack.partner_stack.PartnerStack.as_dict)
    # and the VEXlink radio between the two Brains (VexlinkStats).
    partner: dict[str, Any] | None = None

    @property
    def passed(self) -> bool:
        return all(c.passed for c in self.checks)

    def as_dict(self) -> dict[str, Any]:
        d = asdict(self)
        d["checks"] = [asdict(c) for c in self.checks]
        d["passed"] = self.passed
        return d

    def table(self) -> str:
        rows: list[tuple[str, str]] = [
            ("stack", f"{self.stack} ({self.mode}{', fault ' + self.fault if self.fault else ''})"),
            ("seed", str(self.seed)),
            ("policy", self.policy),
            ("opponent", self.opponent),
            ("rings collected", f"{self.rings}   (opponent {self.opponent_rings})"),
            ("score", f"{self.score}   (opponent {self.opponent_score})"),
        ]
        for alliance, row in (self.game or {}).items():
            parts = [f"{k} {v}" for k, v in row.items() if k not in ("total", "fouls_by_kind")]
            fouls = ", ".join(f"{k} {n}" for k, n in row.get("fouls_by_kind", {}).items())
            rows.append((f"{alliance} by element", f"{row['total']} = " + ", ".join(parts)))
            rows.append((f"{alliance} fouls", fouls or "none"))
        if self.messages is not None:
            for key, label in (("down", "Jetson -> Brain"), ("up", "Brain -> Jetson")):
                m = self.messages[key]
                rows.append(
                    (
                        f"messages {label}",
                        f"sent {m['sent']}, received {m['received']}, lost {m['lost']}, "
                        f"rejected {m['rejected']}",
                    )
                )
        if self.partner is not None:
            rows += partner_rows(self.partner)
        lat = self.latency
        what = "State -> Command" if self.stack == "full" else "policy call"
        if lat.get("n"):
            rows.append(
                (
                    f"loop latency ({what})",
                    f"p50 {lat['p50_ms']:.2f} ms, p99 {lat['p99_ms']:.2f} ms "
                    f"(max {lat['max_ms']:.2f}, n {lat['n']})",
                )
            )
        age = (self.brain or {}).get("command_age") or {}
        if age.get("n"):
            rows.append(
                (
                    "State -> applied (sim time)",
                    f"p50 {age['p50_ms']:.0f} ms, p99 {age['p99_ms']:.0f} ms",
                )
            )
        if self.perception is not None and self.perception.get("frames"):
            p = self.perception
            f1 = "n/a" if p["f1"] is None else f"{p['f1']:.3f}"
            pr = "n/a" if p["precision"] is None else f"{p['precision']:.3f}"
            rc = "n/a" if p["recall"] is None else f"{p['recall']:.3f}"
            err = (
                "" if p["error_median_m"] is None else f", error median {p['error_median_m']:.3f} m"
            )
            rows.append(
                (
                    "perception vs truth",
                    f"F1 {f1} (precision {pr}, recall {rc}) over {p['frames']} frames{err}",
                )
            )
        rows.append(
            (
                "time",
                f"{self.sim_s:.1f} s simulated in {self.wall_s:.1f} s wall "
                f"({self.sim_s / max(self.wall_s, 1e-9):.1f}x)",
            )
        )
        for c in self.checks:
            rows.append((f"check {c.name}", f"{'PASS' if c.passed else 'FAIL'}: {c.detail}"))
        width = max(len(r[0]) for r in rows)
        return "\n".join(f"{k:<{width}}  {v}" for k, v in rows)


def partner_rows(p: dict[str, Any]) -> list[tuple[str, str]]:
    """The summary's rows for the partner on the full stack and the VEXlink radio."""
    v = p["vexlink"]
    lat = p["latency"]
    share = p["jetson_share"]

    def links(changes: list[list[Any]]) -> str:
        return " -> ".join(f"{state} ({t / 1000:.1f} s)" for t, state in changes) or "-"

    rows = [
        (
            "partner (full stack)",
            f"{p['robot']}: its Jetson drove "
            + ("-" if share is None else f"{share:.0%}")
            + " of the match, State -> Command p50 "
            + (f"{lat['p50_ms']:.2f} ms" if lat.get("n") else "-"),
        ),
        ("VEXlink (ours)", links(p["our_partner_link"])),
        ("VEXlink (partner's)", links(p["partner_link"])),
        (
            "VEXlink radio",
            f"{v['frames']} frames, {v['delivered']} delivered, {v['lost']} lost, "
            f"{v['late']} late (max delay {v['max_delay_ms']:.0f} ms)",
        ),
    ]
    ends = [changes[-1][1] for changes in (p["our_partner_link"], p["partner_link"]) if changes]
    if "lost" in ends:
        rows.append(("alliance", "the partner link was lost: each robot played on alone"))
    elif any(s == "lost" for _, s in p["our_partner_link"] + p["partner_link"]):
        rows.append(("alliance", "the partner link was lost for a while and came back"))
    return rows


# --- the replay ---------------------------------------------------------------------------------


def project_rings(rings_robot_xy: np.ndarray, cam: CameraConfig, ring_z: float) -> np.ndarray:
    """Pixels (N, 2) of floor rings given in the robot frame, for a camera of this config."""
    pts = np.asarray(rings_robot_xy, dtype=np.float64).reshape(-1, 2)
    if len(pts) == 0:
        return np.zeros((0, 2))
    robot = np.column_stack([pts, np.full(len(pts), ring_z)])
    origin = np.array([cam.right_m, cam.forward_m, cam.height_m])
    optical = (robot - origin) @ robot_to_camera_rotation(cam.tilt_deg).T
    uv, z = project_points(optical, cam.fx, cam.fy, cam.cx, cam.cy)
    return uv[z > 0]


def compose_frame(
    top: np.ndarray,
    camera_rgb: np.ndarray | None,
    perceived_uv: np.ndarray | None = None,
    caption: str | None = None,
    panel_width: int | None = None,
) -> np.ndarray:
    """The top-down image with the robot's camera view in a panel on its right (pasted over the
    field it would hide too much of it). Perceived rings are circled in yellow."""
    img = Image.fromarray(top)
    if camera_rgb is None:
        return np.asarray(img)
    cam = Image.fromarray(camera_rgb)
    w = panel_width or max(160, img.width * 4 // 5)
    h = round(cam.height * w / cam.width)
    sx = w / cam.width
    cam = cam.resize((w, h), Image.Resampling.NEAREST)
    d = ImageDraw.Draw(cam)
    for u, v in np.asarray(perceived_uv if perceived_uv is not None else []).reshape(-1, 2):
        r = max(5.0, 4 * sx)
        cx, cy = u * sx, v * sx
        d.ellipse([cx - r, cy - r, cx + r, cy + r], outline=(255, 230, 0), width=2)
    out = Image.new("RGB", (img.width + w + 8, max(img.height, h + 24)), (30, 30, 34))
    out.paste(img, (0, 0))
    out.paste(cam, (img.width + 4, 8))
    if caption:
        ImageDraw.Draw(out).text((img.width + 8, h + 12), caption, fill=(235, 235, 235))
    return np.asarray(out)


# --- files --------------------------------------------------------------------------------------


def write_timeline(samples: list[Sample], path: Path) -> Path:
    with path.open("w", newline="") as f:
        w = csv.writer(f)
        names = list(Sample.__dataclass_fields__)
        w.writerow(names)
        for s in samples:
            w.writerow([getattr(s, n) for n in names])
    return path


def write_summary(result: MatchResult, folder: Path) -> tuple[Path, Path]:
    text = folder / "summary.txt"
    text.write_text(result.table() + "\n")
    js = folder / "summary.json"
    js.write_text(json.dumps(result.as_dict(), indent=1, default=str) + "\n")
    return text, js


def plot(
    samples: list[Sample],
    latencies_s: list[float],
    path: Path,
    title: str,
    events: list[tuple[float, str]] | None = None,
) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    t = np.array([s.t_s for s in samples])
    fig, axes = plt.subplots(5, 1, figsize=(9, 12), sharex=False)
    ax = axes[0]
    ax.plot(t, [s.rings for s in samples], label="rings collected (ours)")
    ax.plot(t, [s.held for s in samples], ":", label="rings held (ours)")
    ax.plot(t, [s.score for s in samples], label="score (ours)")
    ax.plot(t, [s.opponent_rings for s in samples], "--", label="rings (opponent)")
    ax.plot(t, [s.opponent_score for s in samples], "--", label="score (opponent)")
    ax.set_ylabel("count / points")
    ax.legend(loc="upper left", fontsize=8)
    ax.set_title(title)
    ax = axes[1]
    ax.plot(t, [s.v_cmd for s in samples], label="v told to motors (m/s)")
    ax.plot(t, [s.v_actual for s in samples], label="v actual (m/s)", alpha=0.7)
    ax.plot(t, [s.w_cmd / 4 for s in samples], label="w told / 4 (rad/s)", alpha=0.7)
    ax.set_ylabel("speed")
    ax.legend(loc="upper left", fontsize=8)
    ax = axes[2]
    sources = ["none", "driver", "jetson", "policy"]
    ax.step(
        t, [sources.index(s.source) if s.source in sources else 0 for s in samples], where="post"
    )
    ax.set_yticks(range(len(sources)), sources)
    ax.set_ylabel("who drove")
    for when, what in events or []:
        ax.axvline(when, color="r", alpha=0.5)
        ax.text(when, 2.5, what, fontsize=7, rotation=90, va="center")
    ax = axes[3]
    ax.plot(t, [s.visible for s in samples], label="rings in view (truth)")
    ax.plot(t, [max(-0.5, s.perceived) for s in samples], label="rings perceived (daemon)")
    ax.set_ylabel("rings")
    ax.set_xlabel("match time (s)")
    ax.legend(loc="upper left", fontsize=8)
    ax = axes[4]
    if latencies_s:
        ms = np.asarray(latencies_s) * 1e3
        ax.hist(ms, bins=60)
        ax.axvline(float(np.percentile(ms, 99)), color="r", label="p99")
        ax.axvline(float(np.percentile(ms, 50)), color="g", label="p50")
        ax.legend(fontsize=8)
    ax.set_xlabel("loop latency (ms, this machine)")
    ax.set_ylabel("count")
    fig.tight_layout()
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path
