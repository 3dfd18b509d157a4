"""The batched planner (sim.fast.planner.FastPlanner) against the planner itself
(sim.baselines.planner.Planner, one per robot, fed the same fast match through FastCore as
MatchCore shows it): the same DriveCommand, intent and map step for step, through full intakes
(a goal fetched), give-ups, back-offs, uncapped intakes and the endgame; and skills' controller
functions against their compiled ports."""

from __future__ import annotations

from collections import Counter
from dataclasses import replace
from typing import Any

import numpy as np
import pytest

from jetson.autonomy import skills
from jetson.autonomy.spec import ObservationSpec
from sim.baselines.planner import Planner, PlannerConfig
from sim.config import WorldConfig
from sim.fast import planner as fp
from sim.fast.matches import FastMatches
from sim.fast.observe import FastObserver
from sim.fast.players import FastCore
from sim.fast.world import FastWorld
from sim.match import EnvConfig
from sim.training.config import load_config
from sim.training.rollout import RolloutConfig, planner_label, teacher_for

# 1v1 as training plays it, a 24 s match so that a few hundred steps reach the endgame.
WORLD = WorldConfig(
    red=("15in",),
    blue=("24in",),
    start_jitter_m=0.1,
    start_jitter_deg=45.0,
    ring_jitter_m=0.03,
    interaction_s=24.0,
)


def _play(config: PlannerConfig, seeds: list[int], steps: int) -> Counter[str]:
    """Both robots of len(seeds) fast matches driven by FastPlanner, each step held to a
    Planner per robot fed the same match; what they did, counted."""
    n = len(seeds)
    world = FastWorld(WORLD, n)
    world.reset(seeds)
    # Match 0 starts one ring short of full (a goal is fetched soon), match 1 never fills.
    world.held[0] = world.capacity - 1
    world.room_cap[1] = 1 << 30
    spec = ObservationSpec()
    observer = FastObserver(world, spec, rng=np.random.default_rng(seeds[0]))
    observer.reset()
    env = EnvConfig()
    # No endgame in match 2 (the teacher of a match paid for rings only).
    configs = [replace(config, endgame=k != 2) for k in range(n)]
    batched = [fp.FastPlanner(world, config) for _ in range(world.n_robots)]
    python = [[Planner(configs[k]) for _ in range(world.n_robots)] for k in range(n)]
    for i, planner in enumerate(batched):
        for k in range(n):
            planner.reset(np.array([k]), np.array([i]), configs[k])
            python[k][i].reset(FastCore.of(world, observer, spec, env, k), i)
    seen: Counter[str] = Counter()
    for step in range(steps):
        lin = np.zeros((n, world.n_robots))
        ang = np.zeros((n, world.n_robots))
        for i, planner in enumerate(batched):
            plan = planner.act(np.ones(n, bool), observer.seen_pose, observer.seen_rings)
            for k in range(n):
                p = python[k][i]
                cmd = p.act(FastCore.of(world, observer, spec, env, k), i)
                where = f"step {step}, match {k}, robot {i}"
                np.testing.assert_allclose(
                    [plan.linear[k], plan.angular[k]], [cmd.linear, cmd.angular],
                    rtol=1e-9, atol=1e-9, err_msg=where,
                )  # fmt: skip
                kind, point = plan.intent_of(k)
                assert kind == p.intent[0], where
                if point is not None:
                    np.testing.assert_allclose(point, p.intent[1], atol=1e-12, err_msg=where)
                count = int(planner.count[k])
                np.testing.assert_allclose(planner.known[k, :count], p.known, atol=1e-12)
                np.testing.assert_array_equal(planner.until[k, :count], p._ignored_until)
                seen[kind] += 1
                seen["backing off"] += int(p._backoff_until > world.time_s[k])
                seen["ignoring"] += int((p._ignored_until > world.time_s[k]).any())
                seen["parked"] += int(p._parked)
                seen["carrying"] += int(world.carried[k, i] >= 0)
            assert not planner.overflow.any()
            lin[:, i], ang[:, i] = plan.linear, plan.angular
        world.step(lin, ang)
        observer.push()
    return seen


def test_the_batched_planner_drives_as_the_planner_step_for_step() -> None:
    """4 matches x 2 robots to the end of a 24 s match: every command, intent and map equal,
    and the steps passed through every branch of the planner."""
    seen = _play(PlannerConfig(), [3, 11, 12, 40], steps=290)
    for what in ("ring", "goal", "home", "other", "backing off", "ignoring", "parked", "carrying"):
        assert seen[what] > 0, (what, seen)


def test_the_nearest_strategy_without_a_prior_drives_as_the_planner() -> None:
    seen = _play(PlannerConfig(strategy="nearest", prior=False), [5, 6], steps=120)
    assert seen["ring"] > 0 and seen["other"] > 0, seen


def test_rows_may_differ_from_the_planner_config_only_in_endgame() -> None:
    world = FastWorld(WORLD, 2)
    planner = fp.FastPlanner(world)
    planner.reset(np.array([0]), np.array([1]), PlannerConfig(endgame=False))
    assert not planner.endgame[0] and planner.robot[0] == 1
    with pytest.raises(ValueError, match="endgame"):
        planner.reset(np.array([0]), np.array([0]), PlannerConfig(give_up_s=1.0))


