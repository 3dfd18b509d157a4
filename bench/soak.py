"""Fault soak of the full stack: hundreds of faults at random moments, and what they cost.

    python -m bench.soak [--faults 210] [--seeds 20] [--seconds 105] [--jobs 2] [--strict]
    python -m bench.soak --faults 14 --seeds 2 --seconds 40     # a quick look (a few minutes)

Two parts, both lockstep full-stack matches (brain_host, the simulated cable, the Jetson daemon)
against the planner, with the shipped policy:

- Fault matches: `--faults` faults (default 210, 30 of each kind) spread over matches of
  `--per-match` faults each (default 10), each at a random (seeded) moment of its own slot of the
  match, none overlapping: the USB cable pulled for 2 s, SIGTERM to the daemon's process then
  systemd's restart, SIGKILL then the restart, the camera stopped for 3 s, 1 % of the bytes
  corrupted for 5 s, the daemon's disk full for 5 s, the Brain's program restarted with a new
  boot id (sim/fullstack/faults.py says what each one checks). The daemon runs as its own process
  (`--daemon process`: real signals, a real file-size limit for the full disk) and records its
  sessions. Perception is not what these faults test, so these matches render a small camera
  (96x72 at 5 frames/s, the classical detector): a third of the default camera's cost, enough
  for the camera thread to run, stop and come back.
- Ring matches: for each of `--seeds` seeds (default 20), the fault-free match exactly as
  `pete-sim match --stack full --seed N` plays it (default camera, in-process daemon) and the
  same match with the cable pulled for 2 s at a random moment (5 to 95 s).

Targets (bench/results/soak.json):

- Motor commands not from a valid current Command: 0. Every step the Jetson drove the motors,
  the Command it drove by must have reached the Brain as it was sent, within its validity
  (valid_ms, 250 ms); counted over every match of both parts.
- Every loss of Commands (cable pulled, SIGTERM, SIGKILL) stops the robot within 250 ms: the
  worst time from the fault to the first step the Jetson no longer drove the motors, or the
  Brain acted on its stop Command (it brakes under its acceleration limit). The policy parks
  once its task is done, so many faults find the robot already still (counted apart).
- Every SIGTERM exits within 1 s (wall clock, from the signal to the process reaped), having
  sent a stop Command to the connected Brain (every one of them).
- Every reconnect within 1 s of the cable returning: the worst time from the cable's return to
  the Brain obeying the Jetson again (both parts).
- Log lines per minute of the daemon's clock at most 600, the worst minute of any match: one
  summary a second is 60 of them, so this leaves ten lines a second for events around faults,
  orders of magnitude below the flood issue 42 reports (link_down every 50 ms).
- Rings lost to a cable pulled for 2 s: at most 1 on average over the seeds (the fault-free
  match's rings minus the cut one's).

Results: bench/results/soak.json, per-fault rows in bench/results/soak_details.json, each
match's run folder under --out (default runs/bench-soak/).
"""

from __future__ import annotations

import argparse
import json
import math
import statistics
import sys
import time
from concurrent.futures import ProcessPoolExecutor
from dataclasses import dataclass
from multiprocessing import get_context
from pathlib import Path
from typing import Any

import numpy as np

from bench.common import RESULTS_DIR, Result
from sim.fullstack.faults import FAULTS, read_log
from sim.fullstack.options import DEFAULT_POLICY, MatchOptions

KINDS = ("link-cut", "jetson-sigterm", "jetson-sigkill", "camera-stops", "corruption")
KINDS += ("disk-full", "brain-reboot")
LOSS_KINDS = ("link-cut", "jetson-sigterm", "jetson-sigkill")  # faults that cut off Commands
RESTART_KINDS = ("jetson-sigterm", "jetson-sigkill")
FAULT_CAMERA = (96, 72, 5.0)  # width, height, frames/s of the fault matches' camera
FIRST_FAULT_S = 3.0  # no fault before the two sides have shaken hands and settled
END_MARGIN_S = 1.0
CUT_WINDOW_S = (5.0, 95.0)  # when the ring matches' cable is pulled
FAULT_SEED_BASE = 1000  # fault matches play seeds 1000, 1001, ...: not the ring matches' seeds
STOP_TARGET_MS = 250.0
EXIT_TARGET_S = 1.0
RECONNECT_TARGET_MS = 1000.0
LOG_TARGET_PER_MIN = 600.0
RINGS_TARGET = 1.0


