"""Benchmark of the batched training backend (issue 45), side by side with PyBullet's training
fidelity in one run.

    python -m bench.fastpath [--matches 8192] [--steps 120] [--processes 2] [--seeds 40]
                             [--game-seeds 200]
                             [--ppo-steps N] [--transfer-steps N] [--skip-ppo]
                             [--skip-transfer] [--skip-agreement] [--skip-competence]
                             [--skip-default] [--default-steps N]

Rows:
  speed       robot control steps per second with every robot's observation built:
              sim.fast (--matches matches at once, random drive commands,
              --steps steps, one process whose compiled loops use every core) against the
              PettingZoo env on PyBullet (every robot an agent) on --processes processes.
              Rows for the ring race 1v1 and 2v2 and the whole 2v2 game (tipping_point_2v2:
              the isolation period, preloads, see-saws, tugs of war, fouls; every rule in
              every match each step). Target (issue 45): >= 200,000 for the whole 2v2 game
              (fast_game_2v2_robot_steps_per_s).
  ppo         PPO end to end (rollouts and updates, sim.training.trainer): sim/configs/fast.toml
              on the fast backend, and the same game on PyBullet (worker processes of 8 matches,
              minibatches of 512): steps per second. Target >= 50,000.
  agreement   the same scripted players (sim.baselines.scripted.GreedyChaser, ground truth)
              on the same seeds, both backends, the ring race 1v1 (--seeds) and the whole 2v2
              game (--game-seeds; agreement_game_*): the share of matches where every robot's
              rings are within 1 (target >= 0.9) and the mean match score's relative error
              (target <= 0.03). Beside them, PyBullet against itself with the red robot's start
              moved 1 cm: how far the twin's own matches move for a centimetre, the floor any
              second model meets.
  transfer    a drive policy (the network drives the wheels) trained for the score on the fast
              backend (sim/configs/fast_score.toml, or --transfer-config, its own total_steps
              or --transfer-steps), played deterministically against an idle opponent in whole
              matches: the points it earns (its alliance's mean match score less a robot
              standing still's in the same matches) on the fast backend, in PyBullet's training
              fidelity and in high fidelity (--transfer-matches, --transfer-high-matches);
              drive_policy_high_fidelity_score_ratio, for the record.
  competence  bench.train's competence row on the fast path: sim/configs/capped.toml trained
              from scratch on the fast backend (its ring memory, route slot and route teacher
              batched, the planner a quarter of its opponents), checked
              every --competence-every steps as bench.train checks it (20 matches against the
              planner in PyBullet's training fidelity); the training wall time until the check
              passes, evaluation excluded (target <= 10 s), beside the same row on PyBullet
              (--skip-competence-pybullet leaves it out).
  default     default.toml's training speed on both backends (--default-steps steps each, its
              own settings, the fast backend sized by its [fast]: the same rollouts), each in a
              fresh process, from which its retraining time follows.
  retrain     default.toml retrained on the fast backend, whole (--retrain-steps to shorten),
              its periodic evaluation off, in a fresh process (as `pete-sim train` runs; the
              benchmark's earlier rows leave threads behind in theirs); then bench.train's
              strength and head-to-head rows
              on its policy in training fidelity (--retrain-matches, --retrain-matches-h2h).
              fast_default_retrain_s (target <= 180 s) is its training wall time, written only
              when every strength target holds (--skip-retrain leaves the row out). The same
              policy is played as the transfer row plays its drive policy; target: high
              fidelity keeps >= 95 % of the points it earns on the fast backend
              (fast_policy_high_fidelity_score_ratio).
Results: bench/results/fastpath.json (RESULTS.md). A GPU is never needed (numpy on the CPU).
"""

from __future__ import annotations

import argparse
import json
import multiprocessing as mp
import os
import statistics
import sys
import tempfile
import time
from dataclasses import replace
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from bench.common import Result

if TYPE_CHECKING:
    from sim.config import WorldConfig

