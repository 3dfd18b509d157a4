"""The scripted alliance's robot side (jetson/autonomy/alliance.py, field_layout.py): numpy only,
no simulator. The twin's matches are tests/sim/baselines/test_alliance.py."""

from __future__ import annotations

import copy
import json
import math

import numpy as np
import pytest

from jetson.autonomy.alliance import (
    GOAL_COLOUR_CODES,
    AllianceAction,
    AllianceConfig,
    AllianceInputs,
    AllianceStrategy,
    RobotRole,
    default_plan,
)
from jetson.autonomy.field_layout import DEFAULT_LAYOUT, load_layout, parse_layout
from jetson.autonomy.geometry import angle_diff_deg

ROLE_15 = RobotRole(
    role="15in",
    length_m=0.381,
    width_m=0.381,
    mass_kg=5.5,
    max_linear_mps=0.904,
    max_angular_rad_s=4.8,
    intake_zone=(-0.11, 0.11, 0.15, 0.27),
    reaches_high_branch=False,
    partner_mass_kg=9.0,
)

ROLE_24 = RobotRole(
    role="24in",
    length_m=0.6096,
    width_m=0.6096,
    mass_kg=9.0,
    max_linear_mps=0.904,
    max_angular_rad_s=4.8,
    intake_zone=(-0.15, 0.15, 0.25, 0.44),
    reaches_high_branch=True,
    partner_mass_kg=5.5,
)


def inputs(
    alliance: str, x: float, y: float, h: float, t: float, rings: np.ndarray
) -> AllianceInputs:
    return AllianceInputs(x, y, h, alliance, t, rings, 3, False)


def test_the_layout_file_loads_and_names_its_goals() -> None:
    layout = load_layout()
    assert layout.match_length_s == pytest.approx(120.0)
    assert {g.owner for g in layout.goals} == {"own", "opponent", None}
    assert layout.goal(layout.awp_goal).owner == "own"
    assert set(layout.starts) == {"24in", "15in"}
    plat = layout.platform
    assert plat.field_side == 1.0 and plat.wall_heading_deg == 270.0
    assert plat.x_at(plat.along(-1.3)) == pytest.approx(-1.3)
    # the other alliance's board is this one turned half a turn about the field's centre
    cx, cy = plat.center
    assert plat.other_contains((-cx, -cy)) and not plat.other_contains((cx, cy))
    assert not plat.contains((-cx, -cy))
    assert plat.either_contains((cx, cy)) and plat.either_contains((-cx, -cy))
    # a point 0.2 m off each board's field edge: within a 0.25 m margin, not within 0.1 m
    edge = plat.x_at(plat.size[0] / 2 + 0.2)
    assert plat.either_contains((edge, cy), 0.25, 0.1) and not plat.either_contains(
        (-edge, -cy), 0.25, 0.1
    )
    assert plat.either_contains((-edge, -cy), 0.1, 0.25) and not plat.either_contains(
        (edge, cy), 0.1, 0.25
    )


def test_a_bad_layout_names_what_is_wrong() -> None:
    data = json.loads(DEFAULT_LAYOUT.read_text())
    broken = copy.deepcopy(data)
    del broken["platform"]["hinge_flat_m"]
    with pytest.raises(ValueError, match="hinge_flat_m"):
        parse_layout(broken)
    broken = copy.deepcopy(data)
    broken["awp_goal"] = "nowhere"
    with pytest.raises(KeyError, match="nowhere"):
        parse_layout(broken)
    broken = copy.deepcopy(data)
    broken["goals"][0]["xy"] = [1.0]
    with pytest.raises(ValueError, match="xy"):
        parse_layout(broken)


def test_each_role_has_its_plan() -> None:
    layout = load_layout()
    big, small = default_plan("24in", layout), default_plan("15in", layout)
    assert big.iso == [] and big.neutral[0] == "neutral_south"
    assert [t.goal for t in small.iso] == ["red_north"] and small.iso[0].keep
    assert small.neutral[0] == "neutral_north"


def test_step_gives_the_five_commands_and_reset_starts_over() -> None:
    s = AllianceStrategy(ROLE_15, load_layout())
    a = s.step(inputs("red", -1.5748, 1.3716, 90.0, 0.0, np.zeros((0, 2))))
    assert isinstance(a, AllianceAction)
    linear, angular, clamp, lift, intake = a
    assert np.isfinite(linear) and np.isfinite(angular)
    assert clamp in (True, False, None) and lift in (True, False, None)
    assert isinstance(intake, bool)
    for k in range(1, 30):
        s.step(inputs("red", -1.5748, 1.3716, 90.0, k / 12, np.zeros((0, 2))))
    s.reset()
    assert s.phase == "iso_goal" and s.holding is None
    assert len(s.memory.known) == len(load_layout().rings)


def test_blue_plays_the_mirror_of_red() -> None:
    """The strategy plans in the alliance frame: a blue robot at red's mirrored pose, seeing the
    same rings in its own robot frame, gets the same commands step for step."""
    layout = load_layout()
    red, blue = AllianceStrategy(ROLE_15, layout), AllianceStrategy(ROLE_15, layout)
    rng = np.random.default_rng(4)
    x, y, h = -1.5748, 1.3716, 90.0
    for k in range(60):
        rings = rng.uniform(-1.0, 1.0, (3, 2))
        t = k / 12
        a = red.step(inputs("red", x, y, h, t, rings))
        b = blue.step(inputs("blue", -x, -y, (h + 180.0) % 360.0, t, rings))
        assert a == pytest.approx(b)
        # Move as commanded, crudely, so the plan goes on.
        hr = np.radians(h)
        x += a.linear / 12 * np.sin(hr)
        y += a.linear / 12 * np.cos(hr)
        h = (h + np.degrees(a.angular / 12)) % 360.0


def test_the_endgame_balance_point_balances_the_board_with_both_robots_on_it() -> None:
    """The 24"'s balance point: the board's torques (both robots, both carried goals) stay
    within what the hinge's flats hold level, and its whole footprint stays over the board."""
    layout = load_layout()
    role = ROLE_24
    s = AllianceStrategy(role, layout)
    s.holding = "neutral_south"
    d = s._balance_along(AllianceInputs(0, 0, 0, "red", 110.0, np.zeros((0, 2)), 0, True))
    plat = layout.platform
    half = plat.size[0] / 2
    partner = layout.goal("red_north")
    neutral = layout.goal("neutral_south")
    c = s.config
    torque = (
        role.mass_kg * d
        + neutral.mass_kg * min(role.clamp_offset(neutral), half)
        + role.partner_mass_kg * c.partner_along_m
        + partner.mass_kg * min(c.partner_along_m + 0.36, half)
    )
    weight = plat.board_mass_kg + role.mass_kg + role.partner_mass_kg
    weight += neutral.mass_kg + partner.mass_kg
    assert abs(torque) < 0.5 * plat.hinge_flat_m * weight
    assert abs(d) + role.length_m / 2 <= half + plat.overhang_m


