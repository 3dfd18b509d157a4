"""Goals in the whole game: clamped and released, stolen and moved out of a home zone, fought over
by robots of both alliances (the tug-of-war model), and rings placed by each robot's mechanism."""

from __future__ import annotations

import math
from collections.abc import Iterator
from dataclasses import replace

import numpy as np
import pytest

from sim.config import ROBOTS, world_preset
from sim.world import rules, seesaw
from sim.world.physics import World
from sim.world.state import DriveCommand

IDLE = DriveCommand(intake=False)
# Apart, in the neutral zone, away from the middle where the tests work.
SPOTS = [(0.0, 1.3), (0.4, 1.3), (-0.4, 1.3), (0.0, -1.3), (0.4, -1.3), (-0.4, -1.3), (0.4, -0.9)]


def clear(w: World) -> None:
    w.set_floor_rings(np.zeros((0, 2)))
    for g, (x, y) in zip(w.goals, SPOTS, strict=True):
        w.place_goal(g.index, x, y)


def back_onto(w: World, robot: int, goal: int, heading: float = 0.0) -> None:
    """Place a robot so the goal sits just behind its back (heading 0: the robot faces north,
    the goal south of it)."""
    r, g = w.robots[robot], w.goals[goal]
    gap = g.spec.base_radius + r.config.length_m / 2 + 0.03
    v = {0.0: (0.0, 1.0), 90.0: (1.0, 0.0), 180.0: (0.0, -1.0), 270.0: (-1.0, 0.0)}[heading]
    w.place_robot(robot, g.x + gap * v[0], g.y + gap * v[1], heading)


@pytest.fixture(params=["training", "high"])
def duel(request: pytest.FixtureRequest) -> Iterator[World]:
    cfg = replace(world_preset("tipping_point_1v1", preloads=False), fidelity=request.param)
    with World(cfg) as w:
        w.reset()
        clear(w)
        yield w


def test_clamp_false_releases_and_the_goal_stays(duel: World) -> None:
    gi = next(g.index for g in duel.goals if g.spec.name == "neutral_tall")
    duel.place_goal(gi, -0.3, 0.0)
    back_onto(duel, 0, gi)
    duel.place_robot(1, 1.2, 0.8, 270.0)
    duel.step([IDLE, IDLE])
    g, r = duel.goals[gi], duel.robots[0]
    assert g.carried_by == 0 and r.carried_goal == gi
    for _ in range(12):
        duel.step([DriveCommand(0.3, 0.0, intake=False), IDLE])
    assert g.y > 0.2  # it came along
    for _ in range(3):  # stop, then let go (a goal let go on the move slides on)
        duel.step([IDLE, IDLE])
    duel.step([DriveCommand(0.0, 0.0, intake=False, clamp=False), IDLE])
    assert g.carried_by is None and r.carried_goal is None
    left = (g.x, g.y)
    for _ in range(12):
        duel.step([DriveCommand(0.3, 0.0, intake=False, clamp=False), IDLE])
    assert np.hypot(g.x - left[0], g.y - left[1]) < 0.05
    assert r.y - g.y > 0.5


def test_a_goal_is_stolen_out_of_its_home_zone(duel: World) -> None:
    """Blue clamps a red goal in red's home zone and drags it out: red loses its 20 points."""
    gi = next(g.index for g in duel.goals if g.spec.name == "red_north")
    zone = duel.field.home_zones["red"]
    duel.place_goal(gi, zone.x1 - 0.3, 0.6)
    assert rules.goal_owner(duel, duel.goals[gi]) == ("red", False)
    back_onto(duel, 1, gi, heading=90.0)  # blue's robot east of it, facing east
    duel.place_robot(0, -1.2, -0.9, 0.0)
    before = duel.score()["red"].goals_in_zone
    duel.step([IDLE, IDLE])
    assert duel.goals[gi].carried_by == 1
    for _ in range(24):
        duel.step([IDLE, DriveCommand(0.5, 0.0, intake=False)])
    assert rules.goal_owner(duel, duel.goals[gi]) == (None, False)
    assert duel.score()["red"].goals_in_zone == before - 1


def tug(w: World, red_v: float, blue_v: float, steps: int = 24) -> None:
    for _ in range(steps):
        w.step([DriveCommand(red_v, 0.0, intake=False), DriveCommand(blue_v, 0.0, intake=False)])


def contested(w: World, x: float = 0.0) -> int:
    gi = next(g.index for g in w.goals if g.spec.name == "neutral_tall")
    w.place_goal(gi, x, 0.0)
    back_onto(w, 0, gi, heading=0.0)  # red north of it, facing north
    w.step([IDLE, IDLE])
    back_onto(w, 1, gi, heading=180.0)  # blue south of it, facing south
    w.step([IDLE, IDLE])
    g = w.goals[gi]
    assert g.holders == (0, 1)
    return gi


