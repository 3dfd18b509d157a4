"""The scripted alliance in the twin (sim/baselines/alliance.py hosts jetson/autonomy/alliance.py):
its field layout agrees with the twin's field file, its isolation routine scores without touching
the other alliance, its endgame elevates both robots and a goal on a balanced platform, and it
reads no World truth beyond its sensors."""

from __future__ import annotations

import numpy as np
import pytest

from jetson.autonomy.alliance import GOAL_COLOUR_CODES
from jetson.autonomy.field_layout import load_layout
from jetson.autonomy.geometry import field_to_robot
from sim.baselines.alliance import AlliancePlayer, ring_race_player, robot_role
from sim.baselines.planner import Planner
from sim.config import world_preset
from sim.field import load_field
from sim.goal_sight import goal_colour, visible_goals
from sim.match import EnvConfig, MatchCore
from sim.players import IdlePlayer, Player
from sim.world import rules, seesaw
from sim.world.state import DriveCommand, GoalState


def test_the_robot_side_layout_agrees_with_the_field_file() -> None:
    """jetson/autonomy/data/tipping_point.json is the field file as red sees it (the alliance
    frame), in metres: the same rings, goals, platform, zones, starts and periods."""
    layout, f = load_layout(), load_field()
    assert layout.half_m == pytest.approx(f.half, abs=1e-4)
    assert np.allclose(np.array(layout.rings), f.ring_positions, atol=1e-4)
    owner = {"red": "own", "blue": "opponent", None: None}
    assert len(layout.goals) == len(f.goals)
    for g, spec in zip(layout.goals, f.goals, strict=True):
        assert (g.name, g.kind, g.owner) == (spec.name, spec.kind, owner[spec.alliance])
        assert g.xy == pytest.approx(spec.position, abs=1e-4)
        assert g.base_radius_m == pytest.approx(spec.base_radius, abs=1e-4)
        assert g.mass_kg == pytest.approx(spec.mass_kg, abs=1e-4)
        assert g.high_branch_capacity == spec.high_branch_capacity
    plat, red = layout.platform, f.platform("red")
    assert plat.center == pytest.approx(red.center, abs=1e-4)
    assert plat.size == pytest.approx(red.size, abs=1e-4)
    assert plat.height_m == pytest.approx(red.height, abs=1e-4)
    ss = f.seesaw
    assert (plat.board_mass_kg, plat.balanced_tilt_deg) == pytest.approx(
        (ss.board_mass_kg, ss.balanced_tilt_deg)
    )
    assert (plat.hinge_flat_m, plat.climb_edge_m, plat.overhang_m) == pytest.approx(
        (ss.hinge_flat, ss.climb_edge, ss.overhang), abs=1e-4
    )
    z = f.home_zones["red"]
    assert layout.home_zone == pytest.approx((z.x0, z.y0, z.x1, z.y1), abs=1e-4)
    assert layout.awp_line == pytest.approx(f.awp_lines["red"], abs=1e-4)
    assert layout.awp_goal == f.goals[f.awp_goals["red"]].name
    for s in f.starts:
        if s.alliance == "red":
            assert layout.starts[s.robot].xy == pytest.approx(s.position, abs=1e-4)
            assert layout.starts[s.robot].heading_deg == pytest.approx(s.heading)
    assert (layout.isolation_s, layout.interaction_s, layout.endgame_s) == pytest.approx(
        (f.rules.autonomous_s, f.rules.interaction_s, f.rules.endgame_s)
    )


def core_2v2(**world: object) -> MatchCore:
    return MatchCore(EnvConfig(world=world_preset("tipping_point_2v2", **world), obs_noise=False))


def test_the_roles_come_from_the_robot_configs() -> None:
    core = core_2v2()
    try:
        core.reset(np.random.default_rng(0))
        big, small = robot_role(core.world, 0), robot_role(core.world, 1)
        assert (big.role, small.role) == ("24in", "15in")
        assert big.reaches_high_branch and not small.reaches_high_branch
        assert big.partner_mass_kg == small.mass_kg and small.partner_mass_kg == big.mass_kg
        assert isinstance(ring_race_player("24in"), Planner)
        assert ring_race_player("15in").name == "scripted"
    finally:
        core.close()


def run(core: MatchCore, players: list[Player], seconds: float) -> list[DriveCommand]:
    """Step the core's world for `seconds`; the commands of the last step."""
    w = core.world
    commands: list[DriveCommand] = []
    for _ in range(round(seconds / w.dt)):
        commands = [p.act(core, i, None) for i, p in enumerate(players)]
        w.step(commands)
    return commands