def sighting(
    t: float, goals: list[tuple[float, float, str]], alliance: str = "red"
) -> AllianceInputs:
    """The 24" standing at (-0.9, -0.9) facing +x (heading 90, red's view) at time t, seeing
    `goals` (field x, y and colour) through its goal detector."""
    x, y = -0.9, -0.9
    rows = [(-(gy - y), gx - x, GOAL_COLOUR_CODES[c]) for gx, gy, c in goals]  # robot frame
    return AllianceInputs(
        x, y, 90.0, alliance, t, np.zeros((0, 2)), 0, False,
        goals_robot=np.array(rows, dtype=np.float64).reshape(-1, 3),
    )  # fmt: skip


def test_a_seen_goal_moves_its_belief_and_a_goal_of_the_other_colour_is_no_target() -> None:
    """The goal detector's sightings: a neutral goal seen 0.5 m from where the layout put it is
    believed there; a blue goal seen where a neutral goal was believed means that one is not
    there (it is no longer a target); without sightings nothing changes."""
    layout = load_layout()
    s = AllianceStrategy(ROLE_24, layout)
    south = np.array(layout.goal("neutral_south").xy)
    tall = np.array(layout.goal("neutral_tall").xy)
    s.step(sighting(20.0, []))
    assert s.goals["neutral_south"].xy == pytest.approx(south)
    assert s._goal_available("neutral_south") and s._goal_available("neutral_tall")
    moved = south + np.array([-0.5, 0.1])
    s.step(sighting(20.1, [(moved[0], moved[1], "yellow"), (tall[0] + 0.05, tall[1], "blue")]))
    assert s.goals["neutral_south"].xy == pytest.approx(moved, abs=1e-6)
    assert s._goal_available("neutral_south")
    assert not s._goal_available("neutral_tall") and s.goals["neutral_tall"].xy is None


def test_a_goal_seen_moving_is_carried_and_left_alone_for_a_while() -> None:
    layout = load_layout()
    s = AllianceStrategy(ROLE_24, layout)
    south = np.array(layout.goal("neutral_south").xy)
    s.step(sighting(20.0, [(south[0], south[1], "yellow")]))
    s.step(sighting(20.5, [(south[0] - 0.3, south[1], "yellow")]))  # 0.6 m/s: carried
    assert not s._goal_available("neutral_south")
    s.step(sighting(20.5 + s.config.busy_s + 0.1, []))
    assert s._goal_available("neutral_south")
    # For a blue robot a red base is the other alliance's: seen at the field spot that is its
    # neutral_south's in its (mirrored) alliance frame, that goal is no target; a blue base
    # there is its own alliance's goal and changes nothing about the neutral one.
    for colour, available in (("red", False), ("blue", True)):
        b = AllianceStrategy(ROLE_24, layout)
        b.step(sighting(20.0, [(-south[0], -south[1], colour)], alliance="blue"))
        assert b._goal_available("neutral_south") == available


def drive(
    s: AllianceStrategy,
    pose: tuple[float, float, float],
    t0: float,
    seconds: float,
    camera: list[tuple[float, float, str]] | None,
    clamped: bool = False,
    stop_on_release: bool = False,
) -> tuple[list[tuple[float, float, float, AllianceAction, str]], bool]:
    """Run a red robot's strategy `seconds` on a kinematic robot (no other robot, no physics):
    the camera reports the `camera` goals (field x, y, colour) within 40 degrees of its heading
    and 3 m (None: no goal detector); the clamp holds from `clamped` until commanded open (then
    the run stops with `stop_on_release`). Returns each step's pose, action and intent, and
    the clamp's state at the end."""
    x, y, h = pose
    dt = 0.05
    log = []
    for k in range(int(seconds / dt)):
        t = t0 + k * dt
        goals = None
        if camera is not None:
            rows = []
            for gx, gy, colour in camera:
                dx, dy = gx - x, gy - y
                rad = math.radians(h)
                right = dx * math.cos(rad) - dy * math.sin(rad)
                ahead = dx * math.sin(rad) + dy * math.cos(rad)
                if ahead > 0 and math.hypot(dx, dy) < 3 and abs(math.atan2(right, ahead)) < 0.7:
                    rows.append((right, ahead, GOAL_COLOUR_CODES[colour]))
            goals = np.array(rows, dtype=np.float64).reshape(-1, 3)
        a = s.step(AllianceInputs(x, y, h, "red", t, np.zeros((0, 2)), 0, clamped, False, goals))
        log.append((x, y, h, a, s.intent))
        if clamped and a.clamp is False:
            clamped = False
            if stop_on_release:
                break
        rad = math.radians(h)
        x += a.linear * dt * math.sin(rad)
        y += a.linear * dt * math.cos(rad)
        h = (h + math.degrees(a.angular * dt)) % 360.0
    return log, clamped


def test_a_goal_not_seen_where_it_should_stand_is_not_backed_onto() -> None:
    """With a goal detector, the 24" looks at the neutral goal before it turns its back to it:
    a goal the camera does not show there (another robot took it) is marked missing, and the
    robot never reverses toward that spot; one the camera shows is backed onto."""
    layout = load_layout()
    south = layout.goal("neutral_south").xy
    s = AllianceStrategy(ROLE_24, layout)
    log, _ = drive(s, (-0.9, -0.9, 90.0), 16.0, 8.0, camera=[])
    intents = [k[4] for k in log]
    assert "look:neutral_south" in intents
    assert "back_onto:neutral_south" not in intents
    assert s.goals["neutral_south"].xy is None
    seen = AllianceStrategy(ROLE_24, layout)
    log, _ = drive(seen, (-0.9, -0.9, 90.0), 16.0, 8.0, camera=[(*south, "yellow")])
    assert "back_onto:neutral_south" in [k[4] for k in log]