RING_RACE_2V2 = {"red": ("24in", "15in"), "blue": ("24in", "15in")}
JITTER = {"start_jitter_m": 0.1, "start_jitter_deg": 10.0, "ring_jitter_m": 0.03}
# The speed rows' games: (robots a side, the world's settings).
SPEED_GAMES = ("ring_race_1v1", "ring_race_2v2", "game_2v2")


def _world(game: str) -> WorldConfig:
    from sim.config import WorldConfig

    return WorldConfig(**_world_settings(game))  # type: ignore[arg-type]


def _world_settings(game: str) -> dict[str, object]:
    from sim.config import WORLD_PRESETS

    if game == "game_2v2":  # the whole VEX AI match: isolation period, preloads, the see-saws
        return {**WORLD_PRESETS["tipping_point_2v2"], **JITTER}
    return {**JITTER, **(RING_RACE_2V2 if game == "ring_race_2v2" else {})}


def _observation(game: str) -> dict[str, object]:
    from sim.config import world_preset

    two = game != "ring_race_1v1"
    length = world_preset("tipping_point_2v2").isolation_s + 105.0 if game == "game_2v2" else 105.0
    return {"n_stack": 2, "n_other_robots": 3 if two else 1, "match_length_s": length}


def fast_speed(args: tuple[str, int, int, int]) -> tuple[int, float]:
    """(robot steps, seconds) of `steps` steps of `matches` fast matches with observations."""
    from jetson.autonomy.spec import ObservationSpec
    from sim.fast.observe import FastObserver
    from sim.fast.world import FastWorld

    game, matches, steps, seed = args
    world = FastWorld(_world(game), matches)
    world.reset(range(seed * matches, (seed + 1) * matches))
    spec = ObservationSpec(**_observation(game))  # type: ignore[arg-type]
    obs = FastObserver(world, spec, rng=np.random.default_rng(seed))
    obs.reset()
    rng = np.random.default_rng(seed)
    r = world.n_robots
    start = time.perf_counter()
    for t in range(steps):
        if t % 12 == 0:
            lin = rng.uniform(-0.5, 1.5, (matches, r))
            ang = rng.uniform(-3.0, 3.0, (matches, r))
        world.step(lin, ang)
        obs.push()
    return matches * r * steps, time.perf_counter() - start


def pybullet_speed(args: tuple[str, int, int, int]) -> tuple[int, float]:
    """(robot steps, seconds) of the PettingZoo env on PyBullet, every robot an agent."""
    from sim.parallel_env import parallel_env

    game, _, steps, seed = args
    env = parallel_env(world=_world_settings(game), observation=_observation(game))
    rng = np.random.default_rng(seed)
    env.reset(seed=seed)
    n = 0
    start = time.perf_counter()
    while n < steps:
        actions = {a: rng.uniform(-1, 1, 2).astype(np.float32) for a in env.agents}
        _, _, terms, truncs, _ = env.step(actions)
        n += 1
        if any(terms.values()) or any(truncs.values()):
            env.reset(seed=seed + n)
    elapsed = time.perf_counter() - start
    robots = len(env.possible_agents)
    env.close()
    return robots * steps, elapsed


def _parallel(fn: object, jobs: list[tuple[str, int, int, int]]) -> float:
    """Total robot steps per second of `jobs` run at once, one process each."""
    if len(jobs) == 1:
        steps, secs = fn(jobs[0])  # type: ignore[operator]
        return steps / secs
    with mp.get_context("spawn").Pool(len(jobs)) as pool:
        out = pool.map(fn, jobs)  # type: ignore[arg-type]
    return sum(s for s, _ in out) / max(t for _, t in out)


