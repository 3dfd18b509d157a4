"""Benchmark of the pose through GPS dropouts: the scripted alliance's score with the field strip
hidden as on a real field, against a GPS that never fails.

    python -m bench.dropouts [--seeds 10] [--first-seed 0] [--seconds S] [--jobs 2] [--strict]
    python -m bench.dropouts --collect [--seeds N] [--out DIR]   # the matches already played there

For each seed, two lockstep full-stack matches of the whole game (`pete-sim match --world
tipping_point_2v2 --opponent alliance`: the red 24" is brain_host, the wire and the daemon running
the scripted alliance; the other robots play in the twin), the same in all but the GPS: once as
before (it always sees the strip), once with `--gps-occlusion` (sim.world.sensors.GpsOcclusion:
robots, goals and the platforms hide the strip, the GPS's range limits and error apply), where
the Brain's pose filter rides through on odometry and the IMU and the daemon drives while the
Brain trusts its pose.

Metrics: red's mean score each way and their ratio (target: >= 0.95, issue 44: within 5 % of a
perfect GPS), the paired differences (mean, standard deviation, standard error), the share of the
match the GPS was hidden, the pose's error against the truth with dropouts (mean and worst) and
the largest standard deviation the Brain reported for it, the steps the pose rested on odometry,
and the daemon's stops for a lost pose. Results: bench/results/dropouts.json; each match's run
folder under --out, and every match's numbers in --out/seeds.json. `--collect` plays nothing: it
reads the matches an earlier (or interrupted) run left under --out, each seed whose two matches
both finished, and reports them the same way.
"""

from __future__ import annotations

import argparse
import json
import multiprocessing
import statistics
import sys
from pathlib import Path
from typing import Any

from bench.common import RESULTS_DIR, Result

SCORE_RATIO_TARGET = 0.95
WORLD = "tipping_point_2v2"


def _pose_stops(folder: Path) -> int:
    """The daemon's stops for its pose (it logs each stop once as it starts: event "decision",
    its reason)."""
    stops = 0
    log = folder / "daemon.jsonl"
    if log.is_file():
        for line in log.read_text().splitlines():
            rec = json.loads(line)
            reason = str(rec.get("reason", ""))
            if rec.get("event") == "decision" and reason.startswith(("pose", "gps")):
                stops += 1
    return stops


def one_match(job: tuple[int, bool, float | None, str]) -> dict[str, Any]:
    """One full-stack match (in a worker process): what the benchmark keeps of it."""
    from sim.fullstack.options import MatchOptions
    from sim.fullstack.runner import run_match

    seed, occluded, seconds, out = job
    folder = Path(out) / f"seed{seed}-{'occluded' if occluded else 'clear'}"
    result = run_match(
        MatchOptions(
            seed=seed, world=WORLD, opponent="alliance", gps_occlusion=occluded,
            seconds=seconds, gif=False, plots=False, out=folder,
        )
    )  # fmt: skip
    stops = _pose_stops(folder)
    pose = (result.brain or {}).get("pose", {})
    return {
        "seed": seed,
        "occluded": occluded,
        "score": result.score,
        "opponent_score": result.opponent_score,
        "passed": result.passed,
        "pose": pose,
        "pose_stops": stops,
        "wall_s": result.wall_s,
    }