def test_the_24_leaves_its_goal_in_the_home_zone_once_the_floor_is_clear() -> None:
    """No ring known (the floor cleared) for deposit_after_s with a goal in the clamp and time
    enough left: the 24" carries it deep into its home zone, beside the platform, lets it go
    there and heads for the next goal on its list; the goal left is not that next goal."""
    from dataclasses import replace

    from jetson.autonomy.alliance import AllianceConfig

    layout = load_layout()
    # no steal; no ring is ever worth taking; deposits on (off by default), the raid off
    config = replace(AllianceConfig(), steal_s=None, ring_x_max_m=-10.0, deposit_after_s=4.0)
    s = AllianceStrategy(ROLE_24, layout, config)
    s.target_goal = "neutral_south"
    log, clamped = drive(s, (0.0, -0.4, 0.0), 20.0, 15.0, None, True, stop_on_release=True)
    assert not clamped and s._deposited == ["neutral_south"]
    x, y, h = log[-1][:3]
    goal_at = (x - 0.47 * math.sin(math.radians(h)), y - 0.47 * math.cos(math.radians(h)))
    assert layout.in_home_zone(goal_at, margin=-0.17)
    assert not layout.platform.contains(goal_at, margin=0.2)
    drive(s, (x, y, h), 20.0 + 0.05 * len(log), 2.0, None)
    assert s.goals["neutral_south"].xy == pytest.approx(goal_at, abs=0.05)
    assert s.phase == "get_goal" and s.target_goal == "neutral_tall"


def test_the_24_tries_as_many_neutral_goals_as_configured_then_its_awp_goal() -> None:
    from jetson.autonomy.alliance import AllianceConfig

    layout = load_layout()
    for n, want in (
        (3, ["neutral_south", "neutral_tall", "neutral_north"]),
        (1, ["neutral_south"]),
        (0, []),
    ):
        s = AllianceStrategy(ROLE_24, layout, AllianceConfig(neutral_goals_24=n))
        assert s.plan.neutral == [*want, layout.awp_goal]
    small = AllianceStrategy(ROLE_15, layout, AllianceConfig(neutral_goals_24=0))
    assert small.plan.neutral == default_plan("15in", layout).neutral


def test_a_goal_of_the_other_colour_seen_moves_that_goals_belief() -> None:
    """The other alliance's goals are beliefs too (the raid's targets): a blue base seen near
    where the layout puts a blue goal moves that belief there, and it is not taken for a
    conflict with itself."""
    layout = load_layout()
    s = AllianceStrategy(ROLE_24, layout)
    theirs = np.array(layout.goal("blue_south").xy)
    moved = theirs + np.array([-0.3, -0.2])
    s.step(sighting(40.0, [(moved[0], moved[1], "blue")]))
    assert s.goals["blue_south"].xy == pytest.approx(moved, abs=1e-6)
    assert s._goal_available("blue_south", raid=True)
    assert not s._goal_available("blue_south")  # deep in the other half: the raid's only


def test_the_raid_takes_the_other_alliances_zone_first_and_never_one_scored_already() -> None:
    """After its first goal is left in the home zone, the 24" (goal detector on) fetches free
    goals from outside its home zone: one in the other alliance's home zone before a nearer
    neutral one (within raid_prefer_m), never one already in its own zone, one on a platform,
    one seen carried, and none once deposit_until_s is reached."""
    from dataclasses import replace

    from jetson.autonomy.alliance import AllianceConfig

    layout = load_layout()
    raid = replace(AllianceConfig(), raid=True, deposit_after_s=2.0)
    s = AllianceStrategy(ROLE_24, layout, raid)
    s.step(sighting(40.0, []))  # the detector reports (nothing seen)
    s._deposited = ["neutral_south"]
    s.goals["neutral_south"].xy = np.array([-1.4, -1.3])  # left in the home zone
    from jetson.autonomy.alliance import Pose

    here = Pose(np.array([0.0, 0.0]), 90.0, 40.0)
    for name in ("red_north", "red_south", "neutral_north", "neutral_tall", "blue_north"):
        s.goals[name].xy = None
    s.goals["neutral_tall"].xy = np.array([0.3, 0.6])  # 0.67 m away, in the neutral zone
    s.goals["blue_south"].xy = np.array([0.9, -1.0])  # 1.35 m away, in their home zone
    assert s._raid_goal(here) == "blue_south"
    s.goals["neutral_tall"].xy = np.array([0.1, 0.2])  # much nearer: the neutral one
    s.goals["blue_south"].xy = np.array([1.5, -1.5])
    assert s._raid_goal(here) == "neutral_tall"
    s.goals["neutral_tall"].xy = np.array([1.5, 0.0])  # on the other alliance's platform
    assert s._raid_goal(here) == "blue_south"
    s._busy["blue_south"] = 50.0  # seen carried
    assert s._raid_goal(here) is None
    s._busy.clear()
    late = Pose(here.xy, 90.0, layout.match_length_s - s.config.deposit_until_s + 0.1)
    assert s._raid_goal(late) is None
    s._deposited = []
    assert s._raid_goal(here) is None  # no raid before the first goal is left
    # the first goal left: the list's goals are then taken only as raid targets
    s._deposited = ["neutral_south"]
    s.goals["blue_south"].xy = np.array([-1.0, -1.5])  # already in its own zone
    assert s._interaction_goal(here) is None
    s.goals["blue_south"].xy = np.array([0.9, -1.0])
    off = AllianceStrategy(ROLE_24, layout)  # the raid is off by default
    off.step(sighting(40.0, []))
    off._deposited = ["neutral_south"]
    off.goals = s.goals
    assert off._raid_goal(here) is None


def test_a_goal_beside_a_platform_is_backed_onto_from_where_the_robot_stays_off_it() -> None:
    """The stage chosen for a goal beside the other alliance's platform (its alliance goal's
    start) leaves the robot's whole footprint off both platforms when the clamp closes."""
    layout = load_layout()
    s = AllianceStrategy(ROLE_24, layout)
    from jetson.autonomy.alliance import Pose

    goal = np.array(layout.goal("blue_south").xy)
    for start in ((0.0, 0.0), (0.5, -1.4), (0.6, 0.3)):
        stage = s._stage_for(goal, Pose(np.array(start), 90.0, 40.0))
        assert not s._clamped_touches_platform(goal, stage)
        assert not s._near_a_platform(stage, 0.3)
    # straight from the field side the footprint would touch the board's corner
    assert s._clamped_touches_platform(goal, goal + np.array([-0.8, 0.0]))


