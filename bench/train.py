"""Benchmark of training and of the shipped policy (issue 5), deterministic evaluation only.

    python -m bench.train [--config capped] [--policy jetson/models/policy/policy.onnx]
                          [--original PATH] [--matches 100] [--matches-h2h 40]
                          [--matches-high 10] [--matches-h2h-high N] [--skip-competence]
                          [--fidelity both|training|high] [--players ours,planner,...]
                          [--rows capped,strength,h2h]
                          [--name train] [--jobs 2]

Three measurements, each with the random policy beside it (so a metric met by chance shows):

competence  (the report's task, 10-ring cap) train the config (sim/configs/capped.toml: our
            settings on the report's task) from scratch and, every
            --eval-every steps, play 20 deterministic matches against the planner on seeds
            training never draws; competence = our robot fills all 10 rings in all 20 with a
            median fill time within 20 % of the planner's in the same matches. Reported: env
            steps (learner steps) and training wall time (evaluation excluded) until then.
            Targets: <= 50k steps, <= 180 s. The report needed 113.4k steps.
            When the config has a teacher ([imitation]), the same config is trained again
            without it and reported beside (competence_no_teacher_*), so what the teacher
            contributes shows; --skip-no-teacher leaves that run out.
strength    (no cap: every ring counts, the intake never fills) rings per 105 s match, each
            player against the same opponent (sim.baselines.scripted's greedy chaser, which is
            none of the compared players), --matches seeded matches with sides swapped per seed.
            The planner parks in the last seconds, which this game does not pay, so the
            planner without its endgame (planner-collector, the stronger collector) runs too.
            Targets: ours >= the planner, ours >= the collector, ours > the original.
head-to-head  1v1 win rate by match score, same seeds, sides swapped: ours against the planner
            and against the original policy (target >= 60 % each); random against both as the
            floor, and the planner against both as the reference (against itself it shows what
            an equal player wins: draws count as no win).

The shipped policy is measured in training fidelity and in high fidelity (fewer matches there:
a high-fidelity match costs ~15 s). Results: bench/results/train.json. A closer look at a few
rows goes under another name, e.g. the strength and head-to-head rows in high fidelity with 100
and 40 matches:

    python -m bench.train --skip-competence --fidelity high --players ours,planner \
        --rows strength,h2h --matches-high 100 --matches-h2h-high 40 --name train_high

(--players also picks the head-to-head opponents: there, ours and the planner each against the
planner.)
"""

from __future__ import annotations

import argparse
import json
import sys
import time
from dataclasses import replace
from pathlib import Path
from typing import Any

from bench.common import RESULTS_DIR, Result
from jetson.models import DEFAULT_POLICY

REPO = Path(__file__).resolve().parent.parent
DEFAULT_ORIGINAL = Path("/work/shared/anchors/blrsai-policy/4-29-22-1.0.onnx")
EVAL_SEED = 2_000_000  # far from every seed a training run draws
COMPETENCE_MATCHES = 20
FILL_SLACK = 1.2  # median fill time within 20 % of the planner's


def competence_check(agent: Any, spec: Any, seed: int = EVAL_SEED) -> dict[str, float]:
    """20 deterministic capped matches against the planner, stopped once both have 10 rings."""
    import numpy as np
    import torch

    from sim.evaluate import EVAL_WORLD, PlayerSpec, evaluate, load_player
    from sim.players import PolicyPlayer

    @torch.no_grad()
    def act(obs: np.ndarray) -> np.ndarray:
        return agent.deterministic(torch.as_tensor(obs, dtype=torch.float32)[None])[0].numpy()

    ours = PlayerSpec("ours", lambda: PolicyPlayer(act, "ours"), spec)
    # A match ends once both robots have 10 rings, or at 20 s: a robot without 10 rings by
    # then has failed the check anyway (the planner needs 2-5 s).
    base = {"world": EVAL_WORLD, "max_steps": 240}
    s = evaluate(
        ours,
        load_player("planner"),
        COMPETENCE_MATCHES,
        seed,
        "capped",
        stop_when_filled=True,
        base_env=base,
    )
    a, b = s.side(0), s.side(1)
    ok = a["fill_rate"] == 1.0 and a["fill_median_s"] <= FILL_SLACK * b["fill_median_s"]
    return {
        "fill_rate": a["fill_rate"],
        "fill_median_s": a["fill_median_s"],
        "planner_fill_median_s": b["fill_median_s"],
        "competent": float(ok),
    }