def speed_rows(result: Result, args: argparse.Namespace) -> None:
    procs = args.processes
    for game in SPEED_GAMES:  # the compiled loops load (or compile) before the timing
        fast_speed((game, 8, 2, 0))
    for game in SPEED_GAMES:
        matches = args.matches if game == "ring_race_1v1" else args.matches // 2
        # One process: its compiled loops run on every core (numba's threads); PyBullet's
        # matches run one per process on as many.
        fast = _parallel(fast_speed, [(game, matches, args.steps, 0)])
        slow = _parallel(pybullet_speed, [(game, 0, args.pybullet_steps, k) for k in range(procs)])
        result.add(f"fast_{game}_robot_steps_per_s", round(fast))
        result.add(f"pybullet_{game}_robot_steps_per_s", round(slow))
        result.add(f"speedup_{game}", round(fast / slow, 1))
        print(f"{game}: fast {fast:,.0f} robot steps/s, PyBullet {slow:,.0f} ({fast / slow:.0f}x)")


def ppo_rows(result: Result, args: argparse.Namespace) -> None:
    """sim/configs/fast.toml on the fast backend, and the same game (tiny.toml's PyBullet
    rollout: processes of 8 matches) on PyBullet."""
    from sim.training.config import load_config
    from sim.training.trainer import train

    fast_cfg = replace(
        load_config("fast"), total_steps=args.ppo_steps, checkpoint_steps=args.ppo_steps
    )
    slow_cfg = replace(
        fast_cfg,
        backend="pybullet",
        total_steps=args.ppo_pybullet_steps,
        checkpoint_steps=args.ppo_pybullet_steps,
        rollout=replace(fast_cfg.rollout, workers=args.processes, envs_per_worker=8),
        ppo=replace(fast_cfg.ppo, minibatch_size=512),
    )
    with tempfile.TemporaryDirectory() as tmp:
        fast = train(fast_cfg, Path(tmp) / "fast", progress=False, export=False)
        slow = train(slow_cfg, Path(tmp) / "slow", progress=False, export=False)
    f, s = fast.steps / fast.wall_s, slow.steps / slow.wall_s
    result.add("fast_ppo_steps_per_s", round(f))
    result.add("pybullet_ppo_steps_per_s", round(s))
    result.add("speedup_ppo", round(f / s, 1))
    print(f"PPO end to end: fast {f:,.0f} steps/s, PyBullet {s:,.0f} ({f / s:.0f}x)")


def _fast_score(checkpoint: Path | None, matches: int, seed: int) -> tuple[float, float]:
    """Mean match score and rings of a checkpoint's deterministic policy (None: a robot that
    stands still) against an idle opponent on the fast backend, `matches` whole matches."""
    import torch

    from jetson.autonomy.spec import ObservationSpec
    from sim.evaluate import EVAL_WORLD, SCENARIOS
    from sim.fast.matches import FastMatches
    from sim.match import make_config
    from sim.training.checkpoint import agent_from_checkpoint, load_checkpoint
    from sim.training.rollout import RolloutConfig

    agent, spec, skills = None, ObservationSpec(n_stack=0), None
    if checkpoint is not None:
        agent, spec, cfg = agent_from_checkpoint(load_checkpoint(checkpoint))
        skills = cfg.env_config().skills  # a skill policy's network picks skills
    env = make_config({"world": EVAL_WORLD, **SCENARIOS["capped"]}, observation=spec, skills=skills)
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=matches), seed=seed)
    fm.set_kinds([("idle", -1)] * matches)
    res = fm.reset()
    idle = np.zeros((matches, env.action_size), np.float32)
    scores: dict[int, tuple[float, float]] = {}
    with torch.no_grad():
        while len(scores) < matches:
            act = (
                idle
                if agent is None
                else agent.deterministic(torch.as_tensor(res.learner_obs)).numpy()
            )
            res = fm.step(act, idle)
            for ep in res.episodes:
                scores.setdefault(ep.slot, (ep.score, float(ep.rings)))
    return (
        statistics.fmean(v[0] for v in scores.values()),
        statistics.fmean(v[1] for v in scores.values()),
    )


def _pybullet_score(
    policy: Path | None, matches: int, seed: int, fidelity: str
) -> tuple[float, float]:
    """The same on PyBullet (sim.evaluate: seeded matches, sides swapped)."""
    from sim.evaluate import evaluate, load_player

    summary = evaluate(
        load_player("idle" if policy is None else str(policy)),
        load_player("idle"),
        matches,
        seed,
        "capped",
        fidelity,
        base_env={"world": JITTER},
    )
    side = summary.side(0)
    return side["score"].mean, side["rings"].mean