@dataclass(frozen=True)
class Job:
    """One match to play (picklable: matches run in worker processes)."""

    part: str  # faults | free | cut
    seed: int
    options: dict[str, Any]


def span_s(kind: str) -> float:
    """How long a scheduled fault of this kind occupies the match (fault, return, settling)."""
    cls = FAULTS[kind]
    return cls(0.0, 105.0, duration_s=cls.window_s).span_ms / 1000


def plan_faults(
    n_faults: int, per_match: int, seconds: float, seed: int = 0
) -> list[tuple[tuple[str, float], ...]]:
    """The fault matches' schedules: n_faults faults, every kind as often as the others (in a
    seeded order), per_match to a match, each at a random moment of its own slot."""
    rng = np.random.default_rng(seed)
    kinds = [KINDS[i % len(KINDS)] for i in range(n_faults)]
    rng.shuffle(kinds)
    out = []
    for first in range(0, n_faults, per_match):
        chunk = kinds[first : first + per_match]
        slot = (seconds - FIRST_FAULT_S - END_MARGIN_S) / len(chunk)
        schedule = []
        for j, kind in enumerate(chunk):
            lo = FIRST_FAULT_S + j * slot
            hi = lo + slot - span_s(kind)
            if hi < lo:
                raise SystemExit(
                    f"bench.soak: {len(chunk)} faults do not fit in {seconds:g} s matches "
                    f"({kind} needs {span_s(kind):g} s): use fewer --per-match or longer --seconds"
                )
            schedule.append((kind, round(float(rng.uniform(lo, hi)), 2)))
        out.append(tuple(schedule))
    return out


def most_per_match(seconds: float) -> int:
    longest = max(span_s(k) for k in KINDS)
    return max(1, math.floor((seconds - FIRST_FAULT_S - END_MARGIN_S) / longest))


def play(job: Job) -> dict[str, Any]:
    """Play one match (in a worker); what the soak needs of it."""
    from sim.errors import MatchError
    from sim.fullstack.runner import run_match

    o = dict(job.options)
    o["policy"] = Path(o["policy"])
    o["out"] = Path(o["out"])
    t0 = time.perf_counter()
    try:
        r = run_match(MatchOptions(**o))
    except MatchError as exc:
        return {"part": job.part, "seed": job.seed, "error": str(exc)}
    log = read_log(Path(o["out"]) / "daemon.jsonl")
    return {
        "part": job.part,
        "seed": job.seed,
        "schedule": o.get("faults") or ([(o["fault"], o["fault_at_s"])] if o.get("fault") else []),
        "rings": r.rings,
        "score": r.score,
        "sim_s": r.sim_s,
        "wall_s": time.perf_counter() - t0,
        "brain": r.brain,
        "daemon": r.daemon,
        "faults": r.faults,
        "checks_failed": [f"{c.name}: {c.detail}" for c in r.checks if not c.passed],
        "log_lines": len(log),
        "log_per_min_max": log_rate_max(log),
        "out": o["out"].as_posix(),
    }


def log_rate_max(log: list[dict[str, Any]], window_s: float = 60.0) -> float:
    """The most lines the daemon logged in any `window_s` of its clock (`t`), per minute; a log
    shorter than the window counts over its own length."""
    ts = sorted(float(e.get("t") or 0.0) for e in log)
    if not ts:
        return 0.0
    span = max(ts[-1] - ts[0], 1.0)
    w = min(window_s, span)
    most = 0
    j = 0
    for i, t in enumerate(ts):
        while ts[j] < t - w:
            j += 1
        most = max(most, i - j + 1)
    return most * 60.0 / w


