"""Training runs end to end: learning on an easy task, determinism, run files, resume, workers."""

from __future__ import annotations

import json
from dataclasses import replace
from pathlib import Path
from statistics import fmean

import pytest
import torch

from sim.training.config import parse_config
from sim.training.trainer import Progress, train

# Easy: no opponent, 8 s episodes from the start pose, one frame of observation, a small network
# and a robot that starts out driving forward, so the first rings are within reach of noise.
EASY = {
    "name": "easy",
    "seed": 5,
    "total_steps": 8192,
    "checkpoint_steps": 100_000,
    "env": {
        "max_steps": 96,
        "world": {"start_jitter_m": 0.05, "start_jitter_deg": 5.0},
        "observation": {"n_stack": 0},
    },
    "ppo": {
        "learning_rate": 1e-3,
        "n_epochs": 4,
        "minibatch_size": 128,
        "ent_coef": 0.0,
        "hidden": [32, 32],
        "init_action_bias": [0.5, 0.0],
        "init_log_std": -0.5,
    },
    "rollout": {"workers": 0, "envs_per_worker": 16, "steps_per_env": 32},
    "opponents": {"none": 1.0},
}


def test_short_training_improves_reward_on_an_easy_task(tmp_path: Path) -> None:
    rings_per_iteration: list[float] = []

    def record(p: Progress) -> bool:
        if p.episodes:
            rings_per_iteration.append(fmean(e.rings for e in p.episodes))
        return False

    result = train(parse_config(EASY), tmp_path / "run", progress=False, callback=record)
    assert result.steps == 8192
    first = fmean(rings_per_iteration[:2])
    last = fmean(rings_per_iteration[-2:])
    # Measured: ~2 rings per 8 s episode at first, ~6 after 8k steps.
    assert last >= first + 2.0, (first, last, rings_per_iteration)


def _weights(run: Path) -> dict[str, torch.Tensor]:
    state = torch.load(run / "checkpoints" / "latest.pt", weights_only=True)
    return state["agent"]


def test_training_is_deterministic_for_a_seed(tmp_path: Path) -> None:
    cfg = replace(parse_config(EASY), total_steps=1024)
    train(cfg, tmp_path / "a", progress=False, export=False)
    train(cfg, tmp_path / "b", progress=False, export=False)
    a, b = _weights(tmp_path / "a"), _weights(tmp_path / "b")
    assert all(torch.equal(a[k], b[k]) for k in a)
    train(replace(cfg, seed=6), tmp_path / "c", progress=False, export=False)
    c = _weights(tmp_path / "c")
    assert not all(torch.equal(a[k], c[k]) for k in a)


def test_self_play_on_two_workers_writes_run_files_and_resumes(tmp_path: Path) -> None:
    data = {
        **EASY,
        "total_steps": 256,
        "checkpoint_steps": 128,
        "rollout": {"workers": 2, "envs_per_worker": 2, "steps_per_env": 32},
        "selfplay": {"save_steps": 128, "swap_steps": 128, "window": 2},
        "opponents": {"pool": 0.5, "scripted": 0.5},
        "env": {**EASY["env"], "max_steps": 40},
    }
    cfg = parse_config(data)
    run = tmp_path / "run"
    result = train(cfg, run, progress=False)
    assert result.steps == 256 and result.episodes == 4, "4 matches, one 40-step match each"
    for name in ("config.json", "run.json", "policy.onnx", "policy.json"):
        assert (run / name).is_file(), name
    assert list((run / "tb").glob("events.out.tfevents.*")), "TensorBoard log"
    info = json.loads((run / "run.json").read_text())
    assert info["seed"] == 5 and "torch" in info["starts"][0]["versions"]
    assert json.loads((run / "config.json").read_text())["rollout"]["workers"] == 2
    state = torch.load(run / "checkpoints" / "latest.pt", weights_only=True)
    assert state["step"] == 256
    assert len(state["pool"]["snapshots"]) == 2, "snapshots every 128 steps, window 2"

    resumed = train(replace(cfg, total_steps=384), run, resume=True, progress=False)
    assert resumed.steps == 384
    info = json.loads((run / "run.json").read_text())
    assert [s["resumed"] for s in info["starts"]] == [False, True]
    with pytest.raises(FileNotFoundError, match=r"latest\.pt"):
        train(cfg, tmp_path / "empty", resume=True, progress=False)


def test_interrupt_keeps_a_checkpoint_and_an_export(tmp_path: Path) -> None:
    def stop(p: Progress) -> bool:
        if p.iteration == 2:
            raise KeyboardInterrupt
        return False

    cfg = replace(parse_config(EASY), total_steps=8192)
    result = train(cfg, tmp_path / "run", progress=False, callback=stop)
    assert result.interrupted and result.steps == 1024
    assert (tmp_path / "run" / "policy.onnx").is_file()
    state = torch.load(tmp_path / "run" / "checkpoints" / "latest.pt", weights_only=True)
    assert state["step"] == 1024


