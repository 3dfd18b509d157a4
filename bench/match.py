"""Benchmark of the full-stack match: what perception, latency and the wire cost the policy.

    python -m bench.match [--seeds 20] [--first-seed 0] [--policy PATH] [--seconds S] [--strict]

For each seed, one lockstep match with --stack full (brain_host + the cable + the Jetson daemon
with perception on rendered frames) and one with --stack sim (the same policy straight in the
simulator at 12 Hz, as `pete-sim eval` plays it), both against the planner. Measured:

- rings per match, full stack / sim stack (target: >= 0.9, the gap perception, latency and the
  wire may cost), and the same for the match score (reported, no target);
- wall-clock time of one lockstep full-stack match on this machine (target: <= 60 s; the median
  over the seeds, the worst is reported beside it);
- loop latency: the daemon's State-bytes-in to Command-bytes-out time, p50 and p99 over every
  State of every match (target p99 <= 10 ms: one Brain loop period);
- perception F1 against the simulator's ground truth, and messages lost or rejected (0 expected:
  no faults are injected).

Results: bench/results/match.json; each match's run folder under --out (default
runs/bench-match/).
"""

from __future__ import annotations

import argparse
import statistics
import sys
import time
from pathlib import Path

import numpy as np

from bench.common import RESULTS_DIR, Result
from sim.errors import MatchError
from sim.fullstack.options import DEFAULT_POLICY, MatchOptions
from sim.fullstack.runner import run_match

RATIO_TARGET = 0.9
WALL_TARGET_S = 60.0
LATENCY_P99_TARGET_MS = 10.0


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--seeds", type=int, default=20, help="matches per stack (default 20)")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--policy", type=Path, default=DEFAULT_POLICY)
    ap.add_argument("--opponent", default="planner")
    ap.add_argument("--seconds", type=float, default=None, help="shorter matches (a quick look)")
    ap.add_argument("--out", type=Path, default=Path("runs/bench-match"))
    ap.add_argument("--results", type=Path, default=RESULTS_DIR, help="where match.json goes")
    ap.add_argument("--strict", action="store_true", help="exit 1 when a target is missed")
    args = ap.parse_args(argv)
    if args.seeds < 1:
        ap.error("--seeds must be at least 1")

    rings: dict[str, list[int]] = {"full": [], "sim": []}
    scores: dict[str, list[int]] = {"full": [], "sim": []}
    walls: list[float] = []
    latencies: list[float] = []
    f1s: list[float] = []
    lost = rejected = 0
    t0 = time.perf_counter()
    for seed in range(args.first_seed, args.first_seed + args.seeds):
        for stack in ("full", "sim"):
            try:
                result = run_match(
                    MatchOptions(
                        stack=stack, seed=seed, policy=args.policy, opponent=args.opponent,
                        seconds=args.seconds, gif=False, plots=False,
                        out=args.out / f"{stack}-seed{seed}",
                    )
                )  # fmt: skip
            except MatchError as exc:
                print(f"bench.match: {exc}", file=sys.stderr)
                return 2
            rings[stack].append(result.rings)
            scores[stack].append(result.score)
            if stack == "full":
                walls.append(result.wall_s)
                latencies.extend(_daemon_latencies(result))
                if result.perception and result.perception.get("f1") is not None:
                    f1s.append(result.perception["f1"])
                for way in ("up", "down"):
                    lost += result.messages[way]["lost"]
                    rejected += result.messages[way]["rejected"]
            print(
                f"seed {seed} {stack:<4}  rings {result.rings:3d}  score {result.score:4d}  "
                f"wall {result.wall_s:5.1f} s",
                flush=True,
            )

    full, sim = statistics.fmean(rings["full"]), statistics.fmean(rings["sim"])
    r = Result("match")
    r.add("matches_per_stack", args.seeds)
    r.add("match_seconds", args.seconds or 105.0)
    r.add("rings_full_mean", full)
    r.add("rings_sim_mean", sim)
    r.add("rings_full_over_sim", full / sim if sim > 0 else 0.0)
    # A policy that loads goals and parks plays for the score, not the ring count: the score is
    # the other half of what the full stack costs it.
    s_full, s_sim = statistics.fmean(scores["full"]), statistics.fmean(scores["sim"])
    r.add("score_full_mean", s_full)
    r.add("score_sim_mean", s_sim)
    r.add("score_full_over_sim", s_full / s_sim if s_sim > 0 else 0.0)
    r.add("lockstep_wall_s_median", statistics.median(walls))
    r.add("lockstep_wall_s_max", max(walls))
    if latencies:
        ms = np.asarray(latencies) * 1e3
        r.add("loop_latency_p50_ms", float(np.percentile(ms, 50)))
        r.add("loop_latency_p99_ms", float(np.percentile(ms, 99)))
        r.add("loop_latency_max_ms", float(ms.max()))
    if f1s:
        r.add("perception_f1_mean", statistics.fmean(f1s))
    r.add("messages_lost", lost)
    r.add("messages_rejected", rejected)
    r.add("bench_wall_s", time.perf_counter() - t0)
    r.target("rings_full_over_sim", RATIO_TARGET, ">=")
    r.target("lockstep_wall_s_median", WALL_TARGET_S, "<=")
    r.target("loop_latency_p99_ms", LATENCY_P99_TARGET_MS, "<=")
    print()
    r.report(args.results)
    print(f"rings per seed: full {rings['full']}, sim {rings['sim']}")
    return 1 if args.strict and not r.all_met else 0


def _daemon_latencies(result: object) -> list[float]:
    """Every State -> Command latency of a match (seconds), from its run folder: percentiles
    are pooled over all matches, not averaged."""
    import json

    name = getattr(result, "files", {}).get("latencies")
    if not name or not Path(name).is_file():
        return []
    return [ms / 1e3 for ms in json.loads(Path(name).read_text())]


if __name__ == "__main__":
    sys.exit(main())
