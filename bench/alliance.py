"""Benchmark of the alliance on the full stack: both red robots with their own Brain, daemon and
camera, talking over VEXlink, against the blue alliance in the twin.

    python -m bench.alliance [--seeds 3] [--first-seed 0] [--seconds S] [--strict]

For each seed, one lockstep whole-game match (`pete-sim match --world tipping_point_2v2
--opponent alliance --partner stack`: the scripted alliance on both robots' Jetsons, the scripted
alliance in blue), and the same seeds played by the twin alone (sim.evaluate: the scripted
alliance on both sides at the policy rate). Then one match with `--fault vexlink-lost`.
Measured:

- wall-clock time of one lockstep full-stack 2v2 match on this machine (target <= 120 s; the
  median over the seeds, the worst beside it);
- red's score on the full stack over the twin's own for the same alliance on the same seeds
  (target >= 0.9: what perception, latency, the wire and the radio cost it);
- VEXlink: frames sent, the share lost and the number late (later than 250 ms), the largest
  delay; the share of the match the partner's Jetson drove;
- the vexlink-lost match: whether both robots said they play alone within 1.5 s and drove on.

The learned alliance's targets (win rate and score against the scripted alliance in high
fidelity, partner collisions) are issue 46's and wait for the learned alliance; they are not
measured here yet.

Results: bench/results/alliance.json, each match's figures in alliance_details.json; the run
folders under --out (default runs/bench-alliance/).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from pathlib import Path

from bench.common import RESULTS_DIR, Result
from sim.errors import EvalError, MatchError
from sim.fullstack.options import MatchOptions
from sim.fullstack.runner import run_match

WORLD = "tipping_point_2v2"
WALL_TARGET_S = 120.0
SCORE_RATIO_TARGET = 0.9
FAULT_AT_S = 30.0


def _twin_red_scores(seeds: list[int]) -> list[float]:
    """Red's score in the twin's own matches of the scripted alliances on these seeds."""
    from sim.evaluate import evaluate, load_side

    side = load_side("alliance")
    out = []
    for seed in seeds:
        summary = evaluate(side, side, 1, seed, world=WORLD)  # match 0: A on red
        (record,) = summary.matches
        out.append(record.score[0])
    return out


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument("--seeds", type=int, default=3, help="full-stack matches (default 3)")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--seconds", type=float, default=None, help="shorter matches (a quick look)")
    ap.add_argument("--out", type=Path, default=Path("runs/bench-alliance"))
    ap.add_argument("--results", type=Path, default=RESULTS_DIR, help="where alliance.json goes")
    ap.add_argument("--name", default="alliance", help="result file name")
    ap.add_argument("--strict", action="store_true", help="exit 1 when a target is missed")
    args = ap.parse_args(argv)
    if args.seeds < 1:
        ap.error("--seeds must be at least 1")
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    t0 = time.perf_counter()
    walls: list[float] = []
    scores: list[float] = []
    frames = lost = late = 0
    max_delay = 0.0
    shares: list[float] = []
    rows: list[dict[str, object]] = []
    try:
        for seed in seeds:
            result = run_match(
                MatchOptions(
                    seed=seed, world=WORLD, opponent="alliance", partner="stack",
                    seconds=args.seconds, gif=False, plots=False, out=args.out / f"seed{seed}",
                )
            )  # fmt: skip
            p = result.partner or {}
            v = p.get("vexlink", {})
            walls.append(result.wall_s)
            scores.append(result.score)
            frames += v.get("frames", 0)
            lost += v.get("lost", 0)
            late += v.get("late", 0)
            max_delay = max(max_delay, v.get("max_delay_ms", 0.0))
            if p.get("jetson_share") is not None:
                shares.append(p["jetson_share"])
            rows.append(
                {
                    "seed": seed, "red": result.score, "blue": result.opponent_score,
                    "wall_s": round(result.wall_s, 1), "vexlink": v, "game": result.game,
                }
            )  # fmt: skip
            print(
                f"seed {seed}: red {result.score} - blue {result.opponent_score}, "
                f"wall {result.wall_s:.1f} s, VEXlink {v.get('delivered', 0)} of "
                f"{v.get('frames', 0)} frames delivered",
                flush=True,
            )
        twin = _twin_red_scores(seeds) if args.seconds is None else []
        for row, score in zip(rows, twin, strict=False):
            row["red_twin"] = score
        fault_at = min(FAULT_AT_S, (args.seconds or 105.0) / 3)
        lost_match = run_match(
            MatchOptions(
                seed=seeds[0], world=WORLD, opponent="alliance", partner="stack",
                seconds=args.seconds, fault="vexlink-lost", fault_at_s=fault_at, camera=False,
                gif=False, plots=False, out=args.out / "vexlink-lost",
            )
        )  # fmt: skip
    except (MatchError, EvalError) as exc:
        print(f"bench.alliance: {exc}", file=sys.stderr)
        return 2

    r = Result(args.name)
    r.add("matches", len(seeds))
    r.add("match_seconds", args.seconds or 105.0)
    r.add("full_stack_2v2_wall_s_median", round(statistics.median(walls), 1))
    r.add("full_stack_2v2_wall_s_max", round(max(walls), 1))
    r.add("red_score_full_stack_mean", statistics.fmean(scores))
    if twin:
        r.add("red_score_twin_mean", statistics.fmean(twin))
        ratio = statistics.fmean(scores) / statistics.fmean(twin) if statistics.fmean(twin) else 0
        r.add("full_stack_score_over_twin", round(ratio, 3))
    r.add("vexlink_frames", frames)
    r.add("vexlink_lost_share", round(lost / frames, 4) if frames else 0.0)
    r.add("vexlink_late", late)
    r.add("vexlink_max_delay_ms", round(max_delay, 1))
    if shares:
        r.add("partner_jetson_share_min", min(shares))
    checks = {c.name: c.passed for c in lost_match.checks}
    r.add("vexlink_lost_both_play_alone", float(checks.get("both_play_alone", False)))
    r.add("vexlink_lost_both_drive_on", float(checks.get("both_drive_on", False)))
    r.add("bench_wall_s", round(time.perf_counter() - t0, 1))
    r.target("full_stack_2v2_wall_s_median", WALL_TARGET_S, "<=")
    if twin:
        r.target("full_stack_score_over_twin", SCORE_RATIO_TARGET, ">=")
    r.target("vexlink_lost_both_play_alone", 1.0, ">=")
    r.target("vexlink_lost_both_drive_on", 1.0, ">=")
    print()
    path = r.report(args.results)
    details = path.with_name(f"{args.name}_details.json")
    details.write_text(json.dumps({"matches": rows}, indent=1, default=str) + "\n")
    print(f"wrote {details}")
    return 1 if args.strict and not r.all_met else 0


if __name__ == "__main__":
    sys.exit(main())
