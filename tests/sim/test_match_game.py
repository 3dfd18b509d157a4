"""MatchCore and the whole game: a skill-driven robot carries its clamp (and intake) through to the
World, so it releases a goal as a drive-action robot does; a whole 2v2 Tipping Point match plays
to its end through MatchCore with its score broken down and its fouls counted."""

from __future__ import annotations

import numpy as np
import pytest

from jetson.autonomy.skills import SkillConfig
from sim.config import world_preset
from sim.match import EnvConfig, MatchCore, make_config
from sim.players import ScriptedPlayer
from sim.world.state import DriveCommand

GAME = {"game": "tipping_point", "isolation_s": 0.0, "preloads": False}
SKILLS = SkillConfig(ring_options=2, goal_options=0, platform=True)


def _core(**overrides: object) -> MatchCore:
    cfg = make_config(world=GAME, obs_noise=False, gps_noise=False, **overrides)
    return MatchCore(cfg)


def _back_onto_goal(core: MatchCore, robot: int, goal: int) -> None:
    w = core.world
    r, g = w.robots[robot], w.goals[goal]
    w.place_goal(goal, 0.0, 0.0)
    w.place_robot(robot, 0.0, g.spec.base_radius + r.config.length_m / 2 + 0.03, 0.0)


def test_the_skill_action_carries_the_clamp_and_the_intake() -> None:
    cfg = make_config(skills=SKILLS, action_intake=True, action_clamp=True)
    assert cfg.action_size == SKILLS.n_options + 2
    assert make_config(skills=SKILLS).action_size == SKILLS.n_options  # unchanged without them
    assert cfg.actuators(np.array([1.0, -1.0])) == (True, False)
    assert cfg.actuators(np.array([-0.5, 0.5])) == (False, True)
    assert make_config().actuators(np.zeros(0)) == (True, None)


def test_a_skill_driven_robot_grabs_and_releases_a_goal() -> None:
    core = _core(skills=SKILLS, action_clamp=True, opponent="none")
    try:
        core.reset(np.random.default_rng(0))
        w = core.world
        _back_onto_goal(core, 0, 5)
        n = SKILLS.n_options
        hold = np.r_[np.eye(n)[n - 1], 1.0]  # the platform skill, clamp held
        release = np.r_[np.eye(n)[n - 1], -1.0]
        cmd = core.command(0, hold)
        assert isinstance(cmd, DriveCommand) and cmd.clamp is True and cmd.intake is True
        core.step([cmd] + [DriveCommand(0.0, 0.0)] * (core.n_robots - 1))
        assert w.robots[0].carried_goal == 5
        core.step([core.command(0, release)] + [DriveCommand(0.0, 0.0)] * (core.n_robots - 1))
        assert w.robots[0].carried_goal is None and w.goals[5].carried_by is None
        for _ in range(6):  # it stays let go while the skill keeps driving
            core.step([core.command(0, release)] + [DriveCommand(0.0, 0.0)] * (core.n_robots - 1))
        assert w.goals[5].carried_by is None
    finally:
        core.close()


def test_a_skill_action_without_actuators_drives_as_before() -> None:
    core = _core(skills=SKILLS)
    try:
        core.reset(np.random.default_rng(3))
        cmd = core.command(0, np.eye(SKILLS.n_options)[0])
        assert cmd.intake is True and cmd.clamp is None
        stop = core.command(0, np.full(SKILLS.n_options, np.nan))
        assert (stop.linear, stop.angular, stop.clamp) == (0.0, 0.0, None)
        with pytest.raises(ValueError):
            core.command(0, np.zeros(SKILLS.n_options + 1))
    finally:
        core.close()


def test_a_whole_2v2_match_plays_to_its_end_through_matchcore() -> None:
    cfg = EnvConfig(world=world_preset("tipping_point_2v2"), end_on_pin=False, obs_noise=False)
    core = MatchCore(cfg)
    try:
        obs = core.reset(np.random.default_rng(4))
        players = [ScriptedPlayer() for _ in range(core.n_robots)]
        for i, p in enumerate(players):
            p.reset(core, i, np.random.default_rng(i))
        fouls = 0
        steps = 0
        phase_changes = 0
        while True:
            commands = [p.act(core, i, obs[i]) for i, p in enumerate(players)]
            results, ended, events = core.step(commands)
            obs = [r.observation for r in results]
            fouls += len(events.fouls)
            phase_changes += events.phase_changed
            steps += 1
            if ended:
                break
        w = core.world
        assert core.n_robots == 4 and steps == 1440 and w.time_s == pytest.approx(120.0)
        assert phase_changes >= 1 and w.autonomous is not None
        s = w.score()
        assert fouls == len(w.fouls) == s["red"].fouls + s["blue"].fouls
        for k, alliance in enumerate(("red", "blue")):
            a = s[alliance]
            assert results[k].info[f"score_{alliance}"] == a.total
            assert a.rings == a.rings_high + a.rings_low + a.rings_base
        assert s["red"].total + s["blue"].total > 80  # more than the four goals they start with
    finally:
        core.close()