def _transfer(
    result: Result, args: argparse.Namespace, prefix: str, ckpt: Path, policy: Path
) -> float | None:
    """What a fast-trained policy earns, played deterministically against an idle opponent in
    whole matches: its alliance's mean score less a robot standing still's in the same matches
    (both alliance goals start in their home zones: 40 points for nothing), on the fast
    backend, in PyBullet's training fidelity and in high fidelity. Returns high fidelity's
    share of the fast backend's points."""
    n, n_high = args.transfer_matches, args.transfer_high_matches
    fast, fast_rings = _fast_score(ckpt, n, seed=7)
    fast -= _fast_score(None, n, seed=7)[0]
    train_fid, train_rings = _pybullet_score(policy, n, 7, "training")
    # A robot standing still scores the same in every match of a fidelity (its goals stay in
    # its zone): a few matches measure it.
    train_fid -= _pybullet_score(None, min(n, 4), 7, "training")[0]
    high, high_rings = _pybullet_score(policy, n_high, 7, "high")
    high -= _pybullet_score(None, min(n_high, 4), 7, "high")[0]
    result.add(f"{prefix}_fast_score", round(fast, 2))
    result.add(f"{prefix}_fast_rings", round(fast_rings, 2))
    result.add(f"{prefix}_pybullet_training_score", round(train_fid, 2))
    result.add(f"{prefix}_pybullet_training_rings", round(train_rings, 2))
    result.add(f"{prefix}_high_fidelity_score", round(high, 2))
    result.add(f"{prefix}_high_fidelity_rings", round(high_rings, 2))
    if fast_rings > 0:
        result.add(f"{prefix}_high_fidelity_rings_ratio", round(high_rings / fast_rings, 3))
    print(
        f"{prefix}: score {fast:.1f} on the fast backend, {train_fid:.1f} in PyBullet's "
        f"training fidelity, {high:.1f} in high fidelity"
    )
    return round(high / fast, 3) if fast > 0 else None


def transfer_rows(result: Result, args: argparse.Namespace) -> None:
    """A drive policy (fast_score.toml) trained on the fast backend and played on both: the
    record of how a policy that drives the wheels itself carries over."""
    from sim.training.config import load_config
    from sim.training.trainer import train

    cfg = load_config(args.transfer_config)
    steps = args.transfer_steps or cfg.total_steps
    cfg = replace(cfg, total_steps=steps, checkpoint_steps=steps)
    with tempfile.TemporaryDirectory() as tmp:
        run = train(cfg, Path(tmp) / "run", progress=False)
        assert run.policy is not None
        ckpt = Path(tmp) / "run" / "checkpoints" / "latest.pt"
        ratio = _transfer(result, args, "transfer_drive", ckpt, run.policy)
    result.add("transfer_drive_train_steps", run.steps)
    result.add("transfer_drive_train_wall_s", round(run.wall_s, 1))
    if ratio is not None:
        result.add("drive_policy_high_fidelity_score_ratio", ratio)


def _pybullet_match(
    seed: int, nudge_m: float = 0.0, game: str = "ring_race_1v1"
) -> tuple[list[int], list[int]]:
    """Greedy chasers, one seeded match of `game` on PyBullet: each robot's rings and each
    alliance's score."""
    from sim.baselines.scripted import GreedyChaser
    from sim.world.physics import World

    with World(_world(game)) as w:
        w.reset(np.random.default_rng(seed))
        if nudge_m:
            r = w.robots[0]
            w.place_robot(0, r.x + nudge_m, r.y, r.heading)
        players = [GreedyChaser(i) for i in range(len(w.robots))]
        while not w.over:
            w.step([p.act(w) for p in players])
        s = w.score()
        return [r.collected for r in w.robots], [s["red"].total, s["blue"].total]