def test_tug_of_war_the_stronger_pull_wins(duel: World) -> None:
    """Both 24" robots pull; blue pulls at full power, red at half: blue drags red and the goal
    south, slower than it drives alone."""
    gi = contested(duel)
    g, red = duel.goals[gi], duel.robots[0]
    y0 = g.y
    tug(duel, 0.45, 0.9)
    assert g.y < y0 - 0.2
    assert g.carried_by == 1 and g.contested_by == 0
    assert red.carried_goal == gi  # still holding on, dragged backwards
    assert red.y - g.y == pytest.approx(duel.clamp_offset(red, g), abs=0.02)
    assert y0 - g.y < 0.5 * 0.9 * 2.0  # (0.9 - 0.45) / (0.9 + 0.45) of its speed: a third


def test_tug_of_war_equal_pulls_hold_still(duel: World) -> None:
    gi = contested(duel)
    g = duel.goals[gi]
    y0 = g.y
    tug(duel, 0.6, 0.6)
    assert abs(g.y - y0) < 0.03


def test_tug_of_war_the_24in_outpulls_the_15in() -> None:
    cfg = world_preset("tipping_point_1v1", blue=("15in",), preloads=False)
    with World(cfg) as w:
        w.reset()
        clear(w)
        gi = contested(w)
        g = w.goals[gi]
        y0 = g.y
        tug(w, 0.9, 0.9)
        assert g.y > y0 + 0.2 and g.carried_by == 0
        # Blue lets go: red keeps the goal alone.
        w.step([DriveCommand(0.9, intake=False), DriveCommand(0.0, intake=False, clamp=False)])
        assert g.holders == (0,) and w.robots[1].carried_goal is None


def test_robots_of_one_alliance_do_not_share_a_goal() -> None:
    with World(world_preset("tipping_point_2v2", preloads=False)) as w:
        w.reset()
        clear(w)
        gi = next(g.index for g in w.goals if g.spec.name == "neutral_tall")
        w.place_goal(gi, 0.0, 0.0)
        back_onto(w, 1, gi, heading=0.0)
        w.step([IDLE] * 4)
        back_onto(w, 0, gi, heading=180.0)
        w.step([IDLE] * 4)
        assert w.goals[gi].holders == (1,)


def load_rings(w: World, robot: int, goal: int, n: int) -> None:
    """Clamp the goal and let the robot's conveyor move n held rings onto it."""
    r = w.robots[robot]
    back_onto(w, robot, goal)
    w.step([IDLE] * len(w.robots))
    assert r.carried_goal == goal
    held = np.flatnonzero(w.ring_state == 0)[:n]
    w.ring_state[held] = 1
    w.ring_owner[held] = robot
    r.held += n
    for _ in range(round(n * r.config.ring_transfer_s / w.dt) + 2):
        w.step([IDLE] * len(w.robots))
    assert r.held == 0


# (robot, goal, rings, (high, low, base)): where each mechanism puts its rings (also played on
# the batched world, tests/sim/fast/test_game.py).
RING_PLACEMENTS = [
    ("24in", "neutral_tall", 8, (6, 2, 0)),  # the lift fills the high branch first
    ("15in", "neutral_tall", 8, (0, 8, 0)),  # no lift: the low branches
    ("15in", "red_north", 14, (0, 12, 2)),  # an alliance goal's one branch, then the base
    ("base", "neutral_north", 3, (0, 0, 3)),  # an intake that drops rings in the base
]


@pytest.mark.parametrize(("robot", "goal", "n", "expected"), RING_PLACEMENTS)
def test_rings_land_where_the_mechanism_puts_them(
    robot: str, goal: str, n: int, expected: tuple[int, int, int]
) -> None:
    # A robot config is named by its size (the field's start poses); "base": a 15" whose intake
    # only drops rings in the base.
    mech = {"base": replace(ROBOTS["15in"], loads="base")}
    name = "15in" if robot == "base" else robot
    robots = dict(ROBOTS, **({name: mech[robot]} if robot in mech else {}))
    cfg = world_preset("tipping_point_1v1", red=(name,), blue=(), preloads=False, robots=robots)
    with World(cfg) as w:
        w.reset()
        gi = next(g.index for g in w.goals if g.spec.name == goal)
        clear(w)
        w.set_floor_rings(np.array([[1.5, -1.5 + 0.1 * k] for k in range(n)]))
        w.place_goal(gi, -0.3, 0.0)
        load_rings(w, 0, gi, n)
        g = w.goals[gi]
        assert (g.rings_high, g.rings_low, g.rings_base) == expected