def test_short_matches_go_to_an_even_share_of_slots() -> None:
    from sim.training.rollout import RolloutConfig

    r = RolloutConfig(workers=2, envs_per_worker=8, short_share=0.5, short_steps=240)
    limits = [r.slot_limit(i) for i in range(r.n_envs)]
    assert limits.count(240) == 8 and limits.count(None) == 8
    assert limits[:8] == limits[8:], "the same on every worker"
    assert RolloutConfig().slot_limit(3) is None


def test_a_curriculum_phase_changes_the_matches_mid_run(tmp_path: Path) -> None:
    data = {
        **EASY,
        "total_steps": 1024,
        "env": {**EASY["env"], "max_steps": 40},
        "rollout": {"workers": 0, "envs_per_worker": 4, "steps_per_env": 64},
        "opponents": {"none": 1.0},
        "phases": [{"from_step": 500, "opponents": {"idle": 1.0}}],
    }
    kinds: list[set[str]] = []

    def record(p: Progress) -> bool:
        kinds.append({e.kind for e in p.episodes})
        return False

    train(parse_config(data), tmp_path / "run", progress=False, callback=record, export=False)
    assert kinds[0] == {"none"} and kinds[-1] == {"idle"}


def test_end_at_fill_ends_the_match_as_terminal_at_the_fill_target() -> None:
    import numpy as np

    from sim.match import make_config
    from sim.training.rollout import RolloutConfig, _Slot

    env = make_config({"max_steps": 96, "world": {"start_jitter_m": 0.0, "start_jitter_deg": 0.0}})
    ends = {}
    for end in (False, True):
        rollout = RolloutConfig(workers=0, fill_target=1, end_at_fill=end)
        slot = _Slot(env, rollout, seed=3, slot=0)
        slot.set_kind("none", -1)
        slot.reset()
        for step in range(1, 97):  # noqa: B007 (the step the loop stopped at is compared)
            _, done, truncated = slot.step(np.array([1.0, 0.0]), np.zeros(2))
            if slot.fill_time is not None or done:
                break
        ends[end] = (step, done, truncated, slot.stats().rings)
    step, done, truncated, rings = ends[True]
    assert (done, truncated, rings) == (True, False, 1), "terminal, not truncated: no bootstrap"
    assert ends[False][0] == step and ends[False][1:3] == (False, False)


def test_the_planner_teacher_labels_every_learner_state_with_its_own_action() -> None:
    """The advice for a state is the action the planner takes when it drives from that state:
    a learner that follows its advice drives exactly as the planner does."""
    import numpy as np

    from sim.baselines.planner import Planner
    from sim.match import make_config
    from sim.training.rollout import RolloutConfig, VecMatches, _Slot

    env = make_config({"max_steps": 96, "world": {"start_jitter_m": 0.0, "start_jitter_deg": 0.0}})
    rollout = RolloutConfig(workers=0, envs_per_worker=2)
    with VecMatches(env, rollout, seed=4) as plain:
        plain.set_kinds([("none", -1)] * 2)
        assert plain.reset().advice is not None and np.isnan(plain.reset().advice).all()

    taught = _Slot(env, rollout, seed=4, slot=0, teacher="planner")
    driven = _Slot(env, rollout, seed=4, slot=0)  # the same match, driven by the planner itself
    for slot in (taught, driven):
        slot.set_kind("none", -1)
        slot.reset()
    planner = Planner()
    planner.reset(driven.core, driven.learner)
    robot = driven.core.world.robots[driven.learner].config
    for _ in range(60):
        advice = taught.advice()
        command = planner.act(driven.core, driven.learner)
        expected = np.clip(
            [command.linear / robot.max_linear_mps, command.angular / robot.max_angular_rad_s],
            -1,
            1,
        )
        np.testing.assert_allclose(advice, expected, atol=1e-6)
        # Both take the very same action: the float32 advice and the float64 command differ
        # in the eighth digit, and a robot brushing a ring can grow that into millimetres.
        taught.step(advice, np.zeros(2))
        driven.step(advice, np.zeros(2))
    assert taught.stats().rings == driven.stats().rings >= 3