def _fast_matches(
    seeds: list[int], game: str = "ring_race_1v1"
) -> list[tuple[list[int], list[int]]]:
    """The same matches on the fast backend, every seed at once."""
    from sim.baselines.scripted import GreedyChaser
    from sim.fast.view import match_view
    from sim.fast.world import FastWorld

    world = FastWorld(_world(game), len(seeds))
    world.reset([np.random.default_rng(s) for s in seeds])
    players = [[GreedyChaser(i) for i in range(world.n_robots)] for _ in seeds]
    lin = np.zeros((len(seeds), world.n_robots))
    ang = np.zeros_like(lin)
    while not world.over.all():
        for k, mine in enumerate(players):
            view = match_view(world, k)
            for i, p in enumerate(mine):
                cmd = p.act(view)  # type: ignore[arg-type]
                lin[k, i], ang[k, i] = cmd.linear, cmd.angular
        world.step(lin, ang)
    red, blue = world.totals()
    return [
        ([int(v) for v in world.collected[k]], [int(red[k]), int(blue[k])])
        for k in range(len(seeds))
    ]


def _agreement(
    a: list[tuple[list[int], list[int]]], b: list[tuple[list[int], list[int]]]
) -> tuple[float, float]:
    within = [
        all(abs(x - y) <= 1 for x, y in zip(p[0], q[0], strict=True))
        for p, q in zip(a, b, strict=True)
    ]
    mean_a = statistics.fmean(sum(p[1]) for p in a)
    mean_b = statistics.fmean(sum(q[1]) for q in b)
    return sum(within) / len(within), abs(mean_b / mean_a - 1.0) if mean_a else 1.0


def agreement_rows(result: Result, args: argparse.Namespace) -> None:
    """The ring race 1v1 on --seeds seeds, and the whole 2v2 game on --game-seeds."""
    for game, n, prefix in (
        ("ring_race_1v1", args.seeds, "agreement"),
        ("game_2v2", args.game_seeds, "agreement_game"),
    ):
        seeds = list(range(n))
        with mp.get_context("spawn").Pool(args.processes) as pool:
            ref = pool.starmap(_pybullet_match, [(s, 0.0, game) for s in seeds])
            nudged = pool.starmap(_pybullet_match, [(s, 0.01, game) for s in seeds])
        fast = _fast_matches(seeds, game)
        within, err = _agreement(ref, fast)
        floor_within, floor_err = _agreement(ref, nudged)
        nudged_key = "pybullet_nudged" if game == "ring_race_1v1" else "pybullet_game_nudged"
        result.add(f"{prefix}_seeds", len(seeds))
        result.add(f"{prefix}_rings_within_1", round(within, 3))
        result.add(f"{prefix}_score_error", round(err, 4))
        result.add(f"{nudged_key}_rings_within_1", round(floor_within, 3))
        result.add(f"{nudged_key}_score_error", round(floor_err, 4))
        print(
            f"agreement ({game}): rings within 1 in {within:.0%} of matches, mean score off by "
            f"{err:.1%} (PyBullet nudged 1 cm: {floor_within:.0%}, {floor_err:.1%})"
        )


def competence_rows(result: Result, args: argparse.Namespace) -> None:
    from bench.train import run_competence

    backends = ["fast"] + ([] if args.skip_competence_pybullet else ["pybullet"])
    walls = {}
    for backend in backends:
        with tempfile.TemporaryDirectory() as tmp:
            r = run_competence(
                "capped", args.competence_every, None, Path(tmp) / "run", backend=backend
            )
        found = r["found"]
        key = "fast_competence" if backend == "fast" else "pybullet_competence"
        result.add(f"{key}_reached", float(bool(found)))
        result.add(f"{key}_eval_overhead_s", round(r["eval_s"], 1))
        if found:
            walls[backend] = found["wall_s"]
            result.add(f"{key}_wall_s", round(found["wall_s"], 1))
            result.add(f"{key}_env_steps", found["step"])
        else:
            result.add(f"{key}_env_steps_tried", r["steps"])
        print(f"competence ({backend}): {found or 'not reached in ' + str(r['steps']) + ' steps'}")
    if len(walls) == 2:
        result.add("competence_wall_speedup", round(walls["pybullet"] / walls["fast"], 2))