def test_front_clamp_holds_the_goal_ahead() -> None:
    robots = dict(ROBOTS, **{"15in": replace(ROBOTS["15in"], clamp="front")})
    cfg = world_preset("tipping_point_1v1", red=("15in",), blue=(), robots=robots)
    with World(cfg) as w:
        w.reset()
        clear(w)
        w.place_goal(4, 0.0, 0.0)
        r = w.robots[0]
        w.place_robot(0, 0.0, -(w.goals[4].spec.base_radius + r.config.length_m / 2 + 0.03), 0.0)
        w.step([DriveCommand(0.2, 0.0, intake=False)])
        assert r.carried_goal == 4
        for _ in range(12):
            w.step([DriveCommand(0.3, 0.0, intake=False)])
        assert w.goals[4].y - r.y == pytest.approx(w.clamp_offset(r, w.goals[4]), abs=0.01)


def test_tug_of_war_the_loser_is_dragged_without_turning(duel: World) -> None:
    """Red pulls at full power; blue pulls at half and tries to turn in place: dragged by the goal
    it holds, it keeps its heading (its wheels slide; swinging about the goal would pass through
    red)."""
    gi = contested(duel)
    blue = duel.robots[1]
    h0 = blue.heading
    for _ in range(24):
        duel.step([DriveCommand(0.9, 0.0, intake=False), DriveCommand(0.45, 3.0, intake=False)])
    assert duel.goals[gi].carried_by == 0
    assert abs((blue.heading - h0 + 180.0) % 360.0 - 180.0) < 3.0
    # Let go, it turns again.
    for _ in range(6):
        duel.step([DriveCommand(0.9, 0.0, intake=False), DriveCommand(0.0, 3.0, clamp=False)])
    assert abs((blue.heading - h0 + 180.0) % 360.0 - 180.0) > 20.0


def test_tug_of_war_the_winner_turning_swings_the_loser_with_it(duel: World) -> None:
    """Red wins the pull and turns: blue, dragged, keeps its place relative to red (the two robots
    and the goal hold together), so it swings round with red instead of passing through it."""
    gi = contested(duel)
    red, blue = duel.robots[0], duel.robots[1]
    gap = math.hypot(blue.x - red.x, blue.y - red.y)
    r0, b0 = red.heading, blue.heading
    for _ in range(12):
        duel.step([DriveCommand(0.9, 1.5, intake=False), IDLE])
    assert duel.goals[gi].carried_by == 0
    turned = (red.heading - r0 + 180.0) % 360.0 - 180.0
    assert abs(turned) > 30.0
    assert abs((blue.heading - b0 - turned + 180.0) % 360.0 - 180.0) < 3.0
    assert math.hypot(blue.x - red.x, blue.y - red.y) == pytest.approx(gap, abs=0.05)


def test_tug_of_war_neither_pulling_the_one_that_turns_turns_all_three(duel: World) -> None:
    """Neither robot pulls and blue, which clamped second, turns in place: it turns, and red and
    the goal swing round with it."""
    gi = contested(duel)
    red, blue = duel.robots[0], duel.robots[1]
    gap = math.hypot(blue.x - red.x, blue.y - red.y)
    r0, b0 = red.heading, blue.heading
    for _ in range(8):
        duel.step([IDLE, DriveCommand(0.0, 1.5, intake=False)])
    turned = (blue.heading - b0 + 180.0) % 360.0 - 180.0
    assert abs(turned) > 20.0
    assert abs((red.heading - r0 - turned + 180.0) % 360.0 - 180.0) < 3.0
    assert math.hypot(blue.x - red.x, blue.y - red.y) == pytest.approx(gap, abs=0.05)
    assert duel.goals[gi].holders == (1, 0)


def test_tug_of_war_a_robot_swung_at_a_wall_stays_inside_the_field(duel: World) -> None:
    """The chain near the east wall, blue turning: red, swung toward the wall, is stopped by it
    (it pushes the whole chain back) instead of passing through it."""
    contested(duel, x=1.2)
    red, blue = duel.robots[0], duel.robots[1]
    lim = duel.field.half
    gap = math.hypot(blue.x - red.x, blue.y - red.y)
    widest = 0.0
    for _ in range(36):
        duel.step([IDLE, DriveCommand(0.0, blue.config.max_angular_rad_s, intake=False)])
        x0, y0, x1, y1 = seesaw.robot_box(red)
        assert -lim - 1e-6 <= x0 and x1 <= lim + 1e-6 and -lim - 1e-6 <= y0 and y1 <= lim + 1e-6
        widest = max(widest, x1)
        assert math.hypot(blue.x - red.x, blue.y - red.y) == pytest.approx(gap, abs=0.05)
    assert widest > lim - 0.02  # it did reach the wall
