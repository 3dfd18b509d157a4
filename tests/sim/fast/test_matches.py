"""Training on the batched backend: FastMatches keeps VecMatches' contract (seeded sides and
starts, rewards as MatchCore's components, truncation with the final observation), the trainer
runs on it, and a config it cannot run is refused by name."""

from __future__ import annotations

import tomllib
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from sim.cli import main
from sim.errors import ConfigError
from sim.fast.matches import FastMatches
from sim.match import make_config
from sim.training.config import FastConfig, load_config, parse_config
from sim.training.rollout import RolloutConfig
from sim.training.trainer import train
from sim.world.physics import World

ENV = {"world": {"start_jitter_m": 0.1, "ring_jitter_m": 0.03}, "max_steps": 30}


def test_each_match_starts_as_the_pybullet_slot_would() -> None:
    env = make_config(ENV)
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=4), seed=7)
    fm.set_kinds([("idle", -1)] * 4)
    fm.reset()
    for k in range(4):
        rng = np.random.default_rng((7, k, 0))
        red = rng.random() < 0.5
        assert fm.learner[k] == (0 if red else 1)
        with World(env.world) as w:
            w.reset(rng)
            assert np.allclose([r.x for r in w.robots], fm.world.x[k])
            assert np.allclose(w.ring_xy, fm.world.ring_xy[k])


def test_rewards_are_the_components_and_truncation_bootstraps() -> None:
    env = make_config({**ENV, "reward": {"ring": 2.0, "approach": 1.0, "ring_cap": 10}})
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=16), seed=1)
    fm.set_kinds([("random", -1)] * 16)
    first = fm.reset()
    assert first.learner_obs.shape == (16, fm.spec.size)
    assert not first.opponent_obs.any()  # no policy opponent: zeros
    forward = np.tile(np.float32([1.0, 0.0]), (16, 1))
    episodes, total = [], np.zeros(16)
    for _ in range(30):
        res = fm.step(forward, np.zeros((16, 2), np.float32))
        total += res.rewards
        episodes += res.episodes
    assert res.dones.all() and res.truncated.all()  # max_steps: truncated, not ended
    assert res.final_obs.shape == (16, fm.spec.size) and res.final_obs.any()
    assert len(episodes) == 16
    for ep in episodes:
        assert ep.length == 30
        assert ep.reward == pytest.approx(sum(ep.components.values()))
        assert ep.components["rings"] == pytest.approx(2.0 * min(ep.rings, 10))
    assert np.allclose(sorted(total), sorted(ep.reward for ep in episodes), atol=1e-3)
    assert sum(ep.rings for ep in episodes) > 0  # driving forward from the start meets rings


def test_a_policy_opponent_gets_its_own_observation_and_actions() -> None:
    env = make_config(ENV)
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=4), seed=3)
    fm.set_kinds([("policy", 5)] * 4)
    res = fm.reset()
    assert res.opponent_obs.any() and not np.array_equal(res.opponent_obs, res.learner_obs)
    x0 = fm.world.x.copy()
    for _ in range(6):
        fm.step(np.zeros((4, 2), np.float32), np.tile(np.float32([1.0, 0.0]), (4, 1)))
    moved = np.abs(fm.world.x - x0) + np.abs(fm.world.y)
    them = 1 - fm.learner
    assert (np.abs(fm.world.x - x0)[np.arange(4), fm.learner] < 1e-9).all()
    assert moved[np.arange(4), them].min() > 0


UNSUPPORTED = """
name = "occluded"
backend = "fast"
[env.world]
occlude_with_rings = true
[opponents]
pool = 0.5
none = 0.5
"""


def test_what_the_fast_backend_cannot_run_is_named() -> None:
    cfg = parse_config(tomllib.loads(UNSUPPORTED))
    with pytest.raises(ConfigError, match="occlude_with_rings") as e:
        cfg.on_backend()
    assert "opponents.none" in str(e.value)
    env = make_config(ENV)
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=2), seed=1)
    with pytest.raises(ConfigError, match="none"):
        fm.set_kinds([("none", -1)] * 2)