def test_the_24_takes_a_goal_in_its_lane_on_the_board_before_it_climbs() -> None:
    """In front of the platform for its climb with an empty clamp, the 24" that sees a goal on
    the board in its lane turns its back to the board and, once the sentry has unlocked the
    board, reverses up its lane toward that goal with the clamp ready (before that it waits);
    with nothing in its lane it lines up facing the wall as before."""
    layout = load_layout()
    plat = layout.platform
    c = AllianceStrategy(ROLE_24, layout).config
    t = layout.match_length_s - c.unlock_s + 1.0  # the sentry has unlocked the board
    stage = (plat.x_at(c.stage_along_m), c.board_y_24_m)
    on_board = (plat.center[0] - 0.14, c.board_y_24_m + 0.2)

    def at_stage(heading: float, seen: list[tuple[float, float]]) -> AllianceInputs:
        x, y = stage
        h = math.radians(heading)
        rows = [
            (
                (gx - x) * math.cos(h) - (gy - y) * math.sin(h),
                (gx - x) * math.sin(h) + (gy - y) * math.cos(h),
                GOAL_COLOUR_CODES["yellow"],
            )
            for gx, gy in seen
        ]
        return AllianceInputs(
            x, y, heading, "red", t, np.zeros((0, 2)), 0, False,
            goals_robot=np.array(rows, dtype=np.float64).reshape(-1, 3),
        )  # fmt: skip

    clear = AllianceStrategy(ROLE_24, layout)
    clear.phase = "climb"
    a = clear.step(at_stage(plat.wall_heading_deg, [on_board]))
    assert clear.intent == "line_up" and a.clamp is False
    assert a.angular != 0.0  # turning its back to the board
    a = clear.step(at_stage((plat.wall_heading_deg + 180.0) % 360.0, []))
    assert clear.intent == "clear_lane" and a.clamp is True and a.linear < 0.0
    # the clamp closes on it: straight out toward the field before turning with it
    x, y = stage
    took = AllianceInputs(
        x - 0.4, y, (plat.wall_heading_deg + 180.0) % 360.0, "red", t, np.zeros((0, 2)), 0, True
    )
    a = clear.step(took)
    assert clear.intent == "pull_out" and a.clamp is True and a.linear > 0.0
    out = took._replace(x=plat.x_at(c.stage_along_m + 0.4))
    clear.step(out)
    assert clear.intent in ("to_stage", "line_up")
    locked = AllianceStrategy(ROLE_24, layout)
    locked.phase = "climb"
    t = layout.match_length_s - c.climb_24_s + 1.0  # still locked
    locked.step(at_stage(plat.wall_heading_deg, [on_board]))
    a = locked.step(at_stage((plat.wall_heading_deg + 180.0) % 360.0, []))
    assert locked.intent == "wait_unlock" and a.linear == 0.0
    plain = AllianceStrategy(ROLE_24, layout)
    plain.phase = "climb"
    plain.step(at_stage(plat.wall_heading_deg, []))
    assert plain.intent in ("wait_unlock", "climb")
    # a sighting is forgotten after a second of reports without it
    old = AllianceStrategy(ROLE_24, layout)
    old.step(at_stage(plat.wall_heading_deg, [on_board])._replace(time_s=40.0))
    assert old._lane_goal(c.board_y_24_m) is not None
    old.step(at_stage(plat.wall_heading_deg, [])._replace(time_s=41.5))
    assert old._lane_goal(c.board_y_24_m) is None


def test_the_steal_targets_the_neutral_goal_seen_carried_before_a_nearer_free_one() -> None:
    """A neutral goal seen in motion again and again (a robot carries it; one pushed aside
    moves once) is followed whatever its name: with the steal on, the 24" goes for it (the
    other alliance's loaded goal), not for the nearer one standing still; a neutral goal in its
    own home zone (not left there by itself: most likely parked by its carrier) comes before
    a nearer one outside it, and one it left there is no target."""
    from jetson.autonomy.alliance import AllianceConfig, Pose

    layout = load_layout()
    s = AllianceStrategy(ROLE_24, layout, AllianceConfig(steal_s=50.0))
    south = np.array(layout.goal("neutral_south").xy)
    north = np.array(layout.goal("neutral_north").xy)
    here = Pose(np.array([-0.9, -0.9]), 90.0, 60.0)
    t = 60.0
    s.step(sighting(t, [(*south, "yellow"), (*north, "yellow")]))
    assert s._tracker.track is None
    pushed = north + np.array([0.25, 0.0])
    s.step(sighting(t + 0.5, [(*south, "yellow"), (*pushed, "yellow")]))  # 0.5 m/s, once
    assert s._tracker.track is not None and s._tracker.carried(t + 0.5) is None
    s.step(sighting(t + 3.0, [(*south, "yellow"), (*pushed, "yellow")]))  # then still
    assert s._steal_goal(here) == "neutral_south"  # the nearest: nothing is carried
    p = pushed.copy()
    for k in range(1, 6):  # in motion for 2.5 s: carried
        p = p + np.array([0.0, -0.25])
        s.step(sighting(t + 3.0 + 0.5 * k, [(*south, "yellow"), (*p, "yellow")]))
    assert s._tracker.carried(t + 5.5) is not None
    assert s._tracker.track.xy == pytest.approx(p, abs=1e-6)
    assert s._steal_goal(here) == "neutral_north"  # farther, but carried
    home = np.array([layout.home_zone[0] + 0.4, -1.2])
    for b in s.goals.values():
        b.xy = None
    s._tracker.track = None
    s.goals["neutral_south"].xy = home.copy()
    s.goals["neutral_north"].xy = north.copy()
    here_north = Pose(north + np.array([-0.3, 0.0]), 90.0, 60.0)
    assert s._steal_goal(here_north) == "neutral_south"  # the one in the home zone first
    s.goals["neutral_south"].xy = None
    assert s._steal_goal(here) == "neutral_north"
    s.goals["neutral_south"].xy = home.copy()
    s.goals["neutral_north"].xy = None
    s._deposited.append("neutral_south")
    assert s._steal_goal(here) is None  # never one it left itself
    s._deposited.clear()
    from jetson.autonomy.carried_goal import Track

    s._tracker.track = Track(home.copy(), 60.0, 55.0, 58.0, 5)
    assert s._steal_goal(here) == "neutral_south"
    # One chased goal_chase_s without the clamp closing is no target for busy_s.
    s._chased["neutral_south"] = s._now + 25.0
    assert s._steal_goal(here) is None
    s._now += 25.5
    assert s._steal_goal(here) == "neutral_south"