def test_the_route_teacher_advises_the_route_skill_from_the_learners_own_observation() -> None:
    """The route teacher's advice is what jetson.autonomy.skills drives onto the observation's first
    route slot: a function of the observation alone. A learner that follows it collects rings; a
    config whose observation has no route slot, or a skill policy, is refused by name."""
    import numpy as np

    from jetson.autonomy.skills import SkillConfig
    from sim.errors import ConfigError
    from sim.match import make_config
    from sim.training.rollout import RolloutConfig, VecMatches, _Slot

    world = {"start_jitter_m": 0.0, "start_jitter_deg": 0.0}
    obs = {"n_stack": 2, "ring_memory": True, "route_slots": 1}
    env = make_config({"max_steps": 150, "world": world, "observation": obs})
    rollout = RolloutConfig(workers=0, envs_per_worker=1)
    slot = _Slot(env, rollout, seed=3, slot=0, teacher="route")
    slot.set_kind("none", -1)
    slot.reset()
    driver = slot.core.skill_driver(
        slot.learner, SkillConfig(route_option=True, ring_options=0, goal_options=0, platform=False)
    )
    robot = slot.core.world.robots[slot.learner].config
    for _ in range(150):
        advice = slot.advice()
        v, w = driver.command(slot.obs[slot.learner], np.ones(1))
        expected = np.clip([v / robot.max_linear_mps, w / robot.max_angular_rad_s], -1, 1)
        np.testing.assert_allclose(advice, expected, atol=1e-6)
        _, done, _ = slot.step(advice, np.zeros(2))
        if done:
            break
    assert slot.stats().rings >= 10

    no_route = make_config({"world": world, "observation": {"n_stack": 2, "ring_memory": True}})
    with pytest.raises(ConfigError, match="route_slots"):
        VecMatches(no_route, rollout, seed=1, teacher="route")
    skills = make_config({"world": world, "observation": obs, "skills": {"route_option": True}})
    with pytest.raises(ConfigError, match="drive policy"):
        VecMatches(skills, rollout, seed=1, teacher="route")
    data = {**EASY, "imitation": {"teacher": "route", "until_step": 100}}
    with pytest.raises(ConfigError, match="route_slots"):
        parse_config(data)


def test_imitation_config_is_checked_and_its_weight_falls_to_zero() -> None:
    from sim.errors import ConfigError

    data = {**EASY, "imitation": {"teacher": "planner", "coef": 2.0, "until_step": 1000}}
    im = parse_config(data).imitation
    assert [im.coef_at(s) for s in (0, 500, 1000, 5000)] == [2.0, 1.0, 0.0, 0.0]
    assert parse_config(EASY).imitation.coef_at(0) == 0.0
    with pytest.raises(ConfigError, match=r"imitation\.teacher"):
        parse_config({**EASY, "imitation": {"teacher": "scripted"}})
    with pytest.raises(ConfigError, match="coef"):
        parse_config({**EASY, "imitation": {"teacher": "planner", "coef": -1.0}})
    back = {"teacher": "planner", "coef": 1.0, "from_step": 2000, "until_step": 3000}
    late = parse_config({**EASY, "imitation": back}).imitation
    assert [late.coef_at(s) for s in (0, 1999, 2000, 2500, 3000)] == [0.0, 0.0, 1.0, 0.5, 0.0]
    with pytest.raises(ConfigError, match=r"until_step .* must come after from_step"):
        parse_config({**EASY, "imitation": {**back, "until_step": 1500}})


def test_the_teacher_can_stay_longer_in_uncapped_matches() -> None:
    from sim.errors import ConfigError

    kept = {"teacher": "planner", "coef": 2.0, "until_step": 1000, "uncapped_until_step": 0}
    im = parse_config({**EASY, "imitation": kept}).imitation
    assert [im.coef_at(s) for s in (0, 500, 1000)] == [2.0, 1.0, 0.0]
    assert [im.coef_at(s, uncapped=True) for s in (0, 500, 1000, 10**7)] == [2.0] * 4
    later = parse_config({**EASY, "imitation": {**kept, "uncapped_until_step": 2000}}).imitation
    assert [later.coef_at(s, uncapped=True) for s in (1000, 2000)] == [1.0, 0.0]
    # Unset, uncapped matches follow until_step.
    same = parse_config({**EASY, "imitation": {**kept, "uncapped_until_step": None}}).imitation
    assert same.coef_at(500, uncapped=True) == same.coef_at(500) == 1.0
    for bad in (-5, "soon"):
        with pytest.raises(ConfigError, match="uncapped_until_step"):
            parse_config({**EASY, "imitation": {**kept, "uncapped_until_step": bad}})


