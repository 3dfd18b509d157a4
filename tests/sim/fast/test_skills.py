"""The batched skills' controller (sim.fast.skills.FastSkillDrivers) against SkillDriver, one per
robot fed the same observations and scores, command for command through every skill, back-offs
and committed goal manoeuvres; and the batched teacher's label (OptionLabels) against
rollout.intent_label. Commands agree to 1e-12, not bit for bit: pursuit_point's numpy 2-vector
dot products may fuse a multiply and an add (OpenBLAS's kernel on this CPU), the compiled
port's arithmetic does not (sim.fast.planner's test holds them to the same 1e-12)."""

from __future__ import annotations

from collections import Counter
from dataclasses import replace

import numpy as np
import pytest

from jetson.autonomy.geometry import robot_to_field
from jetson.autonomy.skills import SkillConfig, SkillDriver, leave
from jetson.autonomy.spec import ObservationSpec
from sim.fast.matches import FastMatches
from sim.fast.planner import INTENTS
from sim.fast.skills import TARGET_KINDS, FastSkillDrivers, OptionLabels
from sim.match import EnvConfig
from sim.training.config import load_config
from sim.training.rollout import RolloutConfig, intent_label
from sim.world.state import DriveCommand


def _matches(n: int, max_steps: int, seed: int) -> tuple[EnvConfig, FastMatches]:
    """default.toml's skill game on n fast matches, every opponent a policy."""
    env = replace(load_config("default").env_config(), max_steps=max_steps)
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=n), seed=seed)
    fm.set_kinds([("policy", -1)] * n)
    return env, fm


def _python_drivers(fm: FastMatches) -> list[list[SkillDriver]]:
    """A fresh SkillDriver per robot of every match (MatchCore.skill_driver's configs)."""
    assert fm._drivers is not None
    return [[SkillDriver(c, fm.spec) for c in fm._drivers.configs] for _ in range(fm.n)]


def _drive_and_compare(
    fm: FastMatches, steps: int, favourite: int | None = None, seed: int = 0
) -> Counter[str]:
    """Every robot of fm's matches holds a random skill for a few steps (`favourite` the one
    most often), some steps without a command (non-finite scores), matches ending and starting
    again: every command, committed() and target of FastSkillDrivers equal to SkillDriver's,
    robot by robot. What was driven, counted."""
    assert fm._drivers is not None
    skills = fm._drivers.configs[0]
    n, n_opt, robots = fm.b, skills.n_options, fm.world.n_robots
    rng = np.random.default_rng(seed)
    fm.reset()
    batched = FastSkillDrivers(fm._drivers.configs, fm.spec, n, fm.world.dt)
    python = _python_drivers(fm)

    def draw(size: tuple[int, ...]) -> np.ndarray:
        k = rng.integers(0, n_opt, size)
        return k if favourite is None else np.where(rng.random(size) < 0.6, favourite, k)

    pick = draw((n, robots))
    seen: Counter[str] = Counter()
    rows = np.arange(n)
    unit = fm.spec.length_unit_m
    for step in range(steps):
        change = rng.random((n, robots)) < 0.08
        pick = np.where(change, draw((n, robots)), pick)
        scores = rng.normal(0.0, 0.3, (n, robots, n_opt))
        scores[rows[:, None], np.arange(robots), pick] += 2.0
        scores[rng.random((n, robots)) < 0.03] = 0.5  # ties: the first of the highest
        active = rng.random((n, robots)) > 0.03
        for i in range(robots):
            who = np.full(n, i)
            obs = fm.obs[:, i]
            busy = batched.committed(obs, who, active[:, i])
            lin, ang = batched.command(obs, scores[:, i], who, active[:, i])
            kind, point = batched.targets(who)
            for k in range(n):
                where = f"step {step}, match {k}, robot {i}"
                driver = python[k][i]
                if not active[k, i]:
                    assert not busy[k] and lin[k] == 0.0 and ang[k] == 0.0, where
                    continue
                assert busy[k] == driver.committed(obs[k]), where
                now = float(obs[k, 0]) * fm.spec.match_length_s
                seen["committed"] += int(busy[k])
                seen["backing off"] += int(driver._backoff_until > now)
                seen[skills.option_names()[driver.option(scores[k, i])]] += 1
                # split_with_partner, keep_clear_s: the best option's ring or goal is the
                # partner's or beside the other platform; climb_at_s: the platform.
                passed = driver.option(scores[k, i], obs[k]) != driver.option(scores[k, i])
                seen["passed over"] += int(passed and not busy[k])
                late = fm.spec.match_length_s - now <= skills.climb_at_s
                seen["endgame climb"] += int(late and not busy[k])
                if fm.spec.match_length_s - now <= skills.keep_clear_s:
                    x, y, cos_h, sin_h = obs[k, 1:5].astype(float) * (unit, unit, 1, 1)
                    cx, cy, hx, hy = skills.platform_box
                    out = leave(x, y, cos_h, sin_h, (-cx, -cy, hx, hy), skills.keep_clear_m, 1)
                    seen["leaving their platform"] += int(out is not None)
                want = driver.command(obs[k], scores[k, i])
                assert (lin[k], ang[k]) == pytest.approx(want, rel=0, abs=1e-12), where
                # What it drove to (the partner report's claim): SkillDriver.target.
                if driver.target is None:
                    assert kind[k] == 0, where
                else:
                    assert TARGET_KINDS[kind[k]] == driver.target[0], where
                    assert tuple(point[k]) == pytest.approx(driver.target[1], abs=1e-9), where
                    seen[f"claims {driver.target[0]}"] += 1
                    seen["stopped"] += int(driver.target[0] == "platform" and want == (0, 0))
        assert not batched.overflow.any()
        # The match's own robots drive the same scores (its controllers are batched too).
        mine = np.stack([scores[rows, fm.robot_of(j)] for j in range(fm.a)], 1)
        theirs = np.stack([scores[rows, fm.robot_of(j, False)] for j in range(fm.a)], 1)
        step_result = fm.step(mine.reshape(fm.n, n_opt), theirs.reshape(fm.n, n_opt))
        for k in np.flatnonzero(step_result.dones[:: fm.a]):
            batched.reset(np.array([k]))
            python[k] = [SkillDriver(c, fm.spec) for c in fm._drivers.configs]
            seen["restarts"] += 1
    return seen


