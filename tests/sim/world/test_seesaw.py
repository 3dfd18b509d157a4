"""The platform as a see-saw (the whole game): the torque-balance model, climbing it over its
lowered field-side edge only, balancing one and two robots, and the hinged body that shows it."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest

from sim.config import world_preset
from sim.field import load_field
from sim.world import rules, seesaw
from sim.world.physics import World
from sim.world.state import DriveCommand, PlatformState

HINGE_X = -60 * 0.0254  # red's platform centre


@pytest.fixture(params=["training", "high"])
def solo(request: pytest.FixtureRequest) -> Iterator[World]:
    """Red's 15" robot alone on a clear field, in front of its platform, facing the wall."""
    cfg = world_preset("tipping_point_1v1", red=("15in",), blue=(), preloads=False)
    with World(cfg.__class__(**{**cfg.__dict__, "fidelity": request.param})) as w:
        w.reset()
        w.set_floor_rings(np.zeros((0, 2)))
        for g in w.goals:
            w.place_goal(g.index, g.x, 1.2 if g.y >= 0 else -1.2)
        w.place_robot(0, -0.8, 0.0, 270.0)
        yield w


def drive_to_x(w: World, x: float, seconds: float = 6.0) -> None:
    """Drive robot 0 straight (facing -x) until its centre is at x, then hold still."""
    r = w.robots[0]
    for _ in range(round(seconds / w.dt)):
        err = r.x - x  # positive: still east of the target, drive forward (west)
        w.step([DriveCommand(max(-0.4, min(0.4, 1.5 * err)), 0.0, intake=False)])


def test_one_robot_climbs_the_ramp_and_balances_at_the_hinge(solo: World) -> None:
    r = solo.robots[0]
    state = solo.platforms["red"]
    plat = solo.field.platform("red")
    assert state.tilt == pytest.approx(plat.max_tilt_rad)  # starts with the field edge down
    assert not rules.robot_elevated(solo, r)
    drive_to_x(solo, HINGE_X)
    assert r.on_platform == "red"
    assert abs(r.x - HINGE_X) < 0.05
    assert abs(state.tilt) <= math.radians(solo.field.seesaw.balanced_tilt_deg)
    assert rules.platform_balanced(solo, "red") and rules.robot_elevated(solo, r)
    assert solo.score()["red"].robots_elevated == 1
    if not solo.training:  # the hinged body follows the model
        assert solo.board_angle("red") == pytest.approx(state.tilt * plat.field_side)


def test_driving_past_the_hinge_tips_the_board_toward_the_wall(solo: World) -> None:
    drive_to_x(solo, HINGE_X - 0.2)
    state = solo.platforms["red"]
    plat = solo.field.platform("red")
    assert solo.robots[0].on_platform == "red"
    assert state.tilt == pytest.approx(-plat.max_tilt_rad)
    assert not rules.robot_elevated(solo, solo.robots[0])


def test_the_raised_edge_blocks_a_robot(solo: World) -> None:
    """With the field-side edge up (the board tipped toward the wall) the board is a step no
    robot drives over: it stops at the edge and stays off."""
    plat = solo.field.platform("red")
    solo.set_tilt("red", -plat.max_tilt_rad)
    drive_to_x(solo, HINGE_X, seconds=4.0)
    r = solo.robots[0]
    edge = plat.center[0] + plat.size[0] / 2
    assert r.on_platform is None
    assert r.x - r.config.length_m / 2 >= edge - 1e-6
    assert solo.platforms["red"].tilt == pytest.approx(-plat.max_tilt_rad)


def test_the_level_board_is_too_high_to_climb(solo: World) -> None:
    solo.set_tilt("red", 0.0)
    drive_to_x(solo, HINGE_X, seconds=4.0)
    assert solo.robots[0].on_platform is None


def test_no_robot_climbs_over_the_boards_end(solo: World) -> None:
    """Only the field-side edge is a ramp: driving at the board's end (along the wall) stops."""
    plat = solo.field.platform("red")
    end = plat.center[1] + plat.size[1] / 2
    solo.place_robot(0, HINGE_X, end + 0.5, 180.0)  # north of the board, facing south
    r = solo.robots[0]
    for _ in range(48):
        solo.step([DriveCommand(0.4, 0.0, intake=False)])
    assert r.on_platform is None
    assert r.y - r.config.length_m / 2 >= end - 1e-6


def _push_goal_at_the_board(w: World, tilt: float) -> tuple[float, float]:
    """Robot 0 pushes a goal straight at the red board tipped to `tilt`; the goal's x after."""
    plat = w.field.platform("red")
    w.set_tilt("red", tilt)
    g = w.goals[0]
    w.place_robot(0, -0.55, 0.0, 270.0)
    w.place_goal(0, -0.55 - w.robots[0].config.length_m / 2 - g.spec.base_radius - 0.03, 0.0)
    drive_to_x(w, HINGE_X, seconds=4.0)
    return g.x, plat.center[0] + plat.size[0] / 2


def test_a_goal_pushed_at_the_raised_edge_stays_off_the_board(solo: World) -> None:
    """A level board's field-side edge (or a raised one) stops a pushed goal as it stops a robot:
    its base stays off the board, and nothing rests on it."""
    x, edge = _push_goal_at_the_board(solo, 0.0)
    g = solo.goals[0]
    assert x - g.spec.base_radius >= edge - 1e-6
    assert not rules.goal_on_board(solo.field.platform("red"), g)
    assert solo.robots[0].on_platform is None