def test_each_row_knows_its_game_and_the_teacher_parks_only_where_parking_pays() -> None:
    import numpy as np

    from sim.match import make_config
    from sim.training.rollout import RolloutConfig, VecMatches, _Slot

    paid = {"park": 2.0, "elevated_end": 5.0}
    for share, want in ((0.0, False), (1.0, True)):
        env = make_config(
            {"max_steps": 4, "uncapped_share": share, "reward": paid,
             "uncapped_reward": {"park": 0.0, "elevated_end": 0.0}}
        )  # fmt: skip
        with VecMatches(env, RolloutConfig(workers=0, envs_per_worker=3), seed=2) as vec:
            vec.set_kinds([("none", -1)] * 3)
            first = vec.reset()
            assert first.uncapped is not None and (first.uncapped == want).all()
            for _ in range(6):  # through a reset: the new match's rows keep their game
                step = vec.step(np.zeros((3, 2), np.float32), np.zeros((3, 2), np.float32))
                assert step.uncapped is not None and (step.uncapped == want).all()
        slot = _Slot(env, RolloutConfig(workers=0), seed=2, slot=0, teacher="planner")
        slot.set_kind("none", -1)
        slot.reset()
        assert slot.teacher is not None and slot.teacher.config.endgame is (not want)
        slot.close()


def test_a_skill_policy_learns_to_pick_rings_and_exports_its_controller(tmp_path: Path) -> None:
    # Skills from a start that prefers the platform: training must learn to pick the ring.
    cfg = dict(EASY, name="easy-skills", total_steps=8192)
    cfg["env"] = dict(
        EASY["env"],
        observation={"n_stack": 0, "ring_memory": True, "goal_memory": True},
        skills={"ring_options": 1, "goal_options": 1, "platform": True},
    )
    cfg["ppo"] = dict(
        EASY["ppo"], init_action_bias=[-0.5, 0.0, 0.5], init_log_std=0.0, learning_rate=3e-3
    )
    rings_per_iteration: list[float] = []

    def record(p: Progress) -> bool:
        if p.episodes:
            rings_per_iteration.append(fmean(e.rings for e in p.episodes))
        return False

    run = tmp_path / "run"
    train(parse_config(cfg), run, progress=False, callback=record)
    first, last = fmean(rings_per_iteration[:2]), fmean(rings_per_iteration[-2:])
    assert last >= first + 1.0, (first, last, rings_per_iteration)
    meta = json.loads((run / "policy.json").read_text())
    assert meta["actions"]["names"] == ["ring0", "goal0", "platform"]

    from sim.evaluate import evaluate, load_player

    ours = load_player(str(run))
    summary = evaluate(ours, None, 2, 0, "capped", base_env={"max_steps": 96})
    assert summary.side(0)["rings"].mean >= 1.0


def test_for_a_skill_policy_the_planner_teacher_names_the_option_it_would_take() -> None:
    """A learner that follows its skill advice collects rings; the advice is a ring option
    early on and a goal option once the intake is full."""
    import numpy as np

    from sim.match import make_config
    from sim.training.rollout import RolloutConfig, _Slot

    env = make_config(
        {
            "max_steps": 12 * 30,
            "world": {"start_jitter_m": 0.0, "start_jitter_deg": 0.0},
            "observation": {"n_stack": 0, "ring_memory": True, "goal_memory": True},
            "skills": {"ring_options": 4, "goal_options": 2},
        }
    )
    assert env.skills is not None
    slot = _Slot(
        env, RolloutConfig(workers=0, envs_per_worker=1), seed=4, slot=0, teacher="planner"
    )
    slot.set_kind("none", -1)
    slot.reset()
    names = env.skills.option_names()
    chosen: list[str] = []
    for _ in range(12 * 30):
        advice = slot.advice()
        if np.isfinite(advice).all():
            assert sorted(advice.tolist()) == [-1.0] * (len(names) - 1) + [1.0]
            chosen.append(names[int(np.argmax(advice))])
        else:
            advice = np.zeros(len(names))
            advice[0] = 1.0  # no option does what the planner does now: the nearest ring
        _, done, trunc = slot.step(advice, np.zeros(len(names)))
        if done or trunc:
            break
    robot = slot.core.world.robots[slot.learner]
    assert robot.collected >= 10
    assert chosen[0].startswith("ring") and any(c.startswith("goal") for c in chosen)


def test_a_committed_skill_makes_the_next_states_non_deciding() -> None:
    import numpy as np

    from sim.match import make_config
    from sim.training.rollout import RolloutConfig, VecMatches

    env = make_config(
        {
            "max_steps": 60,
            "observation": {"n_stack": 0, "ring_memory": True, "goal_memory": True},
            "skills": {"ring_options": 1, "goal_options": 1, "platform": False,
                       "commit_goal_s": 2.0},
        }
    )  # fmt: skip
    with VecMatches(env, RolloutConfig(workers=0, envs_per_worker=2), seed=1) as vec:
        vec.set_kinds([("none", -1)] * 2)
        first = vec.reset()
        assert first.deciding is not None and first.deciding.all()
        goal = np.array([[-1.0, 1.0], [1.0, -1.0]], np.float32)  # slot 0: goal; slot 1: ring
        res = vec.step(goal, np.zeros_like(goal))
        assert res.deciding is not None and res.deciding.tolist() == [False, True]