def _train_default(
    backend: str, steps: int | None, folder: str, export: bool
) -> tuple[int, float, str | None]:
    """default.toml trained on a backend into folder, its periodic evaluation off (steps: None
    for its own total): (steps, wall seconds, the exported policy or None)."""
    from sim.training.config import load_config
    from sim.training.trainer import train

    cfg = load_config("default")
    total = steps or cfg.total_steps
    cfg = replace(
        cfg,
        backend=backend,
        total_steps=total,
        checkpoint_steps=total if not export else cfg.checkpoint_steps,
        evaluation=replace(cfg.evaluation, every_steps=0),
    )
    run = train(cfg, Path(folder) / "run", progress=False, export=export)
    return run.steps, run.wall_s, None if run.policy is None else str(run.policy)


def _in_fresh_process(
    backend: str, steps: int | None, folder: str, export: bool
) -> tuple[int, float, str | None]:
    """_train_default in a spawned process: what a team's `pete-sim train` gets, not a process
    the benchmark's earlier rows left their threads in."""
    from concurrent.futures import ProcessPoolExecutor

    with ProcessPoolExecutor(1, mp_context=mp.get_context("spawn")) as pool:
        return pool.submit(_train_default, backend, steps, folder, export).result()


def default_rows(result: Result, args: argparse.Namespace) -> None:
    """default.toml's training speed on both backends, the same steps each, each in a fresh
    process (as the retrain row trains)."""
    from sim.training.config import load_config

    rates = {}
    for backend in ("fast", "pybullet"):
        with tempfile.TemporaryDirectory() as tmp:
            steps, wall_s, _ = _in_fresh_process(backend, args.default_steps, tmp, False)
        rates[backend] = steps / wall_s
        result.add(f"default_{backend}_steps_per_s", round(rates[backend], 1))
    total = load_config("default").total_steps
    result.add("default_fast_projected_retrain_s", round(total / rates["fast"], 1))
    result.add("default_speedup", round(rates["fast"] / rates["pybullet"], 2))
    print(
        f"default.toml: fast {rates['fast']:,.0f} steps/s, PyBullet {rates['pybullet']:,.0f} "
        f"({total:,} steps: {total / rates['fast']:.0f} s on the fast backend)"
    )