def test_the_steal_leaves_its_own_goal_home_then_hauls_the_stolen_one_home() -> None:
    """With `steal_s` left and a neutral goal seen carried elsewhere, the 24" drives the goal
    it holds into its home zone, beside the platform, and lets it go there (with none seen
    carried it keeps its own, home); a free goal it then steals is hauled to the home zone and
    let go (the next is stolen); one seen carried is held there to the end, pulling toward the
    wall."""
    from jetson.autonomy.alliance import AllianceConfig
    from jetson.autonomy.carried_goal import Track

    layout = load_layout()
    config = AllianceConfig(steal_s=50.0, steal_climb=False, ring_x_max_m=-10.0)
    t0 = layout.match_length_s - 49.0
    # Nothing seen moving: no other robot's goal to take; it keeps its own, hauls it home and
    # holds it there (a goal let go could be taken).
    keep = AllianceStrategy(ROLE_24, layout, config)
    keep.holding = "neutral_south"
    keep._was_clamped = True
    log, clamped = drive(keep, (0.0, -0.6, 0.0), t0, 12.0, None, True, stop_on_release=True)
    assert clamped and log[-1][4] == "hold" and keep._deposited == []
    # A neutral goal seen moving in the other half: it leaves its own goal home for it.
    s = AllianceStrategy(ROLE_24, layout, config)
    s.holding = "neutral_south"
    s._was_clamped = True
    s._tracker.track = Track(np.array([0.9, 1.0]), t0 - 5.0, t0 - 9.0, t0 - 6.0, 4)
    log, clamped = drive(s, (0.0, -0.6, 0.0), t0, 12.0, None, True, stop_on_release=True)
    assert not clamped and s._deposited == ["neutral_south"]
    x, y, h = log[-1][:3]
    goal_at = (x - 0.47 * math.sin(math.radians(h)), y - 0.47 * math.cos(math.radians(h)))
    assert layout.in_home_zone(goal_at)
    assert not layout.platform.contains(goal_at, margin=0.1)
    assert {k[4] for k in log} == {"steal_drop"}
    t1 = t0 + 0.05 * len(log)
    for carried, held in ((False, False), (True, True)):
        s2 = AllianceStrategy(ROLE_24, layout, config)
        s2._steal_dropped = True
        s2._set_phase("steal", t1)
        s2.phase_since = t1 - 1.0
        s2._steal_carried = carried
        s2.holding = s2.target_goal = "neutral_tall"
        s2._was_clamped = True
        log, clamped = drive(s2, (0.2, 0.4, 0.0), t1, 14.0, None, True, stop_on_release=True)
        # where it let go, or where it began to hold (a kinematic robot has no wall)
        x, y, h = next((k for k in log if k[4] == "hold"), log[-1])[:3]
        goal_at = (x - 0.47 * math.sin(math.radians(h)), y - 0.47 * math.cos(math.radians(h)))
        assert layout.in_home_zone(goal_at)
        assert clamped == held
        if held:
            assert log[-1][4] == "hold" and log[-1][3].linear > 0 and log[-1][3].clamp
        else:
            assert s2._deposited == ["neutral_tall"]


def test_with_the_steal_on_the_sentry_keeps_the_board_balanced_to_the_end() -> None:
    """The 24" steals instead of climbing: the 15" never unlocks the board nor climbs, it
    stays at the lock spot (the board level under it and its goal) through the endgame; with
    `steal_climb` the 24" climbs after all, and the 15" plays the climbing endgame."""
    from jetson.autonomy.alliance import AllianceConfig

    layout = load_layout()
    plat = layout.platform
    for steal, climb, phase in (
        (50.0, False, "sentry"),
        (None, False, "climb"),
        (50.0, True, "climb"),
    ):
        s = AllianceStrategy(ROLE_15, layout, AllianceConfig(steal_s=steal, steal_climb=climb))
        s._set_phase("sentry", 20.0)
        s._climbing = s._sentry_set = True
        x = plat.x_at(s.config.lock_along_m)
        wall = plat.wall_heading_deg
        log, _ = drive(
            s, (x, s.config.board_y_15_m, wall), layout.match_length_s - 25.0, 20.0, None, True
        )
        assert s.phase == phase
        if steal is not None:
            assert plat.along(log[-1][0]) == pytest.approx(s.config.lock_along_m, abs=0.03)


def test_a_goal_that_comes_slower_than_the_robot_drives_is_held_by_another_robot() -> None:
    """Driving forward at half speed or more with a goal clamped, yet moving less than half
    the way (a tug of war, or a wall): the goal is contested (`_contested`) until the clamp
    opens; a goal that comes along is not."""
    layout = load_layout()
    from jetson.autonomy.alliance import AllianceConfig

    for gain, contested in ((1.0, False), (0.2, True)):
        s = AllianceStrategy(ROLE_24, layout, AllianceConfig(steal_s=None))
        x, t = -0.5, 30.0
        s.step(AllianceInputs(x, 0.0, 270.0, "red", t, np.zeros((0, 2)), 0, True))
        for _ in range(60):
            t += 0.05
            s.step(AllianceInputs(x, 0.0, 270.0, "red", t, np.zeros((0, 2)), 0, True))
            s._moves[-1] = s._moves[-1]._replace(v=ROLE_24.max_linear_mps)  # as if at full speed
            x -= gain * ROLE_24.max_linear_mps * 0.05  # facing -x: forward is -x
        assert s._contested == contested
        s.step(AllianceInputs(x, 0.0, 270.0, "red", t + 0.05, np.zeros((0, 2)), 0, False))
        assert not s._contested


def test_a_carried_goal_not_seen_where_the_robot_looks_for_it_is_no_longer_followed() -> None:
    """The 24" looks before backing onto a goal; a goal followed as carried (the steal's first
    target) that is not seen where it was last seen in `look_s` is gone from there: the tracker
    drops it (it would send the robot back to that spot until the track is a minute old)."""
    from jetson.autonomy.alliance import AllianceConfig, Pose
    from jetson.autonomy.carried_goal import Track

    layout = load_layout()
    c = AllianceConfig(steal_s=104.0)
    s = AllianceStrategy(ROLE_24, layout, c)
    spot = np.array([0.1, -1.4])
    s._tracker.track = Track(spot.copy(), 15.0, 12.0, 14.0, 5)
    s._detector = True
    s.goals["neutral_tall"].xy = spot.copy()
    t = 20.0
    here = Pose(np.array([-0.7, -1.1]), 110.0, t)
    assert s._look("neutral_tall", here, spot) is not None  # turns to look
    assert s._tracker.carried(t) is not None
    later = Pose(here.xy, here.heading, t + c.look_s + 0.1)
    assert s._look("neutral_tall", later, spot) == (0.0, 0.0, False)
    assert s.goals["neutral_tall"].xy is None and s._tracker.track is None


def holding_a_contested_goal(
    phase: str, t: float, tow_into_board_s: float | None = None
) -> tuple[AllianceStrategy, AllianceConfig]:
    """A red 24" with steal-then-climb on, in `phase` at `t`, its clamp holding the tall goal
    another robot holds too (`tow_into_board_s`: AllianceConfig's, None by default here)."""
    c = AllianceConfig(steal_s=104.0, steal_climb=True, tow_into_board_s=tow_into_board_s)
    s = AllianceStrategy(ROLE_24, load_layout(), c)
    s._set_phase(phase, t)
    s._contested = True
    s.holding = s.target_goal = "neutral_tall"
    s._was_clamped = True
    return s, c