def run_competence(
    config: str,
    eval_every: int,
    max_steps: int | None,
    out: Path,
    teacher: bool = True,
    backend: str | None = None,
) -> dict[str, Any]:
    """Train `config` from scratch, checking every `eval_every` steps; its own total_steps (and
    so its learning-rate schedule) unless max_steps says otherwise. teacher=False drops the
    config's [imitation] teacher. backend overrides the config's ("fast": sim.fast, as the
    config's [fast] table sets it); the checks play PyBullet's training fidelity either way."""
    from sim.training.config import ImitationConfig, load_config
    from sim.training.trainer import Progress, train

    cfg = load_config(config)
    if not teacher:
        cfg = replace(cfg, imitation=ImitationConfig())
    if backend is not None:
        cfg = replace(cfg, backend=backend)
    steps = max_steps or cfg.total_steps
    cfg = replace(
        cfg,
        total_steps=steps,
        checkpoint_steps=steps,
        evaluation=replace(cfg.evaluation, every_steps=0),
    )
    log: list[dict[str, float]] = []
    found: dict[str, float] = {}
    last = [0]
    eval_s = [0.0]

    def check(p: Progress) -> bool:
        if p.step - last[0] < eval_every:
            return False
        last[0] = p.step
        t0 = time.perf_counter()
        r = competence_check(p.agent, p.spec)
        eval_s[0] += time.perf_counter() - t0
        r.update(step=float(p.step), train_wall_s=p.wall_s)
        log.append(r)
        print(
            f"  {p.step:>7} steps {p.wall_s:6.0f} s: fill {r['fill_rate']:.0%}, median "
            f"{r['fill_median_s']:.2f} s vs planner {r['planner_fill_median_s']:.2f} s",
            flush=True,
        )
        if r["competent"]:
            found.update(step=float(p.step), wall_s=p.wall_s)
            return True
        return False

    result = train(cfg, out, progress=False, callback=check, export=False)
    return {"found": found, "log": log, "steps": result.steps, "eval_s": eval_s[0]}


def _num(value: float) -> float:
    """A finite number for the result file (-1 stands for "never": e.g. no fill at all)."""
    import math

    return round(value, 2) if math.isfinite(value) else -1.0


def _row(summary: Any) -> dict[str, Any]:
    return summary.as_dict()


def _paired_difference(a: Any, b: Any) -> Any:
    """Mean and 95 % interval of A's rings minus B's, match by match: both played the same
    seeds against the same opponent, so each seed's luck cancels."""
    from sim.evaluate import mean_ci

    return mean_ci(
        [float(x.rings[0] - y.rings[0]) for x, y in zip(a.matches, b.matches, strict=True)]
    )


def _eval_chunk(job: tuple[str, str, int, int, str, str, bool]) -> list[Any]:
    from sim.evaluate import evaluate, load_player

    a, b, n, seed, scenario, fidelity, stop = job
    s = evaluate(load_player(a), load_player(b), n, seed, scenario, fidelity, stop)
    return s.matches