def retrain_rows(result: Result, args: argparse.Namespace) -> None:
    """default.toml retrained on the fast backend (its own settings; its periodic evaluation off,
    which is not training), then bench.train's strength and head-to-head rows on the policy in
    training fidelity. fast_default_retrain_s is the training's wall time, written only when
    every strength target holds (the target is a retraining to bench.train's strength)."""
    from bench import train as bench_train

    with tempfile.TemporaryDirectory() as tmp:
        steps, wall_s, policy = _in_fresh_process("fast", args.retrain_steps, tmp, True)
        if policy is None:
            print("retrain: the run exported no policy", file=sys.stderr)
            return
        result.add("fast_default_retrain_steps", steps)
        result.add("fast_default_retrain_wall_s", round(wall_s, 1))
        print(f"retrain: {steps:,} steps in {wall_s:.0f} s; its score on both backends")
        ckpt = Path(tmp) / "run" / "checkpoints" / "latest.pt"
        ratio = _transfer(result, args, "transfer", ckpt, Path(policy))
        if ratio is not None:
            result.add("fast_policy_high_fidelity_score_ratio", ratio)
        print("retrain: its strength on PyBullet")
        bench_train.main(
            [
                "--policy", policy, "--skip-competence", "--fidelity", "training",
                "--rows", "strength,h2h", "--players", "ours,planner,collector,original",
                "--matches", str(args.retrain_matches),
                "--matches-h2h", str(args.retrain_matches_h2h),
                "--name", "retrain_strength", "--results-dir", tmp,
            ]
        )  # fmt: skip
        strength = json.loads((Path(tmp) / "retrain_strength.json").read_text())
    targets = strength["targets"]
    met = bool(targets) and all(t["met"] for t in targets.values())
    for key in ("uncapped_rings_ours_minus_planner", "uncapped_rings_ours_minus_collector"):
        result.add(f"retrain_{key}", strength["metrics"][key])
    result.add(
        "retrain_h2h_win_rate_vs_planner", strength["metrics"]["h2h_win_rate_ours_vs_planner"]
    )
    result.add("fast_default_retrain_strength_met", float(met))
    if met:
        result.add("fast_default_retrain_s", round(wall_s, 1))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(prog="python -m bench.fastpath", description=__doc__)
    parser.add_argument("--matches", type=int, default=8192, help="fast matches at once, 1v1")
    parser.add_argument("--steps", type=int, default=120, help="fast steps timed")
    parser.add_argument("--pybullet-steps", type=int, default=600, help="PyBullet steps timed")
    parser.add_argument("--processes", type=int, default=os.cpu_count() or 1)
    parser.add_argument("--seeds", type=int, default=40, help="agreement matches, ring race")
    parser.add_argument(
        "--game-seeds", type=int, default=200, help="agreement matches, the whole 2v2 game"
    )
    parser.add_argument("--ppo-steps", type=int, default=1_048_576, help="fast PPO steps")
    parser.add_argument("--ppo-pybullet-steps", type=int, default=16_384)
    parser.add_argument("--transfer-config", default="fast_score", help="the policy's config")
    parser.add_argument("--transfer-steps", type=int, default=None, help="default: its own")
    parser.add_argument("--transfer-matches", type=int, default=64)
    parser.add_argument("--transfer-high-matches", type=int, default=20)
    parser.add_argument("--skip-ppo", action="store_true")
    parser.add_argument("--skip-transfer", action="store_true")
    parser.add_argument("--skip-agreement", action="store_true")
    parser.add_argument("--skip-competence", action="store_true")
    parser.add_argument("--skip-competence-pybullet", action="store_true")
    parser.add_argument("--skip-default", action="store_true")
    parser.add_argument("--skip-retrain", action="store_true")
    parser.add_argument(
        "--retrain-steps", type=int, default=None, help="default: default.toml's total_steps"
    )
    parser.add_argument("--retrain-matches", type=int, default=100, help="its strength rows")
    parser.add_argument("--retrain-matches-h2h", type=int, default=40)
    parser.add_argument(
        "--default-steps", type=int, default=65_536, help="default.toml steps per backend"
    )
    parser.add_argument(
        "--competence-every", type=int, default=8192, help="steps between competence checks"
    )
    parser.add_argument("--name", default="fastpath", help="result file name")
    args = parser.parse_args(argv)
    result = Result(args.name)
    result.add("load_average_1min", round(os.getloadavg()[0], 2))
    result.add("processes", args.processes)
    speed_rows(result, args)
    if not args.skip_ppo:
        ppo_rows(result, args)
    if not args.skip_transfer:
        transfer_rows(result, args)
    if not args.skip_agreement:
        agreement_rows(result, args)
    if not args.skip_competence:
        competence_rows(result, args)
    if not args.skip_default:
        default_rows(result, args)
    if not args.skip_retrain:
        retrain_rows(result, args)
    result.target("fast_game_2v2_robot_steps_per_s", 200_000, ">=")
    result.target("fast_ppo_steps_per_s", 50_000, ">=")
    result.target("fast_competence_wall_s", 10.0, "<=")
    result.target("fast_default_retrain_s", 180.0, "<=")
    result.target("agreement_rings_within_1", 0.9, ">=")
    result.target("agreement_score_error", 0.03, "<=")
    result.target("agreement_game_rings_within_1", 0.9, ">=")
    result.target("agreement_game_score_error", 0.03, "<=")
    result.target("fast_policy_high_fidelity_score_ratio", 0.95, ">=")
    result.report()
    return 0


if __name__ == "__main__":
    sys.exit(main())