def test_a_goal_pushed_up_the_lowered_ramp_rests_on_the_board(solo: World) -> None:
    plat = solo.field.platform("red")
    x, edge = _push_goal_at_the_board(solo, plat.max_tilt_rad)
    assert x < edge - 0.1
    assert rules.goal_on_board(plat, solo.goals[0])


def test_no_goal_is_pushed_onto_the_board_over_its_end(solo: World) -> None:
    plat = solo.field.platform("red")
    end = plat.center[1] + plat.size[1] / 2
    g = solo.goals[0]
    solo.place_robot(0, HINGE_X, end + 0.6, 180.0)  # north of the board, facing south
    solo.place_goal(0, HINGE_X, end + 0.6 - solo.robots[0].config.length_m / 2 - 0.2)
    for _ in range(60):
        solo.step([DriveCommand(0.4, 0.0, intake=False)])
    assert g.y - g.spec.base_radius >= end - 1e-6
    assert not rules.goal_on_board(plat, g)


def test_two_robots_balance_side_by_side() -> None:
    """The 24" and the 15" robot climb one after the other and balance the platform side by side
    at the hinge: 60 points. The second can climb only while the first holds the board's field
    edge down (standing toward the field), a real manoeuvre."""
    with World(world_preset("tipping_point_2v2", blue=(), preloads=False)) as w:
        w.reset()
        w.set_floor_rings(np.zeros((0, 2)))
        for g in w.goals:
            w.place_goal(g.index, g.x, 1.3 if g.y >= 0 else -1.3)
        w.place_robot(0, -0.8, -0.32, 270.0)
        w.place_robot(1, -0.8, 0.35, 270.0)
        big, small = w.robots
        # The 24" robot climbs first, to the hinge.
        for _ in range(round(6 / w.dt)):
            err = big.x - HINGE_X
            w.step(
                [DriveCommand(max(-0.4, min(0.4, 1.5 * err)), 0.0, intake=False), DriveCommand()]
            )
        assert big.on_platform == "red" and rules.platform_balanced(w, "red")
        # The level board's edge is 3 in up: the 15" robot cannot follow until the board tips
        # its way. The 24" robot backs toward the field to lower the edge, the 15" climbs.
        for _ in range(round(1.0 / w.dt)):  # the 15" robot alone: blocked at the raised edge
            b = max(-0.4, min(0.4, 1.5 * (small.x - HINGE_X)))
            w.step([DriveCommand(0.0, 0.0, intake=False), DriveCommand(b, 0.0, intake=False)])
        assert small.on_platform is None
        for _ in range(round(3.0 / w.dt)):
            a = max(-0.4, min(0.4, 1.5 * (big.x - (HINGE_X + 0.15))))
            b = max(-0.4, min(0.4, 1.5 * (small.x - HINGE_X)))
            w.step([DriveCommand(a, 0.0, intake=False), DriveCommand(b, 0.0, intake=False)])
        assert small.on_platform == "red"
        for _ in range(round(4 / w.dt)):
            a = max(-0.4, min(0.4, 1.5 * (big.x - HINGE_X)))
            b = max(-0.4, min(0.4, 1.5 * (small.x - HINGE_X)))
            w.step([DriveCommand(a, 0.0, intake=False), DriveCommand(b, 0.0, intake=False)])
        s = w.score()["red"]
        assert s.balanced and s.robots_elevated == 2
        assert s.total == 60 + s.goals_in_zone * 20


def test_torque_balance_model() -> None:
    """Level while the loads' centre of mass is within hinge_flat of the hinge; tipped toward
    the heavier side beyond; an empty board stays where it was."""
    f = load_field()
    plat, spec = f.platform("red"), f.seesaw
    state = PlatformState("red", tilt=0.3)
    assert seesaw.target_tilt(plat, spec, state, []) == 0.3
    assert seesaw.target_tilt(plat, spec, state, [(5.5, 0.0)]) == 0.0
    # The 24" robot (9 kg) 0.1 m toward the field, the 15" (5.5 kg) 0.1 m toward the wall: the
    # net 0.35 kg m is within 2 in x 18.5 kg = 0.94 kg m.
    assert seesaw.target_tilt(plat, spec, state, [(9.0, 0.1), (5.5, -0.1)]) == 0.0
    assert seesaw.target_tilt(plat, spec, state, [(9.0, 0.2), (5.5, -0.1)]) == plat.max_tilt_rad
    assert seesaw.target_tilt(plat, spec, state, [(5.5, -0.2)]) == -plat.max_tilt_rad
    # The swing is rate limited.
    state = PlatformState("red", tilt=plat.max_tilt_rad)
    seesaw.step_tilt(plat, spec, state, [(5.5, -0.2)], 1 / 12)
    assert state.tilt == pytest.approx(plat.max_tilt_rad - math.radians(spec.tilt_rate_deg_s) / 12)
    assert math.degrees(plat.max_tilt_rad) == pytest.approx(14.48, abs=0.01)
    assert plat.edge_height(plat.max_tilt_rad) == pytest.approx(0.0, abs=1e-12)