def test_the_batched_controller_drives_as_skill_driver_step_for_step() -> None:
    """6 1v1 matches through every skill, back-offs and committed goal manoeuvres."""
    _, fm = _matches(6, max_steps=150, seed=5)
    seen = _drive_and_compare(fm, 420)
    for what in ("route", "ring0", "ring3", "goal0", "goal1", "platform", "committed",
                 "claims ring", "claims goal", "claims platform"):  # fmt: skip
        assert seen[what] > 20, (what, seen)
    assert seen["backing off"] > 0 and seen["restarts"] >= 6, seen


def test_the_batched_controller_shares_the_platform_as_skill_driver() -> None:
    """alliance.toml's 2v2 with share_platform and split_with_partner (the shipped policy's
    controller), the platform the favourite skill: every robot's stage, climb and stop (each in
    its lane, found from where its partner stands) and every option passed over as the
    partner's equal to SkillDriver's."""
    env = load_config("alliance").env_config()
    assert env.skills is not None
    skills = replace(env.skills, share_platform=True, split_with_partner=True)  # as shipped
    env = replace(env, max_steps=400, skills=skills)
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=8), seed=3)
    fm.set_kinds([("policy", -1)] * 8)
    seen = _drive_and_compare(fm, 520, favourite=env.skills.n_options - 1, seed=1)
    assert seen["platform"] > 2000 and seen["stopped"] > 20 and seen["backing off"] > 0, seen
    assert seen["passed over"] > 20, seen


def test_the_batched_controller_keeps_the_endgame_as_skill_driver() -> None:
    """The shipped controller with the endgame on from early in these short matches (the other
    alliance's platform kept clear of all along, widely; the climb from the 12th second, with
    the goals carried stopping past the hinge): every option passed over beside that platform
    and every endgame climb equal to SkillDriver's."""
    env = load_config("alliance").env_config()
    assert env.skills is not None
    skills = replace(
        env.skills, share_platform=True, split_with_partner=True, keep_clear_s=120.0,
        keep_clear_m=1.2, climb_at_s=108.0, platform_past_m=(0.05, 0.15),
    )  # fmt: skip
    env = replace(env, max_steps=400, skills=skills)
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=8), seed=4)
    fm.set_kinds([("policy", -1)] * 8)
    seen = _drive_and_compare(fm, 520, seed=2)
    assert seen["passed over"] > 100 and seen["endgame climb"] > 500, seen
    assert seen["leaving their platform"] > 20, seen
    assert seen["stopped"] > 0 and seen["claims ring"] > 100, seen