def test_with_steal_climb_the_24in_climbs_with_a_goal_another_robot_holds() -> None:
    """`steal_climb`: the 24" hauling a goal another robot holds too tows it to the stage in its
    lane, never slower than `tow_speed` (a tug of war goes to the harder pull), lines up there
    facing the wall and waits, only ever forward, until `climb_after_s` before the end; then it
    drives straight at the wall (up the board once its edge is down), the clamp closed
    throughout; dragged backward meanwhile (the other robot pulls harder), it pulls straight
    ahead at full speed, and in the last `tow_press_s` it drives at full speed."""
    layout = load_layout()
    plat = layout.platform
    s, c = holding_a_contested_goal("haul", 60.0)
    s._steal_dropped = True
    log, clamped = drive(s, (-0.3, -1.0, 90.0), 60.0, 20.0, None, True)
    assert clamped and all(k[3].clamp for k in log)
    assert s.phase == "haul_climb"
    towed = [k for k in log if k[4] == "tow"]
    assert towed and all(k[3].linear >= c.tow_speed * ROLE_24.max_linear_mps - 1e-9 for k in towed)
    waiting = [k for k in log if k[4] == "haul_wait"]
    assert waiting, "never lined up at its stage"
    x, y, h = waiting[-1][:3]
    assert y == pytest.approx(c.board_y_24_m, abs=0.1)
    assert plat.along(x) == pytest.approx(c.stage_along_m, abs=0.1)
    assert abs(angle_diff_deg(plat.wall_heading_deg, h)) < 8.0
    assert all(k[3].linear >= 0 for k in waiting)
    # The climb: from climb_after_s before the end, straight on toward the wall.
    t0 = layout.match_length_s - c.climb_after_s
    log, clamped = drive(s, (x, y, h), t0, 6.0, None, True)
    climbing = [k for k in log if k[4] == "haul_climb"]
    assert climbing and all(k[3].linear > 0 for k in climbing)
    assert plat.along(log[-1][0]) < plat.along(x) - 0.5
    # Dragged backward 0.3 m/s while driving ahead: full pull, straight.
    t = t0 + 6.0
    x, y, h = log[-1][:3]
    a = None
    for _ in range(30):
        a = s.step(AllianceInputs(x, y, h, "red", t, np.zeros((0, 2)), 0, True))
        x += 0.3 * 0.05  # back toward the field (the wall heading is 270 degrees: -x)
        t += 0.05
    assert a is not None and s.intent == "pull"
    assert a.linear == pytest.approx(ROLE_24.max_linear_mps) and a.angular == 0.0 and a.clamp
    # The last seconds, at the wall: full speed, no turning.
    wall_x = plat.x_at(ROLE_24.length_m / 2 - plat.size[0] / 2)
    t = layout.match_length_s - c.tow_press_s + 1.0
    a = s.step(
        AllianceInputs(wall_x, c.board_y_24_m + 0.05, 268.0, "red", t, np.zeros((0, 2)), 0, True)
    )
    assert s.intent in ("haul_climb", "pull")
    assert a.linear == pytest.approx(ROLE_24.max_linear_mps) and a.angular == 0.0 and a.clamp


def test_with_steal_climb_a_24in_dragged_off_its_stage_tows_back_at_full_speed_late() -> None:
    """Waiting at its stage with a goal another robot holds, the 24" dragged away from it tows
    it back (never turning in place); in the last `tow_press_s`, not yet lined up, it tows at
    full speed (the other robot heads home then)."""
    layout = load_layout()
    plat = layout.platform
    s, c = holding_a_contested_goal("haul_climb", 70.0)
    s._lined, s._towing = True, False
    far = (plat.x_at(c.stage_along_m + 0.7), c.board_y_24_m + 0.3)
    a = s.step(AllianceInputs(*far, 90.0, "red", 80.0, np.zeros((0, 2)), 0, True))
    assert s.intent == "tow" and not s._lined
    assert a.linear >= c.tow_speed * ROLE_24.max_linear_mps - 1e-9 and a.clamp
    late = layout.match_length_s - c.tow_press_s + 0.5
    a = s.step(AllianceInputs(*far, 90.0, "red", late, np.zeros((0, 2)), 0, True))
    assert s.intent == "tow" and a.linear == pytest.approx(ROLE_24.max_linear_mps)


def test_late_a_24in_tows_a_contested_goal_into_its_board_never_slowing_down() -> None:
    """From `tow_into_board_s` before the end the 24" holding a goal another robot holds too
    tows it along its lane into the board, never slower than `tow_speed` (no lining up at the
    stage, no waiting there: slower, the other robot's pull wins), only small turns at the
    board, pressed against it, and at full speed in the last `tow_press_s`."""
    layout = load_layout()
    plat = layout.platform
    c0 = AllianceConfig()
    assert c0.tow_into_board_s is not None and c0.tow_into_board_s > c0.climb_after_s
    t = layout.match_length_s - c0.tow_into_board_s + 0.5
    s, c = holding_a_contested_goal("haul_climb", t, c0.tow_into_board_s)
    least = c.tow_speed * ROLE_24.max_linear_mps - 1e-9
    # Off its lane, facing away from the board: it tows on (turning as it drives).
    log, clamped = drive(s, (plat.x_at(1.6), c.board_y_24_m + 0.6, 90.0), t, 8.0, None, True)
    assert clamped and all(k[3].clamp for k in log)
    assert {k[4] for k in log} == {"tow_press"}
    assert all(k[3].linear >= least for k in log)
    # Lined up in its lane, in front of the board's edge, it heads straight into it.
    edge_x = plat.x_at(plat.size[0] / 2 + ROLE_24.length_m / 2 - 0.02)
    lane_y = c.board_y_24_m + 0.03
    a = s.step(AllianceInputs(edge_x, lane_y, 272.0, "red", t + 8.0, np.zeros((0, 2)), 0, True))
    assert s.intent == "tow_press" and a.clamp and a.linear >= least
    assert abs(a.angular) <= c.turn_gain * c.tow_board_err_rad + 1e-9
    late = layout.match_length_s - c.tow_press_s + 0.5
    a = s.step(
        AllianceInputs(edge_x, c.board_y_24_m, 270.0, "red", late, np.zeros((0, 2)), 0, True)
    )
    assert a.linear == pytest.approx(ROLE_24.max_linear_mps) and a.clamp


def test_a_robot_turning_as_it_drives_is_not_taken_for_dragged_back() -> None:
    """Driving forward while it turns through half a turn in the drag window (the 15" lining up
    on its board in the isolation period): it moved ahead all the way, though it ends further
    back along its last heading than it began, so no tug of war is seen and it keeps its goal;
    driven backward by as much, it is dragged (the goal let go, `tug_release`)."""
    layout = load_layout()
    for back, let_go in ((False, False), (True, True)):
        s = AllianceStrategy(ROLE_15, layout)
        s._set_phase("sentry", 5.0)
        x, y, h, t = -1.1, 0.15, 70.0, 5.0
        released = False
        for _ in range(20):
            a = s.step(AllianceInputs(x, y, h, "red", t, np.zeros((0, 2)), 0, True))
            released = released or a.clamp is False
            step = -0.03 if back else 0.03  # metres along its heading
            x += step * math.sin(math.radians(h))
            y += step * math.cos(math.radians(h))
            h += 14.0  # 280 degrees a second
            t += 0.05
            if s._moves:  # what it commanded: ahead, slowly
                s._moves[-1] = s._moves[-1]._replace(v=0.4)
        assert released == let_go


