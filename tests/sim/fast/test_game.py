"""The whole game on the batched world against the PyBullet twin's training fidelity: the same
scenes (sim/world's whole-game tests: the see-saw climbed, tugs of war, goals stolen, rings placed
by each mechanism, fouls and the autonomous period, the isolation barrier) played on both from the
same state with the same commands, step for step, agree in where the robots and goals end, who
holds what, the boards' tilt, the fouls and the score."""

from __future__ import annotations

from collections.abc import Iterator
from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from sim.config import ROBOTS, WORLD_PRESETS, WorldConfig, world_preset
from sim.errors import WorldError
from sim.fast.matches import FastMatches
from sim.fast.world import FastWorld
from sim.match import make_config
from sim.training.config import FastConfig, load_config
from sim.training.rollout import RolloutConfig
from sim.training.trainer import train
from sim.world import rules
from sim.world.batch import ALLIANCE_CODES, FOUL_KINDS, SCORE_FIELDS
from sim.world.physics import World
from sim.world.state import RING_FLOOR, RING_HELD, DriveCommand
from tests.sim.world.test_goals import RING_PLACEMENTS

IDLE = DriveCommand(intake=False)
# The goals apart along the north and south walls, clear of every scene below (contacts the two
# worlds model differently are not what these scenes test).
SPOTS = [(0.0, 1.4), (0.5, 1.4), (-0.5, 1.4), (1.0, 1.4), (0.5, -1.4), (-0.5, -1.4), (1.0, -1.4)]