def _isolation(seed: int, blue: str) -> tuple[MatchCore, list[tuple[float, float, bool]]]:
    """The isolation period of a 2v2 match, the scripted alliance red against `blue` ("idle":
    standing in its starting places; "ring_race": the ring-race alliance). Per step: the red
    robots' farthest reach toward blue's half (x, field frame; red's half is x < 0), and whether
    a blue robot's centre was in red's half."""
    core = core_2v2()
    core.reset(np.random.default_rng(seed))
    w = core.world
    players: list[Player] = [
        AlliancePlayer()
        if r.alliance == "red"
        else (IdlePlayer() if blue == "idle" else ring_race_player(r.config.name))
        for r in w.robots
    ]
    for i, p in enumerate(players):
        p.reset(core, i, np.random.default_rng(i))
    trace = []
    while w.time_s < w.isolation_s + 0.1:
        run(core, players, w.dt)
        reach = max(seesaw.robot_box(r)[2] for r in w.robots if r.alliance == "red")
        intruder = any(r.x < 0 for r in w.robots if r.alliance == "blue")
        trace.append((w.time_s, reach, intruder))
    return core, trace


def test_the_isolation_routine_scores_and_touches_nobody() -> None:
    """With the other alliance at home: the scripted alliance commits no isolation foul and
    threads the 15"'s preloads onto an alliance goal; its isolation score counts both alliance
    goals in its zone and those rings."""
    for seed in (0, 1):
        core, _ = _isolation(seed, "idle")
        try:
            w = core.world
            red = [f for f in w.fouls if f.alliance == "red"]
            assert red == [], red
            own = [g for g in w.goals if g.spec.alliance == "red"]
            assert sum(g.rings for g in own) >= 3  # the 15"'s preloads
            assert w.autonomous is not None and w.autonomous["red"].score >= 40 + 9
        finally:
            core.close()


def test_in_isolation_the_alliance_stays_home_and_touches_only_intruders() -> None:
    """Against the ring-race alliance, which drives into the scripted robots' half: the scripted
    robots never reach past the centre line, and any contact charged to them is with a robot
    of the other alliance inside their own half (they see no robots yet: issue 46's detector).
    Seeds 0 and 9 are such contacts (the intruder drags its goal across red's lane)."""
    for seed in (0, 1, 9):
        core, trace = _isolation(seed, "ring_race")
        try:
            w = core.world
            assert max(reach for _, reach, _ in trace) < 0.0, "a red robot crossed the line"
            by_time = {round(t, 6): intruder for t, _, intruder in trace}
            for f in w.fouls:
                if f.alliance == "red":
                    assert f.kind == "isolation_contact" and by_time[round(f.time_s, 6)], f
            own = [g for g in w.goals if g.spec.alliance == "red"]
            assert sum(g.rings for g in own) >= 3  # the 15"'s preloads
        finally:
            core.close()


def test_the_endgame_elevates_both_robots_and_a_goal_on_a_balanced_platform() -> None:
    """Set up 26 s before the end: the 24" holds a neutral goal, the 15" its alliance goal, both
    in the field; no opponents. They climb one after the other (the 24" holds the board's
    field edge down while the 15" climbs) and balance it with both goals: 30 + 30 + 40 + 40."""
    core = core_2v2(blue=())
    try:
        core.reset(np.random.default_rng(0))
        w = core.world
        w.set_floor_rings(np.zeros((0, 2)))
        big, small = w.robots
        neutral = next(g for g in w.goals if g.spec.name == "neutral_south")
        own = next(g for g in w.goals if g.spec.name == "red_north")
        for r, g, (x, y) in ((big, neutral, (-0.3, -0.6)), (small, own, (-0.4, 0.9))):
            w.place_robot(r.index, x, y, 270.0)  # facing the wall, the goal behind
            gx, gy = w.clamp_point(r, g)
            w.place_goal(g.index, gx, gy)
        w.step([DriveCommand(0.0, 0.0, False, True)] * 2)
        assert big.carried_goal == neutral.index and small.carried_goal == own.index
        players = [AlliancePlayer(), AlliancePlayer()]
        for i, p in enumerate(players):
            p.reset(core, i)
        # Jump the clock to 26 s before the end (the strategies see the match time).
        w.steps = round((w.match_length_s - 26.0) / w.dt)
        w.time_s = w.steps * w.dt
        while not w.over:
            w.step([p.act(core, i, None) for i, p in enumerate(players)])
        s = w.score()["red"]
        assert s.balanced, [(r.x, r.y, r.on_platform) for r in w.robots]
        assert s.robots_elevated == 2 and s.goals_elevated == 2
        assert all(rules.robot_elevated(w, r) for r in w.robots)
    finally:
        core.close()