def test_pete_sim_train_refuses_a_config_the_fast_backend_cannot_run(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    config = tmp_path / "occluded.toml"
    config.write_text(UNSUPPORTED)
    run = tmp_path / "run"
    code = main(["train", "--config", str(config), "--run-dir", str(run)])
    assert code == 2
    err = capsys.readouterr().err
    assert "--backend fast" in err and "occlude_with_rings" in err
    assert not run.exists()  # refused before the run folder was written


def test_the_trainer_runs_on_the_fast_backend(tmp_path: Path) -> None:
    cfg = replace(
        load_config("tiny"),
        backend="fast",
        fast=FastConfig(envs=64, steps_per_env=16),
        total_steps=4096,
        checkpoint_steps=4096,
    )
    cfg = replace(cfg, env={**cfg.env, "max_steps": 48})
    result = train(cfg, tmp_path / "run", progress=False, export=False)
    assert result.steps == 4096
    assert result.episodes >= 64  # matches of 48 steps ended and started again
    assert (tmp_path / "run" / "checkpoints" / "latest.pt").is_file()
    assert result.history[-1]["charts/steps_per_s"] > 0


@pytest.mark.parametrize("curriculum", ["goal_start_share", "midgame_start_share"])
def test_the_start_curricula_start_as_matchcore_starts(curriculum: str) -> None:
    from sim.match import MatchCore

    env = make_config({**ENV, curriculum: 1.0, "uncapped_share": 0.5})
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=6), seed=11)
    fm.set_kinds([("idle", -1)] * 6)
    fm.reset()
    core = MatchCore(env)
    try:
        for k in range(6):
            rng = np.random.default_rng((11, k, 0))
            rng.random()  # the learner's side, drawn first as _Slot draws it
            core.reset(rng)
            w = core.world
            xyh = np.array([(r.x, r.y, r.heading) for r in w.robots])
            fast = np.stack([fm.world.x[k], fm.world.y[k], fm.world.heading[k]], -1)
            assert np.allclose(xyh, fast)
            assert [r.collected for r in w.robots] == list(fm.world.collected[k])
            assert [r.held for r in w.robots] == list(fm.world.held[k])
            assert fm.uncapped[k] == core.uncapped
            assert int((w.ring_state == 0).sum()) == int(fm.world.ring_floor[k].sum())
    finally:
        core.close()


def test_actions_of_the_wrong_shape_are_refused_before_anything_moves() -> None:
    fm = FastMatches(make_config(ENV), RolloutConfig(workers=0, envs_per_worker=4), seed=2)
    fm.set_kinds([("policy", 1)] * 4)
    fm.reset()
    with pytest.raises(ValueError, match="opponent actions must have shape"):
        fm.step(np.zeros((4, 2), np.float32), np.zeros((4, 3), np.float32))
    with pytest.raises(ValueError, match="actions must have shape"):
        fm.step(np.zeros((2, 2), np.float32), np.zeros((4, 2), np.float32))
    assert not fm.world.steps.any() and not fm.steps.any()


def test_the_route_teacher_drives_its_learner_to_the_rings_it_remembers() -> None:
    """capped.toml's game on the fast backend: the ring memory and route slots in the learner's
    observation, the route skill's labels as advice. Following the advice fills the intake;
    standing still collects nothing."""
    env = load_config("capped").env_config()
    n = 8
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=n), seed=3, teacher="route")
    fm.set_kinds([("idle", -1)] * n)
    step = fm.reset()
    assert step.advice is not None and np.isfinite(step.advice).all()
    spec = fm.spec
    assert spec.route_slots == 1 and len(spec.prior_rings) > 0
    route_ok = step.learner_obs[:, spec.route_offset + 2]
    assert (route_ok == 1.0).all()  # every learner has a first stop from the start
    rings = np.zeros(n)
    for _ in range(96):
        advice = step.advice
        assert np.abs(advice).max() <= 1.0
        step = fm.step(advice, np.zeros((n, 2)))
        for e in step.episodes:
            rings[e.slot] = e.rings
    assert np.median(rings) >= 9  # the route fills a 10-ring intake in the 8 s match (3 s)
    idle = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=n), seed=3)
    idle.set_kinds([("idle", -1)] * n)
    idle.reset()
    for _ in range(96):
        step = idle.step(np.zeros((n, 2)), np.zeros((n, 2)))
        assert step.advice is not None and np.isnan(step.advice).all()  # no teacher, no advice
    assert all(e.rings == 0 for e in step.episodes)


def test_capped_toml_trains_on_the_fast_backend_with_its_route_teacher(tmp_path: Path) -> None:
    """capped.toml as it is: its [fast] table sizes the rollouts, the planner is a quarter of
    the opponents, the route teacher pulls."""
    cfg = replace(load_config("capped"), backend="fast")
    assert cfg.opponents["planner"] > 0
    fast = cfg.on_backend()
    assert fast.opponents == cfg.opponents and fast.rollout.n_envs == 16
    cfg = replace(cfg, total_steps=2048, checkpoint_steps=2048)
    result = train(cfg, tmp_path / "run", progress=False, export=False)
    assert result.steps == 2048
    assert result.history[-1]["charts/imitation_coef"] > 0
    assert np.isfinite(result.history[-1]["losses/imitation_loss"])