class Twin:
    """One scene on World (training fidelity) and on a FastWorld of one match: set up on the
    World, copied to the fast world (sync), then stepped with the same commands on both."""

    def __init__(self, config: WorldConfig, seed: int = 0) -> None:
        self.w = World(config)
        self.w.reset(np.random.default_rng(seed))
        self.f = FastWorld(config, 1)
        self.f.reset([seed])

    def close(self) -> None:
        self.w.close()

    def goal(self, name: str) -> int:
        return next(g.index for g in self.w.goals if g.spec.name == name)

    def clear(self) -> None:
        """No floor rings; the goals apart, out of the way."""
        self.w.set_floor_rings(np.zeros((0, 2)))
        for g, (x, y) in zip(self.w.goals, SPOTS, strict=True):
            self.w.place_goal(g.index, x, y)

    def back_onto(self, robot: int, goal: int, heading: float = 0.0) -> None:
        r, g = self.w.robots[robot], self.w.goals[goal]
        gap = g.spec.base_radius + r.config.length_m / 2 + 0.03
        v = {0.0: (0.0, 1.0), 90.0: (1.0, 0.0), 180.0: (0.0, -1.0), 270.0: (-1.0, 0.0)}[heading]
        self.w.place_robot(robot, g.x + gap * v[0], g.y + gap * v[1], heading)

    def sync(self) -> None:
        """The fast match takes the World's state."""
        w, f = self.w, self.f
        for r in w.robots:
            i = r.index
            f.place_robot(0, i, r.x, r.y, r.heading)
            f.v[0, i], f.w[0, i] = r.v, r.w
            f.held[0, i] = r.held
            f.carried[0, i] = -1 if r.carried_goal is None else r.carried_goal
            f.on_platform[0, i] = -1 if r.on_platform is None else ALLIANCE_CODES[r.on_platform]
            f.transfer[0, i] = r.transfer_timer
        for g in w.goals:
            f.gx[0, g.index], f.gy[0, g.index] = g.x, g.y
            f.carrier[0, g.index] = -1 if g.carried_by is None else g.carried_by
            f.contester[0, g.index] = -1 if g.contested_by is None else g.contested_by
            f.goal_rings[0, g.index] = g.rings
            f.rings_high[0, g.index] = g.rings_high
            f.rings_base[0, g.index] = g.rings_base
        floor = np.flatnonzero(w.ring_state == RING_FLOOR)
        f.ring_floor[0] = False
        f.ring_floor[0, : len(floor)] = True
        f.ring_xy[0, : len(floor)] = w.ring_xy[floor]
        for name, plat in w.platforms.items():
            f.tilt[0, ALLIANCE_CODES[name]] = plat.tilt
        f.steps[0] = w.steps
        f.time_s[0] = f.prev_time[0] = w.time_s

    def step(self, commands: list[DriveCommand]) -> None:
        self.w.step(commands)
        row = np.array([[c.linear for c in commands]]), np.array([[c.angular for c in commands]])
        intake = np.array([[c.intake for c in commands]])
        clamp = np.array([[-1 if c.clamp is None else int(c.clamp) for c in commands]])
        self.f.step(*row, intake, clamp)

    def agree(self, pos_m: float = 0.02, tilt_rad: float = 0.01) -> None:
        """Both worlds in the same state: poses and goals within pos_m, the same holders,
        boards, rings and fouls, tilts within tilt_rad, the same score."""
        w, f = self.w, self.f
        for r in w.robots:
            i = r.index
            assert np.hypot(r.x - f.x[0, i], r.y - f.y[0, i]) < pos_m, (i, r.x, r.y, f.x, f.y)
            turned = (r.heading - f.heading[0, i] + 180.0) % 360.0 - 180.0
            assert abs(turned) < 2.0, (i, r.heading, f.heading[0, i])
            code = -1 if r.on_platform is None else ALLIANCE_CODES[r.on_platform]
            assert f.on_platform[0, i] == code
            assert f.carried[0, i] == (-1 if r.carried_goal is None else r.carried_goal)
        for g in w.goals:
            k = g.index
            assert np.hypot(g.x - f.gx[0, k], g.y - f.gy[0, k]) < pos_m, g.spec.name
            assert f.carrier[0, k] == (-1 if g.carried_by is None else g.carried_by)
            assert f.contester[0, k] == (-1 if g.contested_by is None else g.contested_by)
            assert (f.goal_rings[0, k], f.rings_high[0, k], f.rings_base[0, k]) == (
                g.rings,
                g.rings_high,
                g.rings_base,
            )
        for name, plat in w.platforms.items():
            assert abs(f.tilt[0, ALLIANCE_CODES[name]] - plat.tilt) < tilt_rad, name
        fouls = np.zeros((2, 3), dtype=np.int64)
        for foul in w.fouls:
            fouls[ALLIANCE_CODES[foul.alliance], FOUL_KINDS.index(foul.kind)] += 1
        assert (f.fouls[0] == fouls).all()
        rows = f.game_score()[0] if f.game else None
        for code, a in enumerate(rules.ALLIANCES):
            s = w.score()[a]
            if rows is None:
                assert f.totals()[code][0] == s.total
                continue
            want = [int(getattr(s, name)) for name in SCORE_FIELDS]
            assert rows[code].tolist() == want, (a, rows[code], s)


@pytest.fixture
def solo() -> Iterator[Twin]:
    """Red's 15" robot alone on a clear field, in front of its platform, facing the wall."""
    twin = Twin(world_preset("tipping_point_1v1", red=("15in",), blue=(), preloads=False))
    twin.clear()
    twin.w.place_robot(0, -0.8, 0.0, 270.0)
    twin.sync()
    yield twin
    twin.close()


@pytest.fixture
def duel() -> Iterator[Twin]:
    twin = Twin(world_preset("tipping_point_1v1", preloads=False))
    twin.clear()
    yield twin
    twin.close()


HINGE_X = -60 * 0.0254


@pytest.mark.parametrize("target", [HINGE_X, HINGE_X - 0.2])
def test_a_robot_climbs_the_see_saw_as_in_the_twin(solo: Twin, target: float) -> None:
    """Up the lowered ramp and to the hinge (the board levels, the robot is Elevated), or past
    it (the board tips toward the wall): each world's robot driven by its own position."""
    for _ in range(72):
        err = solo.w.robots[0].x - target
        solo.step([DriveCommand(max(-0.4, min(0.4, 1.5 * err)), 0.0, intake=False)])
        solo.agree(pos_m=0.03, tilt_rad=0.05)
    tilt = solo.f.tilt[0, 0]
    assert solo.f.on_platform[0, 0] == 0
    if target == HINGE_X:
        assert abs(tilt) < np.radians(3.0) and solo.f.game_score()[0, 0, 3] == 1
    else:
        assert tilt < -0.1