def test_it_reads_no_world_truth_beyond_its_sensors() -> None:
    """Two worlds from one seed, the second with the other alliance's robots and goals moved
    where the scripted 15" cannot see or touch them: its commands are the same, step for step,
    through its isolation routine (the strategy sees only its GPS, its camera's rings, its
    intake, its clamp and the clock)."""
    logs = []
    for perturbed in (False, True):
        core = core_2v2()
        try:
            core.reset(np.random.default_rng(7))
            w = core.world
            if perturbed:
                for r in w.robots:
                    if r.alliance == "blue":
                        w.place_robot(r.index, 1.5 - 0.3 * r.slot, -1.0 + 2.0 * r.slot, 0.0)
                for g in w.goals:
                    if g.spec.alliance == "blue":
                        w.place_goal(g.index, g.x, -g.y)
            players: list[Player] = [
                AlliancePlayer() if r.alliance == "red" else IdlePlayer() for r in w.robots
            ]
            for i, p in enumerate(players):
                p.reset(core, i, np.random.default_rng(i))
            log = []
            for _ in range(round(6.0 / w.dt)):
                commands = [p.act(core, i, None) for i, p in enumerate(players)]
                log.append((commands[1].linear, commands[1].angular, commands[1].clamp))
                w.step(commands)
            logs.append(log)
        finally:
            core.close()
    assert logs[0] == logs[1]
    assert any(v != 0.0 for v, _, _ in logs[0])  # it did drive


@pytest.mark.parametrize("fidelity", ["training", "high"])
def test_the_camera_reports_the_goals_in_front_with_their_colours(fidelity: str) -> None:
    """sim/goal_sight.py, what the robot's goal detector reports: a red robot facing the neutral
    south goal sees it, yellow, where it stands in the robot frame; turned to its wall it sees
    no neutral goal; a robot standing in the way hides it (both fidelities)."""
    core = core_2v2(fidelity=fidelity)
    try:
        core.reset(np.random.default_rng(0))
        w = core.world
        south = next(g for g in w.goals if g.spec.name == "neutral_south")
        w.place_robot(0, south.x - 1.0, south.y, 90.0)
        seen = visible_goals(w, 0)
        want = field_to_robot(np.array([[south.x, south.y]]), (w.robots[0].x, w.robots[0].y), 90.0)
        hit = [row for row in seen if np.hypot(*(row[:2] - want[0])) < 0.02]
        assert len(hit) == 1 and hit[0][2] == GOAL_COLOUR_CODES["yellow"]
        blue = [g for g in w.goals if g.spec.alliance == "blue"]
        assert {goal_colour(g.spec.alliance) for g in blue} == {GOAL_COLOUR_CODES["blue"]}
        w.place_robot(0, south.x - 1.0, south.y, 270.0)
        assert not any(row[2] == GOAL_COLOUR_CODES["yellow"] for row in visible_goals(w, 0))
        # Another robot between the camera and the goal hides it.
        w.place_robot(0, south.x - 1.2, south.y, 90.0)
        w.place_robot(1, south.x - 0.6, south.y, 0.0)
        seen = visible_goals(w, 0)
        want = field_to_robot(np.array([[south.x, south.y]]), (w.robots[0].x, w.robots[0].y), 90.0)
        assert not any(np.hypot(*(row[:2] - want[0])) < 0.02 for row in seen)
    finally:
        core.close()


def test_the_strategy_gets_the_sightings_the_daemon_passes_on() -> None:
    """inputs_from_view hands the strategy what the daemon's scripted decider would: a red goal
    base on the red platform is dropped (a piece of a platform can look like one), a neutral
    goal pushed up the same board is kept (no platform is yellow), and a goal off the platforms
    is kept whatever its colour."""
    from sim.baselines.alliance import inputs_from_view

    core = core_2v2(fidelity="training")
    try:
        core.reset(np.random.default_rng(0))
        w = core.world
        layout = load_layout()
        plat = layout.platform  # red's, the field frame is red's alliance frame
        north = next(g for g in w.goals if g.spec.name == "neutral_north")
        red = next(g for g in w.goals if g.spec.name == "red_south")
        blue = next(g for g in w.goals if g.spec.name == "blue_south")
        w.place_goal(north.index, plat.x_at(-0.14), -0.25)
        w.place_goal(red.index, plat.x_at(-0.14), 0.3)
        w.place_goal(blue.index, plat.x_at(0.6), -0.5)  # off the board, in view
        w.place_robot(0, plat.x_at(2.0), 0.0, plat.wall_heading_deg)
        for _ in range(12):  # the GPS's reading catches up with the placed robot
            w.step([DriveCommand(0.0, 0.0, False) for _ in w.robots])
        r = w.robots[0]

        def seen_at(rows: np.ndarray, g: GoalState) -> bool:
            want = field_to_robot(np.array([[g.x, g.y]]), (r.x, r.y), r.heading)[0]
            return any(np.hypot(*(row[:2] - want)) < 0.05 for row in rows)

        raw = visible_goals(w, 0)
        assert seen_at(raw, north) and seen_at(raw, red) and seen_at(raw, blue)
        kept = inputs_from_view(core, 0, True, plat).goals_robot
        assert kept is not None
        assert seen_at(kept, north) and seen_at(kept, blue)
        assert not seen_at(kept, red)
        assert inputs_from_view(core, 0, False, plat).goals_robot is None
    finally:
        core.close()