def test_the_steal_tests_a_goal_it_clamped_by_driving_out_toward_the_field() -> None:
    """A goal the steal clamped without seeing it carried is tested: driven ahead at 0.6 of the
    top speed or more until a whole drag window was read, out toward the field when the haul
    spot is near (against a wall any goal comes slower). One that comes along is left in the
    home zone and the next is stolen; one that comes slower another robot holds too: it is
    towed to the stage (the default `steal_climb`)."""
    layout = load_layout()
    for gain, kept in ((1.0, False), (0.2, True)):
        s = AllianceStrategy(ROLE_24, layout)
        t = 40.0
        s._steal_dropped = True
        s._set_phase("steal", t - 1.0)
        s.holding = s.target_goal = "neutral_south"
        x, y, h = -1.3, -1.0, 270.0  # by the haul spot, facing the wall, the goal behind
        speeds, released = [], None
        for _ in range(int(10.0 / 0.05)):
            a = s.step(AllianceInputs(x, y, h, "red", t, np.zeros((0, 2)), 0, True))
            if a.clamp is False:
                released = (x, y, h)
                break
            speeds.append(a.linear)
            rad = math.radians(h)
            x += gain * a.linear * 0.05 * math.sin(rad)
            y += gain * a.linear * 0.05 * math.cos(rad)
            h = (h + math.degrees(a.angular * 0.05)) % 360.0
            t += 0.05
        assert min(speeds[:20]) >= 0.6 * ROLE_24.max_linear_mps - 1e-9  # until a window is read
        if kept:
            assert released is None and s._contested and s.phase == "haul_climb"
        else:
            assert released is not None and s._deposited == ["neutral_south"]
            rx, ry, rh = released
            goal_at = (
                rx - 0.47 * math.sin(math.radians(rh)),
                ry - 0.47 * math.cos(math.radians(rh)),
            )
            assert layout.in_home_zone(goal_at)
            assert max(s._test_to[0] - (-1.3), 0.0) > 0.9  # tested out toward the field


def test_late_in_the_match_the_steal_keeps_a_free_goal_to_climb_with() -> None:
    """From `refetch_s` before the end a free goal the steal tested is not left home: the 24"
    tows it to its stage (haul_climb) to climb with; a goal it left home earlier is a target
    again then, and not before."""
    from jetson.autonomy.alliance import Pose

    layout = load_layout()
    s = AllianceStrategy(ROLE_24, layout)
    late = layout.match_length_s - s.config.refetch_s + 1.0
    s._steal_dropped = True
    s._set_phase("steal", late - 1.0)
    s.holding = s.target_goal = "neutral_south"
    x, y, h, t = -1.3, -1.0, 270.0, late
    for _ in range(int(4.0 / 0.05)):
        a = s.step(AllianceInputs(x, y, h, "red", t, np.zeros((0, 2)), 0, True))
        assert a.clamp is not False
        rad = math.radians(h)
        x += a.linear * 0.05 * math.sin(rad)
        y += a.linear * 0.05 * math.cos(rad)
        h = (h + math.degrees(a.angular * 0.05)) % 360.0
        t += 0.05
    assert s.phase == "haul_climb" and not s._contested and s._deposited == []
    left = AllianceStrategy(ROLE_24, layout)
    for b in left.goals.values():
        b.xy = None
    left.goals["neutral_south"].xy = np.array([-1.4, -1.2])
    left._deposited.append("neutral_south")
    for when, target in ((60.0, None), (late, "neutral_south")):
        left._now = when
        assert left._steal_goal(Pose(np.array([-0.9, -0.9]), 90.0, when)) == target


def test_a_15in_pushed_out_of_its_lane_on_the_board_lines_up_again() -> None:
    """The 15" at its lock spot (or climbing from it) pushed along the wall more than
    `off_lane_m` (off the board's end it holds nothing level) goes back to its stage in front of
    the board and lines up in its lane again; nudged less, it stays where it is."""
    layout = load_layout()
    plat = layout.platform
    wall = plat.wall_heading_deg
    c = AllianceConfig()
    x = plat.x_at(c.lock_along_m)
    lane = c.board_y_15_m
    for nudge, stays in ((0.5 * c.off_lane_m, True), (c.off_lane_m + 0.4, False)):
        s = AllianceStrategy(ROLE_15, layout, c)
        s._set_phase("sentry", 60.0)
        s._climbing = s._sentry_set = True
        s.step(AllianceInputs(x, lane + nudge, wall, "red", 70.0, np.zeros((0, 2)), 0, True))
        assert (s.intent == "lock") is stays and (s.intent == "to_sentry") is not stays
        log, _ = drive(s, (x, lane + nudge, wall), 70.0, 12.0, None, True)
        if not stays:
            x_end, y_end, h_end = log[-1][:3]
            assert s.intent == "lock" and y_end == pytest.approx(lane, abs=0.07)
            assert plat.along(x_end) == pytest.approx(c.lock_along_m, abs=0.05)
            assert abs(angle_diff_deg(wall, h_end)) < 8.0
    # Climbing: the same, while there is time to line up again.
    left = c.blocked_s + 6.0
    s = AllianceStrategy(ROLE_15, layout, c)
    s._set_phase("climb", layout.match_length_s - left - 1.0)
    s._climbing = True
    s.step(
        AllianceInputs(
            x, lane + c.off_lane_m + 0.3, wall, "red", layout.match_length_s - left,
            np.zeros((0, 2)), 0, True,
        )
    )  # fmt: skip
    assert s.intent == "to_stage" and not s._climbing


def test_a_24in_pressing_a_contested_goal_against_the_wall_does_not_turn() -> None:
    """Towed into the board and up it, the 24" against the wall drives straight on, however
    far its heading is off: turning there walks it sideways along the wall, off its lane and
    its footprint off the board's end."""
    layout = load_layout()
    plat = layout.platform
    c0 = AllianceConfig()
    assert c0.tow_into_board_s is not None
    t = layout.match_length_s - c0.tow_into_board_s + 2.0
    s, c = holding_a_contested_goal("haul_climb", t, c0.tow_into_board_s)
    wall_x = plat.x_at(ROLE_24.length_m / 2 - plat.size[0] / 2)
    for y, h in ((c.board_y_24_m + 0.1, 270.0), (c.board_y_24_m, 262.0)):
        a = s.step(AllianceInputs(wall_x, y, h, "red", t, np.zeros((0, 2)), 0, True))
        assert s.intent == "tow_press" and a.clamp and a.angular == 0.0 and a.linear > 0
        t += 0.05
    # A step away from the wall, it still steers into its lane.
    a = s.step(AllianceInputs(wall_x + 0.2, c.board_y_24_m + 0.1, 270.0, "red", t,
                              np.zeros((0, 2)), 0, True))  # fmt: skip
    assert a.angular != 0.0