def contested(t: Twin) -> int:
    gi = t.goal("neutral_tall")
    t.w.place_goal(gi, 0.0, 0.0)
    t.back_onto(0, gi, heading=0.0)
    t.step([IDLE, IDLE])
    t.back_onto(1, gi, heading=180.0)
    t.sync()
    t.step([IDLE, IDLE])
    assert t.w.goals[gi].holders == (0, 1)
    t.agree()
    return gi


@pytest.mark.parametrize(("red_v", "blue_v"), [(0.45, 0.9), (0.6, 0.6), (0.0, 0.0), (0.9, 0.3)])
def test_a_tug_of_war_goes_as_in_the_twin(duel: Twin, red_v: float, blue_v: float) -> None:
    gi = contested(duel)
    for _ in range(24):
        duel.step([DriveCommand(red_v, 0.0, intake=False), DriveCommand(blue_v, 0.0, intake=False)])
        duel.agree()
    if red_v != blue_v:  # the stronger pull has the goal, the other is dragged along
        win = 0 if red_v > blue_v else 1
        assert duel.f.carrier[0, gi] == win and duel.f.contester[0, gi] == 1 - win
    # One lets go: the other keeps the goal alone.
    duel.step([DriveCommand(0.9, intake=False), DriveCommand(0.0, intake=False, clamp=False)])
    duel.agree()
    assert duel.f.carrier[0, gi] == 0 and duel.f.contester[0, gi] == -1


@pytest.mark.parametrize("blue_v", [0.0, 0.9])
def test_turning_in_a_tug_of_war_goes_as_in_the_twin(duel: Twin, blue_v: float) -> None:
    """Red turns: with blue idle, red swings the goal and blue with it; with blue pulling, red
    is dragged and does not turn by itself."""
    contested(duel)
    for _ in range(12):
        duel.step([DriveCommand(0.0, 1.0, intake=False), DriveCommand(blue_v, intake=False)])
        duel.agree(pos_m=0.03)


def test_a_goal_is_stolen_out_of_its_home_zone_as_in_the_twin(duel: Twin) -> None:
    gi = duel.goal("red_north")
    zone = duel.w.field.home_zones["red"]
    duel.w.place_goal(gi, zone.x1 - 0.3, 0.6)
    duel.back_onto(1, gi, heading=90.0)
    duel.w.place_robot(0, -1.2, -0.9, 0.0)
    duel.sync()
    before = duel.f.game_score()[0, 0, 1]
    duel.step([IDLE, IDLE])
    for _ in range(24):
        duel.step([IDLE, DriveCommand(0.5, 0.0, intake=False)])
        duel.agree()
    assert duel.f.game_score()[0, 0, 1] == before - 1


@pytest.mark.parametrize(("robot", "goal", "n", "expected"), RING_PLACEMENTS)
def test_rings_land_where_the_mechanism_puts_them(
    robot: str, goal: str, n: int, expected: tuple[int, int, int]
) -> None:
    mech = {"base": replace(ROBOTS["15in"], loads="base")}
    name = "15in" if robot == "base" else robot
    robots = dict(ROBOTS, **({name: mech[robot]} if robot in mech else {}))
    cfg = world_preset("tipping_point_1v1", red=(name,), blue=(), preloads=False, robots=robots)
    t = Twin(cfg)
    try:
        gi = t.goal(goal)
        t.clear()
        t.w.set_floor_rings(np.array([[1.5, -1.5 + 0.1 * k] for k in range(n)]))
        t.w.place_goal(gi, -0.3, 0.0)
        t.back_onto(0, gi)
        t.sync()
        t.step([IDLE])
        held = np.flatnonzero(t.w.ring_state == RING_FLOOR)[:n]
        t.w.ring_state[held] = RING_HELD
        t.w.ring_owner[held] = 0
        t.w.robots[0].held += n
        t.f.held[0, 0] += n
        t.f.ring_floor[0, :n] = False
        for _ in range(round(n * t.w.robots[0].config.ring_transfer_s / t.w.dt) + 2):
            t.step([IDLE])
            t.agree()
        high, base = t.f.rings_high[0, gi], t.f.rings_base[0, gi]
        assert (high, t.f.goal_rings[0, gi] - high - base, base) == expected
    finally:
        t.close()


