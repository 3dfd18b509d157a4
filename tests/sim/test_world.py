"""Physics and rules sanity of the simulated field (training fidelity unless stated)."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest

from jetson.autonomy.geometry import box_corners, field_to_robot
from sim.config import WorldConfig
from sim.errors import ConfigError, WorldError
from sim.world import rules, sensors
from sim.world.physics import World
from sim.world.state import RING_FLOOR, RING_HELD, RING_SCORED, DriveCommand


def clear_field(world: World) -> None:
    """No rings on the floor and every goal lined up along the far (+y) wall."""
    world.set_floor_rings(np.zeros((0, 2)))
    for i, _ in enumerate(world.goals):
        world.place_goal(i, -1.5 + 0.5 * i, 1.6)


@pytest.fixture
def solo() -> Iterator[World]:
    """One red 15 in robot on an empty field."""
    with World(WorldConfig(blue=())) as w:
        w.reset(np.random.default_rng(0))
        clear_field(w)
        yield w


def run(world: World, cmd: DriveCommand | list[DriveCommand], steps: int) -> None:
    cmds = cmd if isinstance(cmd, list) else [cmd] * len(world.robots)
    for _ in range(steps):
        world.step(cmds)


def ideal_distance(v_cmd: float, steps_on: int, steps_off: int, accel: float, dt: float) -> float:
    """Dead-reckoned distance of the accel-limited speed profile, computed independently."""
    v, d = 0.0, 0.0
    for k in range(steps_on + steps_off):
        target = v_cmd if k < steps_on else 0.0
        v += max(-accel * dt, min(accel * dt, target - v))
        d += v * dt
    return d


def test_drives_one_metre_straight_within_five_percent(solo: World) -> None:
    r = solo.robots[0]
    solo.place_robot(0, -1.2, 0.0, 90.0)
    dt = solo.dt
    steps_on = 23  # at 0.5 m/s and 12 Hz with the accel ramps: ~1 m
    expect = ideal_distance(0.5, steps_on, 6, r.config.max_linear_accel, dt)
    assert expect == pytest.approx(1.0, abs=0.05)
    run(solo, DriveCommand(0.5, 0.0), steps_on)
    assert r.measured_v == pytest.approx(0.5, rel=0.02)
    assert r.wheel_speeds() == pytest.approx((0.5, 0.5), abs=0.01)
    run(solo, DriveCommand(0.0, 0.0), 6)
    assert r.v == 0.0
    travelled = r.x + 1.2
    assert travelled == pytest.approx(expect, rel=0.05)
    assert abs(r.y) < 0.01, "drifted sideways"
    assert abs((r.heading - 90.0 + 180) % 360 - 180) < 1.0


def test_turns_in_place_clockwise_for_positive_angular(solo: World) -> None:
    r = solo.robots[0]
    solo.place_robot(0, 0.0, -0.5, 0.0)
    run(solo, DriveCommand(0.0, 1.0), 12)  # ramps to 1 rad/s within a step, then 1 s-ish
    run(solo, DriveCommand(0.0, 0.0), 3)
    turned = math.radians(r.heading)
    assert 0.7 < turned < 1.1, "positive angular must increase the heading (clockwise)"
    assert math.hypot(r.x, r.y + 0.5) < 0.01, "turning in place must not move the centre"


def test_differential_drive_wheel_speeds_round_trip(solo: World) -> None:
    rc = solo.robots[0].config
    left, right = rc.wheel_speeds(0.5, 1.0)
    assert left > right, "a clockwise turn runs the left side faster"
    assert rc.from_wheel_speeds(left, right) == pytest.approx((0.5, 1.0))
    cmd = DriveCommand.from_wheels(rc, left, right)
    assert (cmd.linear, cmd.angular) == pytest.approx((0.5, 1.0))


def test_speed_limits_and_nan_commands_stop(solo: World) -> None:
    r = solo.robots[0]
    solo.place_robot(0, 0.0, 0.0, 0.0)
    run(solo, DriveCommand(50.0, 0.0), 12)
    assert r.v == pytest.approx(r.config.max_linear_mps)
    run(solo, DriveCommand(float("nan"), 0.0), 12)
    assert r.v == 0.0


@pytest.mark.parametrize("heading", [0.0, 37.0, 90.0, 135.0, 200.0, 315.0])
def test_cannot_leave_the_field(heading: float) -> None:
    with World(WorldConfig(blue=())) as w:
        w.reset()
        w.place_robot(0, 0.0, 0.0, heading)
        lim = w.field.half + 1e-3
        r = w.robots[0]
        for k in range(84):  # 7 s at full speed, turning now and then into corners
            turn = 2.0 if (k // 20) % 2 else 0.0
            w.step([DriveCommand(r.config.max_linear_mps, turn)])
            corners = box_corners(r.xy, r.heading, r.config.width_m, r.config.length_m)
            assert np.all(np.abs(corners) <= lim), f"left the field at step {k}: {corners}"
        for g in w.goals:
            assert max(abs(g.x), abs(g.y)) <= w.field.half - g.spec.base_radius + 1e-3


def test_cannot_pass_through_a_goal(solo: World) -> None:
    """A goal against the wall cannot move away: the robot must stop at it, not go through."""
    r = solo.robots[0]
    g = solo.goals[0]
    rad = g.spec.base_radius
    solo.place_goal(0, solo.field.half - rad - 0.001, 0.0)
    solo.place_robot(0, 0.8, 0.0, 90.0)
    run(solo, DriveCommand(r.config.max_linear_mps, 0.0), 48)
    assert abs(r.measured_v) < 0.05, "a blocked robot's wheels report (almost) no speed"
    front = r.x + r.config.length_m / 2
    assert front <= g.x - rad + 0.03, f"robot front at {front}, goal base starts at {g.x - rad}"
    assert g.x == pytest.approx(solo.field.half - rad, abs=0.01)


def test_pushes_a_free_goal(solo: World) -> None:
    r = solo.robots[0]
    solo.place_goal(6, 0.0, 0.0)
    solo.place_robot(0, -0.6, 0.0, 90.0)
    run(solo, DriveCommand(0.6, 0.0), 24)
    g = solo.goals[6]
    assert g.x > 0.5, "the goal should have been pushed ahead"
    assert g.x - r.x >= r.config.length_m / 2 + g.spec.base_radius - 0.03


def test_a_sliding_goal_set_back_on_the_floor_slides_on(solo: World) -> None:
    """Training fidelity sets a goal that rose off the floor (a robot's push lifts it a little)
    back down each step; it slides on as it was sliding, rather than stopping dead."""
    import pybullet as p

    g = solo.goals[6]
    solo.place_goal(6, 0.0, 0.0)
    cid = solo.client
    p.resetBasePositionAndOrientation(g.body, (0.0, 0.0, 0.004), (0, 0, 0, 1), physicsClientId=cid)
    p.resetBaseVelocity(g.body, (0.5, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=cid)
    run(solo, DriveCommand(0.0, 0.0), 1)
    x1 = g.x
    run(solo, DriveCommand(0.0, 0.0), 2)
    assert g.x - x1 > 0.02, f"the goal stopped dead at x = {x1:.3f} m"


def test_a_goal_pinned_against_a_wall_stays_inside(solo: World) -> None:
    """A goal pushed hard into a wall is set back inside it and stops there."""
    import pybullet as p

    g = solo.goals[6]
    lim = solo.field.half - g.spec.base_radius
    solo.place_goal(6, lim - 0.01, 0.0)
    p.resetBaseVelocity(g.body, (3.0, 0.0, 0.0), (0.0, 0.0, 0.0), physicsClientId=solo.client)
    for _ in range(3):
        run(solo, DriveCommand(0.0, 0.0), 1)
        assert g.x <= lim + 1e-9


def test_robots_cannot_drive_through_each_other() -> None:
    import pybullet as p

    with World(WorldConfig()) as w:
        w.reset()
        clear_field(w)
        w.place_robot(0, -0.8, 0.0, 90.0)
        w.place_robot(1, 0.8, 0.0, 270.0)
        full = [DriveCommand(r.config.max_linear_mps, 0.0) for r in w.robots]
        deepest = 0.0
        for _ in range(36):
            w.step(full)
            pts = p.getClosestPoints(
                w.robots[0].body, w.robots[1].body, 0.1, physicsClientId=w.client
            )
            deepest = min([deepest, *(c[8] for c in pts)])
        assert w.robots[0].x < w.robots[1].x, "they swapped sides"
        assert deepest > -0.04, f"boxes overlapped by {-deepest:.3f} m"


def test_collects_only_through_the_intake(solo: World) -> None:
    r = solo.robots[0]
    solo.place_robot(0, 0.0, 0.0, 90.0)
    # Rings behind, beside and under the robot, none in front of it.
    behind = [[-0.35, 0.0], [-0.6, 0.0], [0.0, 0.0], [0.0, 0.30], [0.0, -0.30]]
    solo.set_floor_rings(np.array(behind))
    run(solo, DriveCommand(-0.5, 0.0), 24)  # reverse over them
    assert r.collected == 0
    # With the intake off, driving into rings takes none.
    solo.place_robot(0, 0.0, 0.0, 90.0)
    solo.set_floor_rings(np.array([[0.4, 0.0], [0.6, 0.0]]))
    run(solo, DriveCommand(0.5, 0.0, intake=False), 18)
    assert r.collected == 0
    solo.place_robot(0, 0.0, 0.0, 90.0)
    run(solo, DriveCommand(0.5, 0.0), 18)
    assert r.collected == 2 and r.held == 2
    assert np.all(solo.ring_state == RING_HELD)


def test_push_rings_moves_rings_out_from_under_the_body() -> None:
    """Training fidelity with push_rings: a ring the body drives over ends at its edge (and is
    still taken when the intake meets it); without, it stays where it was, under the robot."""
    for push in (False, True):
        with World(WorldConfig(blue=(), push_rings=push)) as w:
            w.reset(np.random.default_rng(0))
            clear_field(w)
            r = w.robots[0]
            w.place_robot(0, 0.0, 0.0, 90.0)  # facing +x
            # Ahead but outside the intake's width (the front corner meets it), and behind.
            w.set_floor_rings(np.array([[0.35, 0.16], [-0.4, -0.02]]))
            start = w.ring_xy.copy()
            run(w, DriveCommand(0.5, 0.0, intake=False), 12)  # forward into the first ring
            run(w, DriveCommand(-0.5, 0.0), 30)  # then back over the ring behind
            assert r.collected == 0
            local = field_to_robot(w.ring_xy, r.xy, r.heading)
            hx = r.config.width_m / 2 + w.field.ring.radius
            hy = r.config.length_m / 2 + w.field.ring.radius
            inside = (np.abs(local[:, 0]) < hx - 1e-9) & (np.abs(local[:, 1]) < hy - 1e-9)
            if not push:
                assert np.array_equal(w.ring_xy, start)
                continue
            assert not inside.any()
            ahead, back = w.ring_xy
            # Met by the front corner, outside the intake's width: bulldozed ahead, not aside.
            assert ahead[1] == pytest.approx(0.16) and ahead[0] > 0.35 + 0.05
            assert back[1] == pytest.approx(-0.02) and back[0] < -0.4 - 0.05
            assert back[0] == pytest.approx(r.x - hy, abs=1e-6)  # at the robot's back face
            # A ring ahead is still taken through the intake.
            w.set_floor_rings(np.array([[r.x + 0.4, r.y]]))
            run(w, DriveCommand(0.5, 0.0), 18)
            assert r.collected == 1


def test_collects_up_to_capacity(solo: World) -> None:
    r = solo.robots[0]
    cap = r.config.ring_capacity
    assert cap == 10
    solo.place_robot(0, -1.5, 0.0, 90.0)
    line = np.array([[-1.1 + 0.2 * k, 0.0] for k in range(13)])
    solo.set_floor_rings(line)
    run(solo, DriveCommand(0.6, 0.0), 84)
    assert r.held == cap and r.collected == cap
    assert int(np.sum(solo.ring_state == RING_FLOOR)) == 3


def test_clamp_transfer_and_score(solo: World) -> None:
    """Back onto a goal: it clamps, held rings move onto it, and it scores where it ends."""
    r = solo.robots[0]
    g = solo.goals[0]  # red_north
    assert g.spec.alliance == "red"
    solo.place_goal(0, -1.0, 0.0)
    solo.place_robot(0, -1.0 + g.spec.base_radius + r.config.length_m / 2 + 0.05, 0.0, 90.0)
    solo.set_floor_rings(np.array([[0.0 + 0.15 * k, 0.0] for k in range(4)]))
    run(solo, DriveCommand(-0.3, 0.0), 6)
    assert r.carried_goal == 0 and g.carried_by == 0
    run(solo, DriveCommand(0.5, 0.0), 30)
    run(solo, DriveCommand(0.0, 0.0), 30)  # let the conveyor run
    assert r.collected == 4 and r.held == 0 and g.rings == 4
    assert int(np.sum(solo.ring_state == RING_SCORED)) == 4
    # The goal followed the robot; it is now behind it.
    local = field_to_robot([[g.x, g.y]], r.xy, r.heading)[0]
    assert local[1] < -r.config.length_m / 2
    score = solo.score()["red"]
    owner, _ = rules.goal_owner(solo, g)
    zone_goals = score.goals_in_zone
    assert score.rings == 4
    assert score.total == 4 * 3 + zone_goals * 20 + score.robots_elevated * 30
    assert owner in ("red", None)
    # Release it with an explicit clamp=False.
    solo.step([DriveCommand(0.0, 0.0, clamp=False)])
    assert r.carried_goal is None and g.carried_by is None


def test_score_counts_as_the_manual() -> None:
    with World(WorldConfig(blue=())) as w:
        w.reset()
        f = w.field
        red_zone = f.home_zones["red"]
        red_goal, blue_goal, neutral = w.goals[0], w.goals[2], w.goals[4]
        # Red goal in red's zone with 3 rings, neutral in blue's zone with 5 rings, a blue goal
        # in red's zone with 2 rings, the red robot on its platform.
        w.place_goal(0, red_zone.x0 + 0.5, 1.0)
        w.place_goal(4, f.home_zones["blue"].x0 + 0.4, 0.0)
        w.place_goal(2, red_zone.x0 + 0.5, -1.2)
        red_goal.rings, neutral.rings, blue_goal.rings = 3, 5, 2
        plat = f.platform("red")
        w.place_robot(0, plat.center[0], plat.center[1], 90.0)
        s = w.score()
        sc = f.scoring
        # Red: 3 rings on its goal; goals in its zone: red_north and red_south (start there) and
        # not the blue one; robot elevated.
        red_in_zone = sum(1 for g in w.goals if rules.goal_owner(w, g) == ("red", False))
        assert s["red"].rings == 3
        assert s["red"].robots_elevated == 1
        assert s["red"].total == 3 * sc.ring_branch + red_in_zone * 20 + 30
        # Blue: its own goal's 2 rings count wherever it is; the neutral's 5 count in its zone.
        assert s["blue"].rings == 2 + 5
        assert rules.goal_owner(w, blue_goal) == (None, False)


def test_pin_after_five_seconds_of_contact() -> None:
    with World(WorldConfig()) as w:
        w.reset()
        clear_field(w)
        w.place_robot(0, -0.2, 0.0, 90.0)  # red faces blue
        w.place_robot(1, 0.2, 0.0, 270.0)
        push = [DriveCommand(0.3, 0.0), DriveCommand(0.3, 0.0)]
        pins_at = []
        for _ in range(72):
            ev = w.step(push)
            if ev.pins:
                pins_at.append(w.time_s)
        assert pins_at, "robots pushing each other for 6 s must be a pin"
        assert pins_at[0] == pytest.approx(5.0, abs=w.dt + 1e-9)
        assert rules.pin_timer(w, 0, 1) < 1.5
        # Apart: the timer resets and nothing is called.
        w.place_robot(0, -1.0, 0.0, 90.0)
        w.place_robot(1, 1.0, 0.0, 90.0)
        for _ in range(72):
            assert not w.step([DriveCommand(), DriveCommand()]).pins
        assert rules.pin_timer(w, 0, 1) == 0.0


def test_match_ends_at_the_configured_time() -> None:
    with World(WorldConfig(interaction_s=1.0, isolation_s=0.5)) as w:
        w.reset()
        assert w.phase == "isolation"
        n = 0
        changed = False
        while not w.over:
            ev = w.step([DriveCommand(), DriveCommand()])
            changed |= ev.phase_changed
            n += 1
        assert n == 18 and changed and w.phase == "over"
        assert w.step([DriveCommand(), DriveCommand()]).match_over


def test_isolation_barrier_stops_robots_at_the_centre_line() -> None:
    with World(WorldConfig(blue=(), interaction_s=2.0, isolation_s=3.0)) as w:
        w.reset()
        clear_field(w)
        w.place_robot(0, -0.6, -1.2, 90.0)
        r = w.robots[0]
        run(w, DriveCommand(0.6, 0.0), 30)
        assert r.x + r.config.length_m / 2 <= 0.03
        run(w, DriveCommand(0.6, 0.0), 12)
        assert r.x > 0.0, "after isolation the centre line is open"


def test_gps_latency_and_noise(solo: World) -> None:
    r = solo.robots[0]
    solo.place_robot(0, -1.0, 0.0, 90.0)
    run(solo, DriveCommand(0.5, 0.0), 12)
    latency = r.config.gps.latency_s
    reading = sensors.gps(solo, 0)
    assert reading.x == pytest.approx(r.x - 0.5 * latency, abs=1e-6)
    assert reading.heading_deg == pytest.approx(90.0, abs=1e-6)
    rng = np.random.default_rng(3)
    xs = np.array([sensors.gps(solo, 0, rng).x for _ in range(2000)])
    assert xs.std() == pytest.approx(r.config.gps.noise_xy_m, rel=0.1)


def test_misuse_is_reported() -> None:
    with World(WorldConfig()) as w:
        with pytest.raises(WorldError, match="reset"):
            w.step([DriveCommand(), DriveCommand()])
        w.reset()
        with pytest.raises(WorldError, match="expected 2 commands"):
            w.step([DriveCommand()])
        with pytest.raises(WorldError, match="outside"):
            w.set_floor_rings(np.array([[5.0, 0.0]]))
    with pytest.raises(ConfigError, match="fidelity"):
        WorldConfig(fidelity="ultra")  # type: ignore[arg-type]
    with pytest.raises(ConfigError, match="not configured"):
        WorldConfig(red=("30in",))


def test_same_seed_same_match() -> None:
    def play(seed: int) -> list[tuple[float, ...]]:
        from sim.baselines.scripted import GreedyChaser

        with World(WorldConfig(start_jitter_m=0.05, start_jitter_deg=10.0)) as w:
            w.reset(np.random.default_rng(seed))
            bots = [GreedyChaser(i) for i in range(2)]
            out = []
            for _ in range(150):
                w.step([b.act(w) for b in bots])
                out.append(tuple(v for r in w.robots for v in (r.x, r.y, r.heading, r.collected)))
            return out

    a, b, c = play(5), play(5), play(6)
    assert a == b
    assert a != c


def test_high_fidelity_rings_are_bodies_that_stay_on_the_floor() -> None:
    with World(WorldConfig(fidelity="high", blue=())) as w:
        w.reset()
        assert w.substeps == 20 and len(w.ring_bodies) == 42
        w.set_floor_rings(np.array([[-0.5, 0.0], [0.8, 0.8]]))
        w.place_robot(0, -1.0, 0.0, 90.0)
        run(w, DriveCommand(0.4, 0.0), 24)
        r = w.robots[0]
        assert r.collected == 1
        assert w.ring_state[0] == RING_HELD and w.ring_state[1] == RING_FLOOR
        assert 0.0 < w.ring_z[1] < 0.05, "a dynamic ring fell through the floor or flew"
        assert w.ring_xy[1] == pytest.approx([0.8, 0.8], abs=0.01)


def test_preloads_and_match_loads_are_options() -> None:
    with World(WorldConfig(preloads=True, match_loads=True)) as w:
        w.reset()
        assert [r.held for r in w.robots] == [3, 3]
        assert int(np.sum(w.ring_state == RING_FLOOR)) == 42 + 18
        assert len(w.ring_xy) == 42 + 18 + 6
        floor = w.ring_xy[w.ring_state == RING_FLOOR]
        assert np.all(np.abs(floor) < w.field.half)
    with World(WorldConfig()) as w:
        w.reset()
        assert [r.held for r in w.robots] == [0, 0] and len(w.ring_xy) == 42
