"""Benchmark of the alliance: the learned alliance against the scripted one in the twin, and the
scripted alliance on the full stack (both red robots with their own Brain, daemon and camera,
talking over VEXlink) against the blue alliance in the twin.

    python -m bench.alliance [--part all|learned|stack] [--learned POLICY]
                             [--learned-matches 100] [--fidelity high] [--ray ADDRESS]
                             [--seeds 3] [--strict]

The learned alliance (`--learned`, default jetson/models/alliance/policy.onnx: one skill policy
on both robots, trained with sim/configs/alliance.toml) plays `--learned-matches` whole-game 2v2
matches (tipping_point_2v2) against the scripted alliance (the robots' own strategy,
jetson/autonomy/alliance.py), sides swapped per seed, in `--fidelity` (default high), here
or with `--ray ADDRESS` as tasks on a Ray cluster (`local`: one on this machine, a process a
core). Measured:

- its win rate (target >= 0.7) and its mean score over the scripted alliance's (target >= 1.1);
- collisions between its two robots, per match (target <= 1: sim.evaluate counts each time the
  partners come into contact);
- against itself, how far red's win rate is from one half (target <= 0.1: neither side of the
  field is favoured);
  and against the ring-race alliance (for the record).

Without a learned policy these rows are not measured (their targets not met).

For each full-stack seed, one lockstep whole-game match (`pete-sim match --world
tipping_point_2v2 --opponent alliance --partner stack`: the scripted alliance on both robots'
Jetsons, the scripted alliance in blue), and the same seeds played by the twin alone
(sim.evaluate: the scripted alliance on both sides at the policy rate). Then one match with
`--fault vexlink-lost`. Measured:

- wall-clock time of one lockstep full-stack 2v2 match on this machine (target <= 120 s; the
  median over the seeds, the worst beside it);
- red's score on the full stack over the twin's own for the same alliance on the same seeds
  (target >= 0.9: what perception, latency, the wire and the radio cost it);
- VEXlink: frames sent, the share lost and the number late (later than 250 ms), the largest
  delay; the share of the match the partner's Jetson drove;
- the vexlink-lost match: whether both robots said they play alone within 1.5 s and drove on.

Results: bench/results/alliance.json, each match's figures in alliance_details.json; the run
folders under --out (default runs/bench-alliance/).
"""

from __future__ import annotations

import argparse
import json
import statistics
import sys
import time
from contextlib import nullcontext
from pathlib import Path

from bench.common import RESULTS_DIR, Result
from jetson.models import ALLIANCE_POLICY
from sim.errors import ClusterError, EvalError, MatchError
from sim.evaluate import PlayerSpec, SeriesRunner, Summary
from sim.fullstack.options import MatchOptions
from sim.fullstack.runner import run_match
from sim.training.ray_cli import ray_backend

WORLD = "tipping_point_2v2"
WALL_TARGET_S = 120.0
SCORE_RATIO_TARGET = 0.9
FAULT_AT_S = 30.0
LEARNED = ALLIANCE_POLICY
RING_RACE = "planner-collector,scripted"  # sim.baselines.alliance's ring-race alliance
WIN_TARGET = 0.7
SCORE_OVER_SCRIPTED_TARGET = 1.1
COLLISIONS_TARGET = 1.0
SELF_PLAY_OFF_HALF_TARGET = 0.1