def test_isolation_contact_is_a_foul_that_forfeits_the_autonomous_period() -> None:
    t = Twin(world_preset("tipping_point_2v2", preloads=False, interaction_s=40.0))
    try:
        t.clear()
        t.w.place_robot(0, -1.2, -0.9, 90.0)
        t.w.place_robot(2, 1.2, -0.9, 270.0)
        t.w.place_robot(1, -0.4, 0.0, 90.0)
        t.w.place_robot(3, 0.1, 0.0, 90.0)
        t.sync()
        commands = [IDLE] * 4
        commands[1] = DriveCommand(0.5, intake=False)
        while t.w.time_s < t.w.isolation_s - 1e-9:  # 15 s of pushing blue into the wall
            t.step(commands)
            t.agree(pos_m=0.03)
        assert t.f.fouls[0, 0, 0] == 1 and t.f.fouls[0].sum() == 1
        assert t.f.auto_bonus[0].tolist() == [0, 20] and t.f.auto_win_point[0].tolist() == [0, 1]
    finally:
        t.close()


def test_the_platform_is_protected_in_the_endgame() -> None:
    """Blue's robot touches red's platform in the last endgame_s seconds: a foul, and red is
    credited an Elevated robot."""
    t = Twin(world_preset("tipping_point_1v1", preloads=False, isolation_s=0.0, interaction_s=35.0))
    try:
        t.clear()
        plat = t.w.field.platform("red")
        t.w.place_robot(0, 0.0, -0.5, 0.0)
        t.w.place_robot(1, plat.center[0] + plat.size[0] / 2 + 0.6, 0.9, 270.0)
        t.sync()
        for _ in range(round(8.0 / t.w.dt)):
            t.step([IDLE, DriveCommand(0.3, 0.0, intake=False)])
            t.agree(pos_m=0.03)
        assert t.f.fouls[0, 1, 2] == 1 and t.f.game_score()[0, 0, 10] == 1
    finally:
        t.close()


def test_the_isolation_barrier_stops_robots_at_the_centre_line() -> None:
    cfg = WorldConfig(isolation_s=5.0, interaction_s=5.0, blue=())
    t = Twin(cfg)
    try:
        t.w.set_floor_rings(np.zeros((0, 2)))
        t.w.place_robot(0, -0.5, 0.0, 90.0)
        t.sync()
        for _ in range(round(4.0 / t.w.dt)):
            t.step([DriveCommand(0.5, 0.0, intake=False)])
            t.agree(pos_m=0.02)
        assert t.f.x[0, 0] < 0 and abs(t.f.x[0, 0] + 0.01 + t.f.half_l[0]) < 0.02
        for _ in range(round(2.0 / t.w.dt)):  # the interaction period: the wall is gone
            t.step([DriveCommand(0.5, 0.0, intake=False)])
        assert t.f.x[0, 0] > 0.2
    finally:
        t.close()