def test_a_24in_dragged_back_on_its_way_to_climb_takes_its_goal_for_held_by_another() -> None:
    """The 24" heading for its stage with a goal it believed free, driving ahead yet moved
    backward (another robot holds the goal too: the steal's test had not told yet), tows it
    (haul_climb) instead of lining up slowly, the clamp closed."""
    layout = load_layout()
    c = AllianceConfig()
    s = AllianceStrategy(ROLE_24, layout, c)
    t = layout.match_length_s - c.climb_24_s + 1.0
    s._set_phase("climb", t)
    s.holding = s.target_goal = "neutral_tall"
    s._was_clamped = True
    x, y, h = 0.0, -0.3, 270.0  # facing its board (-x), toward the stage
    a = s.step(AllianceInputs(x, y, h, "red", t, np.zeros((0, 2)), 0, True))
    assert s.phase == "climb" and a.linear > 0
    for _ in range(30):
        x += 0.3 * 0.05  # dragged toward the field, away from the board
        t += 0.05
        a = s.step(AllianceInputs(x, y, h, "red", t, np.zeros((0, 2)), 0, True))
        if s.phase != "climb":
            break
    assert s.phase == "haul_climb" and s._contested and a.clamp
    assert a.linear >= c.tow_speed * ROLE_24.max_linear_mps - 1e-9


def test_a_24in_that_finds_its_goal_held_by_another_on_its_way_to_climb_tows_it() -> None:
    """The 24" heading for its stage with a goal it believed free that comes slower than the
    robot drives (another robot holds it too and is dragged along) tows it (haul_climb) instead
    of lining up slowly and turning in place, which would hand the goal over."""
    layout = load_layout()
    c = AllianceConfig()
    for share, towed in ((0.2, True), (1.0, False)):
        s = AllianceStrategy(ROLE_24, layout, c)
        t = layout.match_length_s - c.climb_24_s + 1.0
        s._set_phase("climb", t)
        s.holding = s.target_goal = "neutral_tall"
        s._was_clamped = True
        x, y, h = 0.4, -0.25, 270.0  # facing its board (-x), far from the stage, in its lane
        for _ in range(40):
            a = s.step(AllianceInputs(x, y, h, "red", t, np.zeros((0, 2)), 0, True))
            if s.phase != "climb":
                break
            x -= share * max(a.linear, 0.0) * 0.05  # the goal (and the robot) come this share
            t += 0.05
        assert (s.phase == "haul_climb") == towed
        assert s._contested == towed and a.clamp


def test_a_goal_the_steal_finds_again_after_searching_is_chased_afresh() -> None:
    """The steal's time on one goal (`goal_chase_s`, then it is left for `busy_s`) counts from
    when the goal was found again: time spent searching after losing sight of it (the robot
    backs onto it blind, another robot drags it away) does not use it up."""
    layout = load_layout()
    c = AllianceConfig()
    s = AllianceStrategy(ROLE_24, layout, c)
    name = "neutral_tall"
    t = 30.0
    s._set_phase("steal", t - 5.0)
    s._steal_dropped = True
    s.goals[name].xy = np.array([-0.5, -1.0])
    s.step(AllianceInputs(-0.9, -0.2, 180.0, "red", t, np.zeros((0, 2)), 0, False))
    assert s.target_goal == name and s.intent != "steal_search"
    # Lost: nothing known, it searches for most of goal_chase_s.
    for b in s.goals.values():
        b.xy = None
    t += c.goal_chase_s - 1.0
    s.step(AllianceInputs(-0.9, -0.2, 180.0, "red", t, np.zeros((0, 2)), 0, False))
    assert s.intent == "steal_search"
    # Found again, past goal_chase_s since it was first chased: still the one it goes for.
    s.goals[name].xy = np.array([-0.5, -1.0])
    for _ in range(3):
        t += 1.0
        s.step(AllianceInputs(-0.9, -0.2, 180.0, "red", t, np.zeros((0, 2)), 0, False))
    assert s.target_goal == name and s._chased.get(name, -math.inf) <= t
    assert s.intent != "steal_search"


def test_a_goal_the_steal_takes_where_it_left_one_is_held_untested() -> None:
    """A chaser standing still with its loaded goal does not pull: the goal tests free and is
    left home, where it stays (its chaser stands still) and the steal comes back for it. A goal
    the steal clamps within `steal_again_m` of where it left one is held as another robot's
    (towed to the stage, no test drive); one clamped elsewhere is tested, and left home when
    it comes along, its place remembered."""
    from jetson.autonomy.alliance import Pose

    layout = load_layout()
    x0, y0, h0 = -1.3, -1.0, 270.0  # by the haul spot, facing the wall, the goal behind
    probe = AllianceStrategy(ROLE_24, layout)
    left_at = probe._clamp_point(Pose(np.array([x0, y0]), h0, 0.0), probe._widest)
    for shift, held in ((0.2, True), (1.0, False)):
        s = AllianceStrategy(ROLE_24, layout)
        t = 40.0
        s._steal_dropped = True
        s._left_at = [left_at + np.array([0.0, shift])]  # a goal it tested free, left there
        s._set_phase("steal", t - 1.0)
        s.holding = s.target_goal = "neutral_south"
        x, y, h = x0, y0, h0
        released = False
        for _ in range(int(10.0 / 0.05)):
            a = s.step(AllianceInputs(x, y, h, "red", t, np.zeros((0, 2)), 0, True))
            if a.clamp is False:
                released = True
                break
            rad = math.radians(h)
            x += a.linear * 0.05 * math.sin(rad)  # the goal comes along at full speed
            y += a.linear * 0.05 * math.cos(rad)
            h = (h + math.degrees(a.angular * 0.05)) % 360.0
            t += 0.05
        assert released != held
        if held:
            assert s._contested and s.phase == "haul_climb" and s._test_to is None
        else:
            assert s._deposited == ["neutral_south"] and len(s._left_at) == 2
    off = AllianceStrategy(ROLE_24, layout, AllianceConfig(steal_again_m=None))
    off._left_at = [left_at]
    assert not off._taken_again(Pose(np.array([x0, y0]), h0, 40.0))