def parallel_eval(
    a: str,
    b: str,
    matches: int,
    seed: int,
    scenario: str,
    fidelity: str,
    stop_when_filled: bool = False,
    jobs: int = 2,
) -> Any:
    """sim.evaluate.evaluate split over `jobs` processes by seed pairs; the same matches as one
    process would play, in the same order."""
    import multiprocessing as mp

    from sim.evaluate import Summary, load_player

    pairs = (matches + 1) // 2
    jobs = max(1, min(jobs, pairs))
    per = [pairs // jobs + (1 if k < pairs % jobs else 0) for k in range(jobs)]
    chunks, first, left = [], 0, matches
    for count in per:
        n = min(2 * count, left)
        chunks.append((a, b, n, seed + first, scenario, fidelity, stop_when_filled))
        first += count
        left -= n
    if jobs == 1:
        results = [_eval_chunk(chunks[0])]
    else:
        with mp.get_context("spawn").Pool(jobs) as pool:
            results = pool.map(_eval_chunk, chunks)
    summary = Summary(load_player(a).label, load_player(b).label, scenario, fidelity)
    summary.matches = [m for r in results for m in r]
    return summary


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--config", default="capped", help="trained for competence")
    parser.add_argument("--policy", type=Path, default=DEFAULT_POLICY)
    parser.add_argument("--original", type=Path, default=DEFAULT_ORIGINAL)
    parser.add_argument("--matches", type=int, default=100, help="strength matches per player")
    parser.add_argument("--matches-h2h", type=int, default=40, help="head-to-head matches")
    parser.add_argument("--matches-high", type=int, default=10, help="per row, high fidelity")
    parser.add_argument(
        "--matches-h2h-high", type=int, default=None, help="head-to-head, high fidelity"
    )
    parser.add_argument("--fidelity", choices=("both", "training", "high"), default="both")
    parser.add_argument(
        "--players",
        default="ours,random,original,planner,collector",
        help="the players to evaluate and to meet head-to-head, comma-separated (a target needs "
        "ours and the player it compares with)",
    )
    parser.add_argument(
        "--rows", default="capped,strength,h2h", help="the measurements, comma-separated"
    )
    # 8192 = 8 rollouts of capped.toml: checks at 8k, 16k, ... 49k, inside the 50k target.
    parser.add_argument("--eval-every", type=int, default=8192)
    parser.add_argument(
        "--competence-max-steps",
        type=int,
        default=None,
        help="train this long (default: the config's total_steps, its learning-rate schedule)",
    )
    parser.add_argument("--run-dir", type=Path, default=REPO / "runs" / "bench-competence")
    parser.add_argument("--skip-competence", action="store_true")
    parser.add_argument("--skip-high", action="store_true", help="the same as --fidelity training")
    parser.add_argument("--skip-no-teacher", action="store_true")
    parser.add_argument("--name", default="train")
    parser.add_argument(
        "--results-dir", type=Path, default=RESULTS_DIR, help="where NAME.json goes"
    )
    parser.add_argument("--jobs", type=int, default=2, help="evaluation processes")
    args = parser.parse_args(argv)

    result = Result(args.name)
    details: dict[str, Any] = {}

    if not args.skip_competence:
        from sim.training.config import load_config

        runs = [("competence", True)]
        if load_config(args.config).imitation.teacher != "none" and not args.skip_no_teacher:
            runs.append(("competence_no_teacher", False))
        for name, teacher in runs:
            print(f"{name}: training {args.config} from scratch (eval every {args.eval_every})")
            comp = run_competence(
                args.config,
                args.eval_every,
                args.competence_max_steps,
                args.run_dir
                if teacher
                else args.run_dir.with_name(args.run_dir.name + "-no-teacher"),
                teacher,
            )
            details[name] = comp
            found = comp["found"]
            last = comp["log"][-1] if comp["log"] else {"step": 0.0, "train_wall_s": 0.0}
            result.add(f"{name}_reached", 1.0 if found else 0.0)
            if found:
                result.add(f"{name}_env_steps", found["step"])
                result.add(f"{name}_train_wall_s", round(found["wall_s"], 1))
            else:
                # Not reached: what was spent without reaching it (a lower bound); the steps
                # and time targets then have no measurement and count as missed.
                result.add(f"{name}_env_steps_tried", last["step"])
                result.add(f"{name}_train_wall_s_tried", round(last["train_wall_s"], 1))
            result.add(f"{name}_fill_rate_last", last.get("fill_rate", 0.0))
            result.add(f"{name}_fill_median_s_last", _num(last.get("fill_median_s", -1.0)))
            result.add(f"{name}_eval_overhead_s", round(comp["eval_s"], 1))
        result.target("competence_reached", 1.0, ">=")
        result.target("competence_env_steps", 50_000, "<=")
        result.target("competence_train_wall_s", 180.0, "<=")

    if not args.policy.is_file():
        print(f"no shipped policy at {args.policy}: stopping after competence", file=sys.stderr)
        result.report(args.results_dir)
        return 1

    def words_of(text: str, known: set[str], what: str) -> set[str]:
        chosen = {w.strip() for w in text.split(",") if w.strip()}
        if chosen - known:
            parser.error(f"unknown {what} {sorted(chosen - known)} (known: {sorted(known)})")
        return chosen

    wanted = words_of(
        args.players, {"ours", "random", "original", "planner", "collector"}, "players"
    )
    rows = words_of(args.rows, {"capped", "strength", "h2h"}, "rows")
    players = {"ours": str(args.policy), "planner": "planner", "random": "random"}
    if args.original.is_file():
        players["original"] = f"original:{args.original}"
    elif "original" in wanted:
        print(f"original policy not found at {args.original}: its rows are skipped")
    words = {**players, "collector": "planner-collector"}
    opponents = [o for o in ("planner", "original") if o in players and o in wanted]
    players = {k: v for k, v in players.items() if k in wanted}

    def run(a: str, b: str, n: int, scenario: str, fidelity: str, stop: bool = False) -> Any:
        return parallel_eval(
            words[a], words.get(b, b), n, EVAL_SEED, scenario, fidelity, stop, args.jobs,
        )  # fmt: skip

    fidelity_choice = "training" if args.skip_high else args.fidelity
    h2h_high = args.matches_h2h_high or args.matches_high
    fidelities = []
    if fidelity_choice in ("both", "training"):
        fidelities.append(("training", args.matches, args.matches_h2h, COMPETENCE_MATCHES))
    if fidelity_choice in ("both", "high"):
        fidelities.append(("high", args.matches_high, h2h_high, args.matches_high))
    for fidelity, n_strength, n_h2h, n_capped in fidelities:
        tag = "" if fidelity == "training" else "_high"
        print(f"\n== {fidelity} fidelity ==", flush=True)
        # Competence of the shipped policy: capped matches against the planner.
        for name in [n for n in ("ours", "random") if n in players and "capped" in rows]:
            s = run(name, "planner", n_capped, "capped", fidelity, stop=True)
            a, b = s.side(0), s.side(1)
            details[f"capped_{name}_vs_planner{tag}"] = _row(s)
            result.add(f"capped_fill_rate_{name}{tag}", a["fill_rate"])
            result.add(f"capped_fill_median_s_{name}{tag}", _num(a["fill_median_s"]))
            if name == "ours":
                result.add(f"capped_fill_median_s_planner{tag}", _num(b["fill_median_s"]))
            print(f"capped, {name} vs planner:\n{s.table()}\n", flush=True)
        # Strength: rings per uncapped match against the scripted chaser. The planner parks
        # in the last seconds, which this game does not pay; the collector is the planner that
        # does not, and ours must beat both.
        strength = {}
        collectors = [*players, *(["collector"] if "collector" in wanted else [])]
        for name in collectors if "strength" in rows else []:
            s = strength[name] = run(name, "scripted", n_strength, "uncapped", fidelity)
            details[f"uncapped_{name}_vs_scripted{tag}"] = _row(s)
            stat = s.side(0)["rings"]
            result.add(f"uncapped_rings_{name}{tag}", _num(stat.mean))
            result.add(f"uncapped_rings_ci95_{name}{tag}", _num(stat.half_width))
            print(f"uncapped, {name} vs scripted:\n{s.table()}\n", flush=True)
        m = result.metrics
        for other, least in (("planner", 0.0), ("collector", 0.0), ("original", 0.01)):
            ours, theirs = f"uncapped_rings_ours{tag}", f"uncapped_rings_{other}{tag}"
            if ours in m and theirs in m:
                key = f"uncapped_rings_ours_minus_{other}{tag}"
                result.add(key, round(m[ours] - m[theirs], 2))
                result.target(key, least, ">=")
                # Both played the same seeds: the paired difference has a tighter interval.
                if other != "original":
                    diff = _paired_difference(strength["ours"], strength[other])
                    result.add(f"{key}_paired_ci95", _num(diff.half_width))
        # Head-to-head by match score.
        for name in [n for n in ("ours", "random", "planner") if n in players and "h2h" in rows]:
            for opp in opponents:
                s = run(name, opp, n_h2h, "capped", fidelity)
                details[f"h2h_{name}_vs_{opp}{tag}"] = _row(s)
                result.add(f"h2h_win_rate_{name}_vs_{opp}{tag}", round(s.win_rate, 3))
                result.add(f"h2h_draw_rate_{name}_vs_{opp}{tag}", round(s.draws / n_h2h, 3))
                if name == "ours":
                    result.target(f"h2h_win_rate_ours_vs_{opp}{tag}", 0.6, ">=")
                print(f"head-to-head, {name} vs {opp}:\n{s.table()}\n", flush=True)

    path = result.report(args.results_dir)
    detail_path = path.with_name(f"{args.name}_details.json")
    detail_path.write_text(json.dumps(details, indent=1, default=str) + "\n")
    print(f"wrote {detail_path}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