def test_a_skill_policy_drives_through_each_robots_skill_controller() -> None:
    """default.toml's skills on the fast backend: the route option (score it highest) fills the
    intake as the planner's tour does; a goal option commits the robot to its manoeuvre, and
    the learner decides nothing until the clamp closes or its time is up."""
    cfg = load_config("default")
    env = cfg.env_config()
    assert env.skills is not None and env.skills.route_option
    n = 6
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=n), seed=5)
    fm.set_kinds([("idle", -1)] * n)
    step = fm.reset()
    route = np.full((n, env.action_size), -1.0)
    route[:, 0] = 1.0
    most = np.zeros(n)
    for _ in range(60):  # 5 s
        step = fm.step(route, np.zeros_like(route))
        assert step.deciding is not None and step.deciding.all()
        most = np.maximum(most, fm.world.collected[np.arange(n), fm.learner])
    assert np.median(most) >= 8  # the route fills the 10-ring intake (uncapped: more)
    goal = np.full((n, env.action_size), -1.0)
    goal[:, 1 + env.skills.ring_options] = 1.0  # the nearest goal slot
    step = fm.step(goal, np.zeros_like(goal))
    assert step.deciding is not None and not step.deciding.any()  # committed to the goal
    for _ in range(2):
        step = fm.step(goal, np.zeros_like(goal))
    rows = np.arange(n)
    v0 = np.abs(fm.world.v[rows, fm.learner])
    assert v0.max() > 0.1  # backing onto goals
    bad = np.full((n, env.action_size), np.nan)
    fm.step(bad, np.zeros_like(bad))  # NaN scores: a stop (braking), not the manoeuvre
    v1 = np.abs(fm.world.v[rows, fm.learner])
    assert (v1 <= v0 + 1e-9).all() and (v1 < v0).any()


def test_intake_actions_run_the_intake_only_when_asked() -> None:
    """A drive policy with an intake action (action_intake): rings come in only while it is
    above 0, as MatchCore.command's actuators have it."""
    env = make_config({**ENV, "max_steps": 200, "action_intake": True})
    assert env.action_size == 3
    n = 8
    rings = {}
    for on in (1.0, -1.0):
        fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=n), seed=2)
        fm.set_kinds([("idle", -1)] * n)
        fm.reset()
        forward = np.tile([0.8, 0.15, on], (n, 1))
        for _ in range(60):
            fm.step(forward, np.zeros_like(forward))
        rings[on] = int(fm.world.collected[np.arange(n), fm.learner].sum())
    assert rings[1.0] > 4 and rings[-1.0] == 0, rings


def test_the_planner_plays_and_teaches_on_fast_matches() -> None:
    """default.toml's planner on the fast backend: as the opponent it drives the other robot to
    rings, as the teacher its labels pick the skill that does what it intends; following them
    fills the learner's intake too."""
    env = load_config("default").env_config()
    n = 4
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=n), seed=5, teacher="planner")
    fm.set_kinds([("planner", -1)] * 2 + [("scripted", -1)] * 2)
    step = fm.reset()
    rows = np.arange(n)
    picked = 0
    for _ in range(96):  # 8 s
        advice = step.advice
        assert advice is not None and advice.shape == (n, env.skills.n_options)
        labelled = np.isfinite(advice).all(axis=1)
        assert ((advice[labelled] == 1.0).sum(axis=1) == 1).all()  # one option, +1
        picked += int(labelled.sum())
        step = fm.step(np.nan_to_num(advice, nan=-1.0), np.zeros((n, env.action_size)))
    assert picked > 0.5 * 96 * n  # (NaN: backing off, searching, a target off the slots)
    assert (fm.world.collected[rows, fm.learner] >= 8).all()
    assert (fm.world.collected[rows, 1 - fm.learner] >= 5).all()  # the opponents collect too


def test_default_toml_trains_on_the_fast_backend(tmp_path: Path) -> None:
    """The shipped policy's config, unchanged: skills, memories, the planner teaching and a
    quarter of the opponents, on the fast backend."""
    cfg = replace(
        load_config("default"),
        backend="fast",
        fast=FastConfig(envs=8, steps_per_env=32),
        total_steps=512,
        checkpoint_steps=512,
    )
    result = train(cfg, tmp_path / "run", progress=False, export=False)
    assert result.steps == 512
    assert result.history[-1]["charts/imitation_coef"] > 0
    assert np.isfinite(result.history[-1]["losses/imitation_loss"])


def test_a_slot_whose_opponent_changes_plays_the_new_one_from_its_next_match() -> None:
    env = make_config({**ENV, "max_steps": 3})
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=2), seed=4)
    fm.set_kinds([("planner", -1), ("scripted", -1)])
    fm.reset()
    assert fm._planning[0] and fm._players[1] is not None
    fm.set_kinds([("policy", -1)] * 2)
    still = np.zeros((2, env.action_size))
    for _ in range(3):  # the matches end (max_steps) and start again with the new opponent
        fm.step(still, still)
    assert fm.kinds == ["policy", "policy"] and all(p is None for p in fm._players)
    assert not fm._planning.any()
    them = 1 - fm.learner
    ahead = np.tile([1.0, 0.0], (2, 1))
    for _ in range(2):  # inside the new 3-step matches
        fm.step(still, ahead)  # the caller drives the opponents now, not a planner
    assert fm.world.v[np.arange(2), them].min() > 0.3