def test_a_whole_game_match_runs_every_rule_in_every_match_at_once() -> None:
    """The 2v2 preset, random drives in 32 matches to the end: every match ends, its score is
    the rules' (rows of SCORE_FIELDS), the isolation period is judged in every match, and the
    whole-game state stays consistent (holders hold their goals, rings add up)."""
    f = FastWorld(world_preset("tipping_point_2v2"), 32)
    f.reset(range(32))
    rng = np.random.default_rng(0)
    judged = np.zeros(32, dtype=bool)
    while not f.over.all():
        ev = f.step(rng.uniform(-0.3, 1.0, (32, 4)), rng.uniform(-2, 2, (32, 4)))
        judged |= ev.phase_changed
        for i in range(4):
            g = f.carried[:, i]
            held = g >= 0
            rows = np.flatnonzero(held)
            holders = np.stack([f.carrier[rows, g[rows]], f.contester[rows, g[rows]]], -1)
            assert (holders == i).any(axis=1).all()
        assert (f.rings_high + f.rings_base <= f.goal_rings).all()
    # The bonus: 20 to one alliance or 10 each, none when both forfeited it by a foul.
    both_forfeit = (f.fouls[:, :, :2].sum(axis=2) > 0).all(axis=1)
    assert judged.all()
    assert (f.auto_bonus.sum(axis=1) == np.where(both_forfeit, 0, 20)).all()
    rows = f.game_score()
    assert (rows[:, :, 7] == f.auto_bonus).all() and (rows[:, :, 4] > 0).any()


def test_training_matches_of_the_whole_game_score_as_the_twin_does() -> None:
    """FastMatches on the whole game (tipping_point_1v1's world, matches cut at 20 s, past the
    isolation period), both robots idle: each match's score is the twin's for the same start,
    the autonomous period's tie bonus included."""
    env = make_config({"world": WORLD_PRESETS["tipping_point_1v1"], "max_steps": 240})
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=3), seed=3)
    fm.set_kinds([("idle", -1)] * 3)
    fm.reset()
    episodes = []
    for _ in range(240):
        episodes += fm.step(np.zeros((3, 2), np.float32), np.zeros((3, 2), np.float32)).episodes
    assert sorted(ep.slot for ep in episodes) == [0, 1, 2]
    for ep in episodes:
        with World(env.world) as w:
            w.reset(np.random.default_rng((3, ep.slot, 0)))
            for _ in range(240):
                w.step([DriveCommand(intake=False)] * 2)
            mine = rules.ALLIANCES[int(fm.learner[ep.slot])]
            s = w.score()
            assert w.autonomous is not None and s[mine].autonomous_bonus == 10
            assert (ep.score, ep.opponent_score) == (s[mine].total, s[rules.other(mine)].total)


def test_the_trainer_plays_the_whole_game_on_the_fast_backend(tmp_path: Path) -> None:
    """`pete-sim train --backend fast` on the whole game (tipping_point_1v1's world): matches
    through the isolation period into the interaction period, and their scores are the whole
    game's (the autonomous bonus is paid once the period is judged)."""
    cfg = replace(
        load_config("tiny"),
        backend="fast",
        fast=FastConfig(envs=8, steps_per_env=64),
        total_steps=2048,
        checkpoint_steps=2048,
    )
    world = {**cfg.env["world"], **WORLD_PRESETS["tipping_point_1v1"]}
    observation = {**cfg.env["observation"], "match_length_s": 120.0}  # isolation + interaction
    cfg = replace(
        cfg, env={**cfg.env, "world": world, "observation": observation, "max_steps": 200}
    )
    cfg.on_backend()  # the fast backend runs it (else a ConfigError names what it cannot)
    result = train(cfg, tmp_path / "run", progress=False, export=False)
    assert result.steps == 2048 and result.episodes >= 8
    assert result.history[-1]["charts/steps_per_s"] > 0


def test_a_carried_goal_cannot_be_placed_by_hand() -> None:
    """As World.place_goal: a goal in a clamp is released first (a clear error, nothing moved)."""
    f = FastWorld(world_preset("tipping_point_1v1", preloads=False), 1)
    f.reset([0])
    f.carrier[0, 2], f.carried[0, 0] = 0, 2
    before = (f.gx[0, 2], f.gy[0, 2])
    with pytest.raises(WorldError, match="carried; release it first"):
        f.place_goal(0, 2, 0.0, 0.0)
    assert (f.gx[0, 2], f.gy[0, 2]) == before