def learned_rows(
    r: Result,
    policy: Path,
    matches: int,
    fidelity: str,
    seconds: float | None = None,
    seed: int = 1000,
    runner: SeriesRunner | None = None,
) -> dict[str, object]:
    """The learned alliance's rows (module docstring) into `r`, in matches of `seconds` (None:
    whole matches), played by `runner` (None: here); each series' summary returned for the
    details file."""
    from sim.config import world_preset
    from sim.evaluate import evaluate, load_side

    learned, scripted = load_side(str(policy)), load_side("alliance")
    few = max(2, matches // 4)
    out: dict[str, object] = {}
    t0 = time.perf_counter()
    cut = None
    if seconds is not None:
        cut = {"max_steps": max(1, round(seconds * world_preset(WORLD).control_hz))}

    def series(a: tuple[PlayerSpec, ...], b: tuple[PlayerSpec, ...], n: int) -> Summary:
        return evaluate(a, b, n, seed, fidelity=fidelity, world=WORLD, base_env=cut, runner=runner)

    vs = series(learned, scripted, matches)
    mine = statistics.fmean(m.score[0] for m in vs.matches)
    theirs = statistics.fmean(m.score[1] for m in vs.matches)
    r.add("learned_matches", matches)
    r.add("learned_high_fidelity", float(fidelity == "high"))
    r.add("learned_vs_scripted_win_rate", round(vs.win_rate, 3))
    r.add("learned_score_mean", round(mine, 1))
    r.add("scripted_score_mean", round(theirs, 1))
    r.add("learned_score_over_scripted", round(mine / theirs, 3) if theirs else 0.0)
    collisions = statistics.fmean(m.partner_collisions[0] for m in vs.matches)
    r.add("learned_partner_collisions_per_match", round(collisions, 2))
    r.add("scripted_partner_collisions_per_match", round(
        statistics.fmean(m.partner_collisions[1] for m in vs.matches), 2
    ))  # fmt: skip
    print(vs.table(), flush=True)
    out["vs_scripted"] = vs.as_dict()
    # Against itself each seed is played twice, the same match with the sides' names swapped:
    # what can differ from one half is the share red wins (a field or a policy that favours a
    # side), a draw counting half.
    itself = series(learned, learned, few)
    red = [m.result if m.a_alliance == "red" else 1.0 - m.result for m in itself.matches]
    red_rate = statistics.fmean(red)
    r.add("learned_self_play_red_win_rate", round(red_rate, 3))
    r.add("learned_self_play_off_half", round(abs(red_rate - 0.5), 3))
    out["vs_itself"] = itself.as_dict()
    race = series(learned, load_side(RING_RACE), few)
    r.add("learned_vs_ring_race_win_rate", round(race.win_rate, 3))
    print(race.table(), flush=True)
    out["vs_ring_race"] = race.as_dict()
    r.add("learned_wall_s", round(time.perf_counter() - t0, 1))
    return out


def learned_targets(r: Result) -> None:
    r.target("learned_vs_scripted_win_rate", WIN_TARGET, ">=")
    r.target("learned_score_over_scripted", SCORE_OVER_SCRIPTED_TARGET, ">=")
    r.target("learned_partner_collisions_per_match", COLLISIONS_TARGET, "<=")
    r.target("learned_self_play_off_half", SELF_PLAY_OFF_HALF_TARGET, "<=")


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


def stack_rows(r: Result, args: argparse.Namespace) -> list[dict[str, object]]:
    """The scripted alliance on the full stack (module docstring) into `r`; each match's row."""
    seeds = list(range(args.first_seed, args.first_seed + args.seeds))
    walls: list[float] = []
    scores: list[float] = []
    frames = lost = late = 0
    max_delay = 0.0
    shares: list[float] = []
    rows: list[dict[str, object]] = []
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
    r.target("full_stack_2v2_wall_s_median", WALL_TARGET_S, "<=")
    r.target("full_stack_score_over_twin", SCORE_RATIO_TARGET, ">=")
    r.target("vexlink_lost_both_play_alone", 1.0, ">=")
    r.target("vexlink_lost_both_drive_on", 1.0, ">=")
    return rows


def _learned_key(key: str) -> bool:
    return key.startswith(("learned_", "scripted_"))


def _keep_other_part(r: Result, results: Path, name: str, part: str) -> dict[str, object]:
    """A part run alone keeps the other part's rows of the last run (its metrics, targets and
    details) in the result files."""
    path = results / f"{name}.json"
    old_details = results / f"{name}_details.json"
    try:
        old = json.loads(path.read_text())
        details = json.loads(old_details.read_text()) if old_details.is_file() else {}
    except (OSError, ValueError):
        return {}
    other = (lambda k: not _learned_key(k)) if part == "learned" else _learned_key
    for key, value in old.get("metrics", {}).items():
        if other(key) and key != "bench_wall_s" and key not in r.metrics:
            r.add(key, value)
    for key, t in old.get("targets", {}).items():
        if other(key) and key not in r.targets:
            r.target(key, t["target"], t["op"])
    keep = "matches" if part == "learned" else "learned"
    return {keep: details[keep]} if keep in details else {}


def main(argv: list[str] | None = None) -> int:
    ap = argparse.ArgumentParser(
        description=__doc__.splitlines()[0], formatter_class=argparse.RawDescriptionHelpFormatter
    )
    ap.add_argument(
        "--part", choices=("all", "learned", "stack"), default="all",
        help="the learned alliance's rows, the full stack's, or both (default)",
    )  # fmt: skip
    ap.add_argument(
        "--learned",
        type=Path,
        default=LEARNED,
        help="its policy.onnx (default: the shipped one, jetson/models/alliance/)",
    )
    ap.add_argument("--learned-matches", type=int, default=100, help="default 100")
    ap.add_argument("--fidelity", choices=("training", "high"), default="high")
    ap.add_argument(
        "--ray", metavar="ADDRESS", default=None,
        help="play the learned alliance's matches as tasks on a Ray cluster (local: this machine)",
    )  # fmt: skip
    ap.add_argument("--seeds", type=int, default=3, help="full-stack matches (default 3)")
    ap.add_argument("--first-seed", type=int, default=0)
    ap.add_argument("--seconds", type=float, default=None, help="shorter matches (a quick look)")
    ap.add_argument("--out", type=Path, default=Path("runs/bench-alliance"))
    ap.add_argument("--results", type=Path, default=RESULTS_DIR, help="where alliance.json goes")
    ap.add_argument("--name", default="alliance", help="result file name")
    ap.add_argument("--strict", action="store_true", help="exit 1 when a target is missed")
    args = ap.parse_args(argv)
    if args.seeds < 1 or args.learned_matches < 2:
        ap.error("--seeds must be at least 1 and --learned-matches at least 2")
    t0 = time.perf_counter()
    r = Result(args.name)
    details: dict[str, object] = {}
    try:
        if args.part in ("all", "learned"):
            if args.learned.is_file():
                cluster = ray_backend(args.ray)
                with cluster or nullcontext():
                    details["learned"] = learned_rows(
                        r, args.learned, args.learned_matches, args.fidelity, args.seconds,
                        runner=None if cluster is None else cluster.play,
                    )  # fmt: skip
            else:
                print(f"bench.alliance: no learned alliance at {args.learned}: not measured")
            learned_targets(r)
        if args.part in ("all", "stack"):
            details["matches"] = stack_rows(r, args)
    except (MatchError, EvalError, ClusterError) as exc:
        print(f"bench.alliance: {exc}", file=sys.stderr)
        return 2
    r.add("bench_wall_s", round(time.perf_counter() - t0, 1))
    if args.part != "all":
        details = {**_keep_other_part(r, args.results, args.name, args.part), **details}
    print()
    path = r.report(args.results)
    out = path.with_name(f"{args.name}_details.json")
    out.write_text(json.dumps(details, indent=1, default=str) + "\n")
    print(f"wrote {out}")
    return 1 if args.strict and not r.all_met else 0


if __name__ == "__main__":
    sys.exit(main())