def make_jobs(
    args: argparse.Namespace, schedules: list[tuple[tuple[str, float], ...]]
) -> list[Job]:
    """Every match of the soak: the fault matches, then a fault-free and a cut match a seed."""
    common: dict[str, Any] = {"policy": str(args.policy), "opponent": "planner"}
    common |= {"seconds": args.seconds, "gif": False, "plots": False}
    w, h, hz = FAULT_CAMERA
    jobs = []
    for i, schedule in enumerate(schedules):
        seed = FAULT_SEED_BASE + i
        o = {**common, "seed": seed, "faults": schedule, "daemon": "process", "record": True}
        o |= {"camera_width": w, "camera_height": h, "camera_hz": hz, "detector": "classical"}
        jobs.append(Job("faults", seed, o | {"out": str(args.out / f"faults-seed{seed}")}))
    cut_rng = np.random.default_rng(1)
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        cut_at = round(float(cut_rng.uniform(*CUT_WINDOW_S)) * min(1.0, args.seconds / 105.0), 2)
        o = {**common, "seed": seed}
        jobs.append(Job("free", seed, o | {"out": str(args.out / f"free-seed{seed}")}))
        o |= {"fault": "link-cut", "fault_at_s": cut_at, "out": str(args.out / f"cut-seed{seed}")}
        jobs.append(Job("cut", seed, o))
    return jobs


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        description=__doc__.splitlines()[0],
        epilog=__doc__.split("\n\n", 1)[1],
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    ap.add_argument("--faults", type=int, default=210, help="faults in all (default 210)")
    ap.add_argument("--per-match", type=int, default=10, help="faults per match (default 10)")
    ap.add_argument("--seeds", type=int, default=20, help="ring-match seeds (default 20)")
    ap.add_argument("--first-seed", type=int, default=0, help="first ring-match seed")
    ap.add_argument("--seconds", type=float, default=105.0, help="match length (default 105)")
    ap.add_argument("--policy", type=Path, default=DEFAULT_POLICY)
    ap.add_argument(
        "--jobs",
        type=int,
        default=2,
        help="ring matches at once (default 2; the fault matches run one at a time)",
    )
    ap.add_argument("--out", type=Path, default=Path("runs/bench-soak"))
    ap.add_argument("--results", type=Path, default=RESULTS_DIR, help="where soak.json goes")
    ap.add_argument("--strict", action="store_true", help="exit 1 when a target is missed")
    args = ap.parse_args(argv)
    if args.faults < 0 or args.seeds < 0 or args.faults + args.seeds == 0:
        ap.error("--faults and --seeds must be >= 0, and not both 0")
    if not args.per_match >= 1 or not args.jobs >= 1:
        ap.error("--per-match and --jobs must be at least 1")
    if not 10.0 <= args.seconds <= 105.0:
        ap.error("--seconds must be within 10 .. 105 (a match is 105 s)")
    if not args.policy.is_file():
        ap.error(f"no policy at {args.policy}")

    per_match = min(args.per_match, most_per_match(args.seconds))
    schedules = plan_faults(args.faults, per_match, args.seconds) if args.faults else []
    jobs = make_jobs(args, schedules)
    print(
        f"bench.soak: {len(schedules)} fault matches ({args.faults} faults, {per_match} a "
        f"match), {args.seeds} seeds x 2 ring matches, {args.seconds:g} s each, {args.jobs} at "
        "a time",
        flush=True,
    )
    t0 = time.perf_counter()
    done: list[dict[str, Any]] = []
    # The fault matches one at a time: they time SIGTERM exits on the wall clock, which a second
    # match on the same cores would slow. The ring matches may share the cores (--jobs).
    rings = [j for j in jobs if j.part != "faults"]
    for job in jobs:
        if job.part == "faults" or args.jobs == 1:
            done.append(_report(play(job)))
    if args.jobs > 1 and rings:
        with ProcessPoolExecutor(args.jobs, mp_context=get_context("spawn")) as pool:
            for got in pool.map(play, rings):
                done.append(_report(got))
    wall = time.perf_counter() - t0
    r, details = summarise(done, args, per_match, wall)
    print()
    r.report(args.results)
    path = args.results / "soak_details.json"
    path.write_text(json.dumps(details, indent=1, default=str) + "\n")
    print(f"wrote {path}")
    return 1 if args.strict and not r.all_met else 0