def collected(job: tuple[int, bool, float | None, str]) -> dict[str, Any] | None:
    """What the benchmark keeps of a match an earlier run played into --out (None: it did not
    finish there)."""
    seed, occluded, _seconds, out = job
    folder = Path(out) / f"seed{seed}-{'occluded' if occluded else 'clear'}"
    summary = folder / "summary.json"
    if not summary.is_file():
        return None
    data = json.loads(summary.read_text())
    return {
        "seed": seed,
        "occluded": occluded,
        "score": data["score"],
        "opponent_score": data["opponent_score"],
        "passed": data["passed"],
        "pose": (data.get("brain") or {}).get("pose", {}),
        "pose_stops": _pose_stops(folder),
        "wall_s": data["wall_s"],
    }


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--seeds", type=int, default=10, help="seeds, each played both ways")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--seconds", type=float, default=None, help="shorter matches (a quick look)")
    ap.add_argument("--jobs", type=int, default=2, help="matches side by side")
    ap.add_argument("--out", type=Path, default=Path("runs/bench-dropouts"))
    ap.add_argument("--results", type=Path, default=RESULTS_DIR, help="where dropouts.json goes")
    ap.add_argument("--strict", action="store_true", help="exit 1 when a target is missed")
    ap.add_argument(
        "--collect", action="store_true",
        help="play nothing: report the seeds whose two matches finished under --out",
    )  # fmt: skip
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.jobs < 1:
        ap.error("--seeds and --jobs must be at least 1")
    asked = range(args.first_seed, args.first_seed + args.seeds)
    jobs = [(s, occ, args.seconds, str(args.out)) for s in asked for occ in (False, True)]
    runs = []
    if args.collect:
        found = [r for job in jobs if (r := collected(job)) is not None]
        done = {r["seed"] for r in found if r["occluded"]} & {
            r["seed"] for r in found if not r["occluded"]
        }
        runs = [r for r in found if r["seed"] in done]
        seeds = [s for s in asked if s in done]
        if not seeds:
            ap.error(f"no seed finished both ways under {args.out}")
        print(f"  collected {len(seeds)} seeds from {args.out}: {seeds}", flush=True)
    else:
        seeds = list(asked)
        ctx = multiprocessing.get_context("spawn")
        with ctx.Pool(args.jobs) as pool:
            for i, r in enumerate(pool.imap_unordered(one_match, jobs), 1):
                runs.append(r)
                way = "occluded" if r["occluded"] else "clear"
                print(f"  {i}/{len(jobs)} seed {r['seed']} {way}: red {r['score']}", flush=True)
    by = {(r["seed"], r["occluded"]): r for r in runs}
    args.out.mkdir(parents=True, exist_ok=True)
    ordered = [by[(s, occ)] for s in seeds for occ in (False, True)]
    (args.out / "seeds.json").write_text(json.dumps(ordered, indent=1) + "\n")
    clear = [by[(s, False)]["score"] for s in seeds]
    occl = [by[(s, True)]["score"] for s in seeds]
    result = Result("dropouts")
    result.add("seeds", len(seeds))
    result.add("match_s", args.seconds or 120.0)
    result.add("red_score_clear", round(statistics.fmean(clear), 2))
    result.add("red_score_occluded", round(statistics.fmean(occl), 2))
    mean_clear = statistics.fmean(clear)
    result.add("score_ratio", round(statistics.fmean(occl) / mean_clear, 4) if mean_clear else 0.0)
    diffs = [o - c for o, c in zip(occl, clear, strict=True)]
    result.add("paired_difference_mean", round(statistics.fmean(diffs), 2))
    if len(diffs) > 1:
        result.add("paired_difference_stdev", round(statistics.stdev(diffs), 2))
        stderr = statistics.stdev(diffs) / len(diffs) ** 0.5
        result.add("paired_difference_stderr", round(stderr, 2))
    occluded = [by[(s, True)] for s in seeds]
    steps = sum(r["pose"].get("steps", 0) for r in occluded)
    hidden = sum(r["pose"].get("gps_hidden_steps", 0) for r in occluded)
    odo = sum(r["pose"].get("by_fix", {}).get("odometry", 0) for r in occluded)
    result.add("gps_hidden_share", round(hidden / steps, 4) if steps else 0.0)
    result.add("pose_on_odometry_share", round(odo / steps, 4) if steps else 0.0)
    errs = [e for r in occluded if (e := r["pose"].get("error_mean_m")) is not None]
    if errs:
        result.add("pose_error_mean_m", round(statistics.fmean(errs), 4))
    worst = max(r["pose"].get("error_max_m", 0.0) for r in occluded)
    result.add("pose_error_max_m", round(worst, 4))
    result.add("pose_std_max_m", round(max(r["pose"].get("std_max_m", 0.0) for r in occluded), 4))
    result.add("pose_stops", sum(r["pose_stops"] for r in occluded))
    result.add("checks_failed", sum(not r["passed"] for r in runs))
    result.target("score_ratio", SCORE_RATIO_TARGET, ">=")
    result.target("checks_failed", 0, "<=")
    result.report(args.results)
    return 1 if args.strict and not result.all_met else 0


if __name__ == "__main__":
    sys.exit(main())