def test_fast_matches_drive_their_robots_with_the_controllers() -> None:
    """FastMatches' learner and opponent commands are the controllers' (a SkillDriver per robot
    through matches that restart), and its deciding flags are not committed()."""
    n = 4
    env, fm = _matches(n, max_steps=60, seed=2)
    assert env.skills is not None
    commands: list[tuple[np.ndarray, ...]] = []
    original = fm._commands

    def spy(actions: np.ndarray, who: np.ndarray) -> tuple[np.ndarray, ...]:
        commands.append(original(actions, who))
        return commands[-1]

    fm._commands = spy  # type: ignore[method-assign]
    step = fm.reset()
    python = _python_drivers(fm)
    rng = np.random.default_rng(1)
    rows = np.arange(n)
    for t in range(200):
        mine, theirs = rng.normal(size=(2, n, env.action_size))
        for k in range(n):
            me = int(fm.learner[k])
            assert step.deciding[k] == (not python[k][me].committed(step.learner_obs[k])), t
        want = [
            [python[k][int(who[k])].command(fm.obs[k, int(who[k])], a[k, : env.skills.n_options])
             for k in range(n)]
            for a, who in ((mine, fm.learner), (theirs, 1 - fm.learner))
        ]  # fmt: skip
        commands.clear()
        step = fm.step(mine, theirs)
        for (lin, ang, *_), expected in zip(commands, want, strict=True):
            got = [(lin[k], ang[k]) for k in rows]
            np.testing.assert_allclose(got, expected, rtol=0, atol=1e-12, err_msg=str(t))
        for k in np.flatnonzero(step.dones):
            python[k] = [SkillDriver(c, fm.spec) for c in fm._drivers.configs]  # type: ignore[union-attr]


def test_the_batched_labels_equal_intent_label() -> None:
    """Intents of every kind at points near the observation's slots (the route's first stop,
    ring and goal slots: some within option_for's 0.3 m, some not) and far from them."""
    n = 8
    env, fm = _matches(n, max_steps=400, seed=9)
    skills = env.skills
    assert skills is not None
    spec = fm.spec
    rng = np.random.default_rng(3)
    fm.reset()
    labels = OptionLabels(spec, skills)
    labelled: Counter[int] = Counter()
    rows = np.arange(n)
    for t in range(120):
        route = np.zeros((n, env.action_size))
        route[:, 0] = 1.0
        fm.step(route, route)
        if t % 4:
            continue
        me = fm.learner
        obs = fm.obs[rows, me]
        pose = np.stack(
            [fm.world.x[rows, me], fm.world.y[rows, me], fm.world.heading[rows, me]], -1
        )
        for _ in range(6):
            intent = rng.integers(0, len(INTENTS), n)
            point = np.full((n, 2), np.nan)
            for k in range(n):
                if intent[k] == 0:
                    continue
                frame = obs[k, : spec.frame_size].astype(np.float64)
                slot = rng.choice(
                    [spec.route_offset, spec.ring_offset + 3 * int(rng.integers(0, 4)),
                     spec.goal_offset + 3 * int(rng.integers(0, 2))]
                )  # fmt: skip
                local = frame[slot : slot + 2] * spec.length_unit_m + rng.normal(0, 0.2, 2)
                if rng.random() < 0.2:
                    local = rng.uniform(-2, 2, 2)
                point[k] = robot_to_field(local[None], pose[k, :2], pose[k, 2])[0]
            got = labels(intent, point, pose, obs)
            for k in range(n):
                kind = INTENTS[int(intent[k])]
                plan = (kind, None if kind == "other" else point[k].copy())
                want = intent_label(
                    DriveCommand(0.0, 0.0), plan, fm.world.robot_configs[int(me[k])],
                    (float(pose[k, 0]), float(pose[k, 1]), float(pose[k, 2])), obs[k], spec,
                    skills,
                )  # fmt: skip
                np.testing.assert_array_equal(got[k], want, err_msg=f"{t}, {k}, {kind}")
                labelled[int(np.argmax(want)) if np.isfinite(want).all() else -1] += 1
    for option in range(skills.n_options):
        assert labelled[option] > 0, labelled
    assert labelled[-1] > 0, labelled


def test_the_batched_controller_refuses_what_it_does_not_run() -> None:
    """Letting go in a tug of war (release_dragged_s) and room to turn from the partner
    (partner_room_m) are SkillDriver's only: a clear error, not a controller that drives
    differently."""
    spec = ObservationSpec(n_stack=0, goal_memory=True, goal_clamp_offset_m=0.35, partner=True)
    skills = SkillConfig(ring_options=2, goal_options=2, release_dragged_s=1.0)
    with pytest.raises(ValueError, match="release_dragged_s"):
        FastSkillDrivers([skills] * 2, spec, 2, 1 / 12)
    roomy = SkillConfig(ring_options=2, goal_options=2, partner_room_m=0.8)
    with pytest.raises(ValueError, match="partner_room_m"):
        FastSkillDrivers([roomy] * 2, spec, 2, 1 / 12)