def test_the_compiled_controller_functions_equal_skills() -> None:
    """turn_first, arc_through, pursuit_point and back_onto on random targets and paths,
    including targets beside the bumper, behind the robot and paths inside the lookahead."""
    rng = np.random.default_rng(0)
    for _ in range(2000):
        tx, ty = rng.uniform(-1.5, 1.5, 2) * rng.choice([0.1, 1.0])
        length, gain, in_place = rng.uniform(0.3, 0.7), rng.uniform(1, 6), rng.uniform(0.5, 2)
        want = skills.turn_first(tx, ty, 1.2, 4.8, gain, in_place, length)
        turns, v, w = fp.turn_first(tx, ty, 1.2, 4.8, gain, in_place, length)
        assert turns == (want is not None)
        if want is not None:
            assert (v, w) == pytest.approx(want, abs=1e-12)
        assert fp.arc_through(tx, ty, 1.0, 4.8) == pytest.approx(
            skills.arc_through(tx, ty, 1.0, 4.8), abs=1e-12
        )
        path = rng.uniform(-1.0, 1.0, (int(rng.integers(1, 4)), 2)) * rng.choice([0.2, 1.0])
        look = rng.uniform(0.1, 0.6)
        assert fp.pursuit_point(path, look) == pytest.approx(
            skills.pursuit_point(path, look), abs=1e-12
        )
        assert fp.back_onto(tx, ty, 1.2, 4.8, gain) == pytest.approx(
            skills.back_onto(tx, ty, 1.2, 4.8, gain), abs=1e-12
        )


def test_the_compiled_trail_equals_skills_trail() -> None:
    """Trail.push, stuck and clear at irregular times, positions that creep and jump."""
    rng = np.random.default_rng(1)
    window, distance = 1.2, 0.04
    trail = skills.Trail(window, distance)
    rows = np.zeros((1, int(window / 0.01) + 8, 3))
    count = np.zeros(1, dtype=np.int64)
    overflow = np.zeros(1, dtype=np.int64)
    now, x, y = 0.0, 0.0, 0.0
    stuck = 0
    for _ in range(3000):
        now += rng.uniform(0.01, 0.2)
        x += rng.normal(0.0, 0.01) + rng.choice([0.0, 0.2], p=[0.95, 0.05])
        trail.push(now, x, y)
        fp.trail_push(rows, count, overflow, 0, now, x, y, window)
        speed = rng.uniform(0.0, 0.5)
        want = trail.stuck(now, speed)
        assert fp.trail_stuck(rows, count, 0, now, speed, window, distance) == want
        stuck += want
        if rng.random() < 0.02:
            trail.clear()
            count[0] = 0
    assert stuck > 10 and not overflow.any()


@pytest.mark.parametrize("name", ["default", "drive"])
def test_fast_matches_teach_and_play_with_the_planner_as_planner_label_does(name: str) -> None:
    """default.toml's (a skill policy's) and drive.toml's fast matches: each step's advice is
    planner_label of a Planner fed the same match (FastCore), and each planner opponent's
    command that Planner's, through matches that end and start again (sides and uncapped
    intakes drawn anew)."""
    env = replace(load_config(name).env_config(), max_steps=100)
    n = 4
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=n), seed=3, teacher="planner")
    fm.set_kinds([("planner", -1)] * 3 + [("policy", -1)])
    commands: list[tuple[np.ndarray, ...]] = []
    opponents = fm._opponents

    def spy(actions: np.ndarray, random: np.ndarray, j: int, cores: Any) -> tuple[np.ndarray, ...]:
        commands.append(opponents(actions, random, j, cores))
        return commands[-1]

    fm._opponents = spy  # type: ignore[method-assign]
    step = fm.reset()
    teachers: list[Planner] = []
    players: list[Planner] = []

    def start(k: int) -> None:
        core = fm._core(k)
        me = int(fm.learner[k])
        teacher = teacher_for(env.match_reward(bool(fm.uncapped[k])))
        teacher.reset(core, me)  # type: ignore[arg-type]
        player = Planner()
        player.reset(core, 1 - me)  # type: ignore[arg-type]
        teachers[k:k] = [teacher]
        players[k:k] = [player]

    for k in range(n):
        start(k)
    ends = 0
    for t in range(260):
        assert step.advice is not None
        for k in range(n):
            want = planner_label(teachers[k], fm._core(k), int(fm.learner[k]), step.learner_obs[k])
            np.testing.assert_allclose(step.advice[k], want, atol=1e-6, err_msg=f"{t}, {k}")
        them = 1 - fm.learner
        expected = [players[k].act(fm._core(k), int(them[k])) for k in range(3)]  # type: ignore[arg-type]
        actions = np.nan_to_num(step.advice, nan=-1.0)
        step = fm.step(actions, np.zeros((n, env.action_size)))
        lin, ang = commands[-1][0], commands[-1][1]
        for k, cmd in enumerate(expected):
            np.testing.assert_allclose([lin[k], ang[k]], [cmd.linear, cmd.angular], atol=1e-9)
        for k in np.flatnonzero(step.dones):
            del teachers[k], players[k]
            start(int(k))
            ends += 1
    assert ends >= n