def _report(m: dict[str, Any]) -> dict[str, Any]:
    if "error" in m:
        print(f"{m['part']:<6} seed {m['seed']:4d}  FAILED TO RUN: {m['error']}", flush=True)
        return m
    bad = len(m["checks_failed"])
    print(
        f"{m['part']:<6} seed {m['seed']:4d}  faults {len(m['faults']):2d}  rings {m['rings']:3d}  "
        f"log {m['log_per_min_max']:5.0f}/min  checks failed {bad:2d}  wall {m['wall_s']:5.1f} s",
        flush=True,
    )
    for line in m["checks_failed"][:5]:
        print(f"    {line[:160]}", flush=True)
    return m


def _max(values: list[float]) -> float | None:
    return max(values) if values else None


def summarise(
    done: list[dict[str, Any]], args: argparse.Namespace, per_match: int, wall_s: float
) -> tuple[Result, dict[str, Any]]:
    ok = [m for m in done if "error" not in m]
    fault_matches = [m for m in ok if m["part"] == "faults"]
    records = [{**f, "seed": m["seed"]} for m in ok for f in m["faults"]]
    injected = [f for f in records if f["kind"] in KINDS]
    fault_records = [f for m in fault_matches for f in m["faults"]]

    r = Result("soak")
    r.add("faults_injected", len(fault_records))
    for kind in KINDS:
        r.add(f"faults_{kind.replace('-', '_')}", sum(f["kind"] == kind for f in fault_records))
    r.add("fault_matches", len(fault_matches))
    r.add("fault_checks_failed", sum(len(f["failed"]) for f in fault_records))
    r.add("ring_seeds", args.seeds)
    r.add("match_seconds", args.seconds)
    r.add("matches_failed_to_run", len(done) - len(ok))
    w, h, hz = FAULT_CAMERA
    r.add("fault_match_camera_width", w)
    r.add("fault_match_camera_height", h)
    r.add("fault_match_camera_hz", hz)

    r.add(
        "motor_steps_invalid_command", sum(m["brain"].get("invalid_command_steps", 0) for m in ok)
    )
    r.add("motor_steps_jetson", sum(m["brain"].get("jetson_steps", 0) for m in ok))
    ages = [m["brain"].get("max_command_age_ms", 0) for m in ok]
    if ages:
        r.add("command_age_max_ms", max(ages))

    # Something that never happened (a robot that never stopped, a daemon that never came
    # back) counts as the whole match: the worst value, and its target missed.
    never = args.seconds * 1000.0
    stops = [f["stop_after_fault_ms"] for f in injected if f["kind"] in LOSS_KINDS]
    r.add("command_losses", len(stops))
    lost_driving = [f for f in injected if f["kind"] in LOSS_KINDS and f.get("driven_at_fault")]
    r.add("command_losses_while_driving", len(lost_driving))
    r.add("command_losses_never_stopped", sum(s is None for s in stops))
    if stops:
        stops_ms = [never if s is None else s for s in stops]
        r.add("stop_after_command_loss_ms_max", max(stops_ms))
        r.add("stop_after_command_loss_ms_median", statistics.median(stops_ms))

    terms = [f for f in fault_records if f["kind"] == "jetson-sigterm"]
    exits = [args.seconds if f.get("exit_s") is None else f["exit_s"] for f in terms]
    r.add("sigterms", len(terms))
    if exits:
        r.add("sigterm_exit_s_max", max(exits))
        r.add("sigterm_exit_s_median", statistics.median(exits))
    r.add("sigterm_forced_kills", sum(bool(f.get("forced")) for f in terms))
    r.add("sigterm_exits_without_stop", sum(not f.get("stop_sent") for f in terms))

    def reconnects(kinds: tuple[str, ...]) -> list[float | None]:
        return [f.get("reconnect_ms") for f in injected if f["kind"] in kinds]

    for name, kinds in (
        ("cable", ("link-cut",)),
        ("restart", RESTART_KINDS),
        ("reboot", ("brain-reboot",)),
    ):
        got = [never if x is None else x for x in reconnects(kinds)]
        if got:
            r.add(f"reconnect_after_{name}_ms_max", max(got))
            r.add(f"reconnect_after_{name}_ms_median", statistics.median(got))

    rates = [m["log_per_min_max"] for m in ok]
    if rates:
        r.add("log_lines_per_min_max", max(rates))
        r.add("log_lines_per_min_median", statistics.median(rates))

    free = {m["seed"]: m["rings"] for m in ok if m["part"] == "free"}
    cut = {m["seed"]: m["rings"] for m in ok if m["part"] == "cut"}
    seeds = sorted(set(free) & set(cut))
    if seeds:
        diffs = [free[s] - cut[s] for s in seeds]
        r.add("rings_fault_free_mean", statistics.fmean(free[s] for s in seeds))
        r.add("rings_cable_pulled_mean", statistics.fmean(cut[s] for s in seeds))
        r.add("rings_lost_to_cable_pull_mean", statistics.fmean(diffs))
        r.add("rings_diff_abs_mean", statistics.fmean(abs(d) for d in diffs))

    starts = [s for m in fault_matches for s in m["daemon"].get("start_wall_s", [])]
    if starts:
        r.add("daemon_start_wall_s_median", statistics.median(starts))
    for part, key in (
        ("faults", "fault_match_wall_s_median"),
        ("free", "ring_match_wall_s_median"),
    ):
        walls = [m["wall_s"] for m in ok if m["part"] == part]
        if walls:
            r.add(key, statistics.median(walls))
    r.add("soak_wall_s", wall_s)

    r.target("motor_steps_invalid_command", 0, "<=")
    r.target("stop_after_command_loss_ms_max", STOP_TARGET_MS, "<=")
    r.target("sigterm_exit_s_max", EXIT_TARGET_S, "<=")
    r.target("sigterm_exits_without_stop", 0, "<=")
    r.target("reconnect_after_cable_ms_max", RECONNECT_TARGET_MS, "<=")
    r.target("log_lines_per_min_max", LOG_TARGET_PER_MIN, "<=")
    r.target("rings_lost_to_cable_pull_mean", RINGS_TARGET, "<=")

    settings = {
        "command": "python -m bench.soak " + " ".join(sys.argv[1:]),
        "faults": args.faults,
        "per_match": per_match,
        "seeds": args.seeds,
        "first_seed": args.first_seed,
        "seconds": args.seconds,
        "jobs": args.jobs,
        "policy": str(args.policy),
        "opponent": "planner",
        "fault_matches": f"daemon as a process, recording, camera {w}x{h} at {hz:g} Hz, "
        "classical detector",
        "ring_matches": "pete-sim match defaults (in-process daemon, camera 240x180 at 10 Hz)",
    }
    details = {
        "settings": settings,
        "matches": [
            {k: v for k, v in m.items() if k not in ("brain", "daemon", "faults")}
            | {"exits": (m.get("daemon") or {}).get("exits")}
            for m in done
        ],
        "faults": records,
        "rings": [{"seed": s, "fault_free": free[s], "cable_pulled": cut[s]} for s in seeds],
    }
    return r, details


if __name__ == "__main__":
    sys.exit(main())
