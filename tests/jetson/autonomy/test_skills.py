"""The skill action space: the controller drives the option the policy scores highest."""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np
import pytest

from jetson.autonomy.observation import PartnerView, RobotView, build_frame
from jetson.autonomy.skills import (
    CLIMB,
    PLATFORM_STAGE_M,
    PLATFORM_STAGGER_M,
    STAGE,
    THERE,
    SkillConfig,
    SkillDriver,
    around,
    leave,
    platform_plan,
    skill_config_from_dict,
)
from jetson.autonomy.spec import ObservationSpec
from sim.errors import ConfigError
from sim.evaluate import eval_env, make_cores, play_match
from sim.match import EnvConfig, make_config
from sim.players import IdlePlayer, PolicyPlayer

SPEC = ObservationSpec(n_stack=0, goal_memory=True, goal_clamp_offset_m=0.35)
SKILLS = SkillConfig(
    ring_options=2, goal_options=2, platform=True, platform_box=(0, -1.5, 0.3, 0.6)
)
RING0, RING1, GOAL0, GOAL1, PLATFORM = range(5)


def frame(
    rings: list[tuple[float, float]] = (),  # type: ignore[assignment]
    goals: list[tuple[float, float]] = (),  # type: ignore[assignment]
    x: float = 0.0,
    y: float = 0.0,
    heading: float = 0.0,
    t: float = 10.0,
    route: list[tuple[float, float]] = (),  # type: ignore[assignment]
    spec: ObservationSpec = SPEC,
) -> np.ndarray:
    view = RobotView(
        x=x,
        y=y,
        heading_deg=heading,
        alliance="red",
        time_s=t,
        rings_robot_xy=np.array(rings, dtype=float).reshape(-1, 2),
        goals_robot_xy=np.array(goals, dtype=float).reshape(-1, 2),
        route_robot_xy=np.array(route, dtype=float).reshape(-1, 2),
    )
    return build_frame(spec, view)


def pick(option: int) -> np.ndarray:
    a = np.full(SKILLS.n_options, -1.0)
    a[option] = 1.0
    return a


def test_options_are_named_in_action_order() -> None:
    assert SKILLS.option_names() == ["ring0", "ring1", "goal0", "goal1", "platform"]
    assert SkillDriver(SKILLS, SPEC).option(pick(GOAL0)) == GOAL0


def test_a_ring_ahead_is_driven_at_and_one_to_the_right_is_turned_to() -> None:
    d = SkillDriver(SKILLS, SPEC)
    v, w = d.command(frame(rings=[(0.0, 1.0)]), pick(RING0))
    assert v == pytest.approx(SKILLS.max_linear_mps) and w == pytest.approx(0.0)
    v, w = d.command(frame(rings=[(0.4, 1.0)]), pick(RING0))
    assert v > 0 and w > 0  # clockwise toward +x (the robot's right)
    # Far off the nose: turn in place first.
    v, w = d.command(frame(rings=[(-1.0, -0.5)]), pick(RING0))
    assert v == 0.0 and w < 0


def test_ring_slots_are_nearest_first_and_ring1_is_the_second() -> None:
    d = SkillDriver(SKILLS, SPEC)
    f = frame(rings=[(0.5, 2.0), (-0.3, 0.6)])
    _, w0 = d.command(f, pick(RING0))
    _, w1 = d.command(f, pick(RING1))
    assert w0 < 0 < w1  # the nearer ring is on the left


def test_an_empty_slot_turns_in_place_looking() -> None:
    v, w = SkillDriver(SKILLS, SPEC).command(frame(rings=[(0.0, 1.0)]), pick(RING1))
    assert v == 0.0 and w > 0


def test_a_goal_is_backed_onto_and_a_far_one_approached_nose_first() -> None:
    d = SkillDriver(SKILLS, SPEC)
    v, w = d.command(frame(goals=[(0.0, -0.6)]), pick(GOAL0))
    assert v < 0 and w == pytest.approx(0.0)
    v, _ = d.command(frame(goals=[(0.0, 2.0)]), pick(GOAL0))
    assert v > 0  # to a point short of it first
    # The second goal slot holds the farther goal.
    _, w = d.command(frame(goals=[(0.0, -0.6), (0.5, -0.6)]), pick(GOAL1))
    assert w != pytest.approx(0.0)


def test_the_platform_is_driven_to_and_the_robot_stops_on_it() -> None:
    d = SkillDriver(SKILLS, SPEC)
    # Facing the platform (south, heading 180) from 1 m north of it: straight on.
    v, w = d.command(frame(x=0.0, y=-0.5, heading=180.0), pick(PLATFORM))
    assert v > 0 and abs(w) < 1e-6
    assert d.command(frame(x=0.0, y=-1.5, heading=90.0), pick(PLATFORM)) == (0.0, 0.0)


# The Tipping Point red platform in the alliance frame (skill_settings): the hinge runs along
# y through x = -1.524, the board 0.61 m deep and 1.27 m long.
BOARD = (-1.524, 0.0, 0.3048, 0.635)
SHARED = SkillConfig(ring_options=0, goal_options=0, platform_box=BOARD, share_platform=True)
ALLIANCE_SPEC = ObservationSpec(version=6, n_stack=0, role_flag=True, partner=True)


def test_two_robots_share_the_platform_each_up_its_own_lane() -> None:
    hinge, edge = BOARD[0], BOARD[0] + BOARD[2]
    # Far away: to the stage in front of the board in its lane, the tall robot's -0.3, the
    # other's +0.4 and farther out (two robots turning at their stages would touch).
    mode, x, y, _ = platform_plan(SHARED, True, 0.0, -1.0, None)
    assert (mode, x, y) == (STAGE, pytest.approx(edge + PLATFORM_STAGE_M), -0.3)
    mode, x, y, _ = platform_plan(SHARED, False, 0.0, 1.0, None)
    assert (mode, y) == (STAGE, 0.4)
    assert x == pytest.approx(edge + PLATFORM_STAGE_M + PLATFORM_STAGGER_M)
    # The partner known: each takes the end of the board on its side of the partner, whatever
    # its role (the 24" north of the 15" takes the north end), so they never cross.
    assert platform_plan(SHARED, True, 0.0, 0.5, (0.0, -0.5))[2] == 0.3
    assert platform_plan(SHARED, False, 0.0, 0.5, (0.0, 0.9))[2] == -0.4
    # In its lane between the stage and the hinge: climb (steering at the lane beyond it),
    # then stop at the hinge; past it, climb back.
    mode, x, y, ahead = platform_plan(SHARED, True, edge + 0.3, -0.28, None)
    assert (mode, y) == (CLIMB, -0.3) and x < hinge and ahead == pytest.approx(0.6048)
    assert platform_plan(SHARED, True, hinge + 0.01, -0.3, None)[0] == THERE
    assert platform_plan(SHARED, True, hinge - 0.1, -0.3, None)[0] == CLIMB
    # Carrying a goal, with platform_past_m: the stop moves past the hinge toward the wall (x
    # below the hinge here), the tall robot's 0.05, the other's 0.15; the hinge is no stop.
    past = replace(SHARED, platform_past_m=(0.05, 0.15))
    assert platform_plan(past, True, hinge + 0.01, -0.3, None, carrying=True)[0] == CLIMB
    assert platform_plan(past, True, hinge - 0.05, -0.3, None, carrying=True)[0] == THERE
    mode, _, _, ahead = platform_plan(past, False, hinge, 0.4, None, carrying=True)
    assert mode == CLIMB and ahead == pytest.approx(0.15)
    assert platform_plan(past, False, hinge - 0.15, 0.4, None, carrying=True)[0] == THERE
    assert platform_plan(past, False, hinge, 0.4, None)[0] == THERE  # no goal: the hinge
    # Without share_platform: the centre, as one robot drives it.
    alone = replace(SHARED, share_platform=False)
    assert platform_plan(alone, True, 0.0, -1.0, None)[:3] == (STAGE, -1.524, 0.0)
    assert platform_plan(alone, True, -1.524, 0.1, None)[0] == THERE


def climbing_frame(x: float, y: float, heading: float, tall: bool) -> np.ndarray:
    # A partner report without a position: the lane is the role's.
    view = RobotView(
        x=x, y=y, heading_deg=heading, alliance="red", time_s=100.0,
        rings_robot_xy=np.zeros((0, 2)), tall=tall,
        partner=PartnerView(xy=None, clamped=False, rings=0, claim_xy=None),
    )  # fmt: skip
    return build_frame(ALLIANCE_SPEC, view)


def test_a_robot_climbs_its_lane_facing_the_wall_and_stops_at_the_hinge() -> None:
    d = SkillDriver(SHARED, ALLIANCE_SPEC)
    platform = np.ones(1)
    # In its lane in front of the board, facing the wall (heading 270): straight up, at the
    # board's speed.
    v, w = d.command(climbing_frame(-0.9, -0.3, 270.0, True), platform)
    assert v == pytest.approx(SHARED.platform_speed_mps) and abs(w) < 1e-6
    # Facing the field: turn to the wall first, in place.
    v, w = d.command(climbing_frame(-0.9, -0.3, 90.0, True), platform)
    assert v == 0.0 and abs(w) > 1.0
    # Near the hinge it slows; at it, it stops; past it, it backs onto it.
    v, _ = d.command(climbing_frame(-1.45, -0.3, 270.0, True), platform)
    assert 0 < v < SHARED.platform_speed_mps
    assert d.command(climbing_frame(-1.53, -0.3, 270.0, True), platform) == (0.0, 0.0)
    v, w = d.command(climbing_frame(-1.6, -0.3, 270.0, True), platform)
    assert v < 0 and w == 0.0
    with pytest.raises(ValueError, match="role flag"):
        SkillDriver(SHARED, ObservationSpec(n_stack=0))


def test_the_rings_nearer_the_partner_are_left_to_it() -> None:
    skills = SkillConfig(ring_options=2, goal_options=0, split_with_partner=True)
    d = SkillDriver(skills, ALLIANCE_SPEC)
    near = [(0.0, 0.8), (1.5, 1.0)]

    def seen(partner_xy: tuple[float, float] | None, rings: list = near) -> np.ndarray:  # type: ignore[type-arg]
        view = RobotView(
            x=0.0, y=0.0, heading_deg=0.0, alliance="red", time_s=30.0,
            rings_robot_xy=np.array(rings),
            partner=PartnerView(xy=partner_xy, clamped=False, rings=0, claim_xy=None),
        )  # fmt: skip
        return build_frame(ALLIANCE_SPEC, view)

    favours_ring0 = np.array([1.0, 0.5, -1.0])
    # The partner stands 0.36 m from ring 0 (0.8 m from this robot): ring 0 is its, ring 1
    # this robot's.
    assert d.option(favours_ring0, seen((-0.2, 1.1))) == 1
    # Nearer the partner, but by less than the margin: still this robot's.
    assert d.option(favours_ring0, seen((0.0, 1.5))) == 0
    # Every ring the partner's: the best of the rest (the platform is nobody's), else the best.
    far = seen((0.75, 1.7), [(0.0, 1.6), (1.5, 1.6)])
    assert d.option(favours_ring0, far) == 2
    rings_only = SkillDriver(replace(skills, platform=False), ALLIANCE_SPEC)
    assert rings_only.option(favours_ring0[:2], far) == 0
    # No partner position, or no observation: the best score.
    assert d.option(favours_ring0, seen(None)) == 0 and d.option(favours_ring0) == 0
    _, w = d.command(seen((-0.2, 1.1)), favours_ring0)  # to ring 1, on the right
    assert w > 0
    with pytest.raises(ValueError, match="partner block"):
        SkillDriver(skills, ObservationSpec(n_stack=0))


def test_with_its_partner_beside_it_a_robot_with_nothing_to_do_backs_away_not_turns() -> None:
    # partner_room_m: a robot turning in place sweeps its corners round; two robots side by side
    # at their platform, both looking for rings, touched every turn.
    skills = SkillConfig(ring_options=2, goal_options=0, partner_room_m=0.8)
    d = SkillDriver(skills, ALLIANCE_SPEC)

    def seen(partner_xy: tuple[float, float] | None) -> np.ndarray:  # type: ignore[type-arg]
        view = RobotView(
            x=0.0, y=0.0, heading_deg=0.0, alliance="red", time_s=30.0,
            rings_robot_xy=np.array([(0.0, 1.0)]),
            partner=PartnerView(xy=partner_xy, clamped=False, rings=0, claim_xy=None),
        )  # fmt: skip
        return build_frame(ALLIANCE_SPEC, view)

    empty = pick_of(skills, 1)  # ring 1: one ring seen, its slot is empty
    v, w = d.command(seen((-0.3, 0.5)), empty)  # ahead, 0.58 m away: back away
    assert v < 0 and w == 0.0
    v, w = d.command(seen((0.4, -0.3)), empty)  # behind: ahead, away from it
    assert v > 0 and w == 0.0
    assert d.command(seen((1.0, 0.5)), empty)[0] == 0.0  # room enough: it turns, looking
    assert d.command(seen((1.0, 0.5)), empty)[1] > 0
    assert d.command(seen(None), empty) == (0.0, 0.3 * d.w_max)  # where the partner is unknown
    off = SkillDriver(replace(skills, partner_room_m=0.0), ALLIANCE_SPEC)
    assert off.command(seen((-0.3, 0.5)), empty) == (0.0, 0.3 * off.w_max)
    v, w = d.command(seen((-0.3, 0.5)), pick_of(skills, 0))  # a ring to drive to: it drives
    assert v > 0
    with pytest.raises(ValueError, match="partner block"):
        SkillDriver(skills, ObservationSpec(n_stack=0, goal_memory=True))


def test_the_endgame_keeps_clear_of_their_platform_and_climbs_at_the_end() -> None:
    """keep_clear_s: late in the match, rings beside the other alliance's platform (SKILLS'
    box turned about the centre: (0, +1.5), 0.3 x 0.6 half extents) are passed over;
    climb_at_s: in the last seconds the platform is driven whatever the action."""
    skills = replace(SKILLS, keep_clear_s=33.0, keep_clear_m=0.4, climb_at_s=20.0)
    d = SkillDriver(skills, SPEC)
    end = SPEC.match_length_s
    # Facing +y from (0, 0.3): ring 0 at (0, 1.0) in the alliance frame, 0.2 m short of the
    # other platform's near edge (y 0.9 .. 2.1); ring 1 at (0.8, 0.3), 0.5 m to its side.
    rings = [(0.0, 0.7), (0.8, 0.0)]
    favours = np.array([1.0, 0.5, -1.0, -1.0, -1.0])
    assert d.option(favours, frame(rings, x=0.0, y=0.3, t=end - 40)) == RING0
    assert d.option(favours, frame(rings, x=0.0, y=0.3, t=end - 30)) == RING1
    # Facing the other way from (0.2, 2.6) behind the board: ring 0 (0.8 m ahead, at y 1.8)
    # is over it; ring 1 (1.4 m to the right, at (-1.2, 2.6)) is clear of it by 0.9 m.
    behind = frame([(0.0, 0.8), (1.4, 0.0)], x=0.2, y=2.6, heading=180.0, t=end - 25)
    assert d.option(favours, behind) == RING1
    # Every ring beside it: the platform (nobody's); 20 s left: the platform, even so.
    then_platform = np.array([1.0, 0.5, -1.0, -1.0, -0.5])
    assert d.option(then_platform, frame([(0.0, 0.7), (0.3, 0.9)], y=0.3, t=end - 25)) == PLATFORM
    assert d.option(favours, frame(rings, y=0.3, t=end - 20)) == PLATFORM
    _, w = d.command(frame(rings, y=0.3, t=end - 20), favours)  # to its own board, behind it
    assert d.target is not None and d.target[0] == "platform" and w != 0
    # Off (the defaults): the best score to the end.
    assert SkillDriver(SKILLS, SPEC).option(favours, frame(rings, y=0.3, t=end - 1)) == RING0
    with pytest.raises(ValueError, match="platform option"):
        SkillDriver(replace(skills, platform=False), SPEC)


def test_the_way_goes_round_their_platform_and_a_robot_beside_it_leaves_straight() -> None:
    """around: a straight way that misses the grown box is kept; one through it goes by the
    field-side corner that makes it shortest. leave: inside the grown box, straight out
    forward or back, never turning; along its side, toward the field's centre."""
    box, m = (1.524, 0.0, 0.305, 0.635), 0.5  # the blue platform seen by red
    assert around(0.0, 1.5, 0.5, -1.5, box, m) == (0.5, -1.5)  # misses the box (x < 0.719)
    x, y = around(0.9, 1.5, 0.9, -1.5, box, m)  # straight through: round its field side
    assert x == pytest.approx(1.524 - 0.805 - 0.05) and abs(y) == pytest.approx(1.185)
    assert around(0.9, 1.5, 0.9, -1.5, box, m)[1] > 0  # the corner on the robot's side first
    assert around(0.5, -0.2, 1.0, 1.6, box, m)[1] > 0  # ... or the shorter way from level
    # Inside the grown box, facing it: reverse; its back to it: forward.
    assert leave(1.0, 0.0, 0.0, 1.0, box, m, 0.5) == (-0.5, 0.0)  # heading +x (sin_h 1)
    assert leave(1.0, 0.0, 0.0, -1.0, box, m, 0.5) == (0.5, 0.0)
    # Along its side (heading +x at y 0.9, beside it): toward the centre, backwards here.
    assert leave(1.4, 0.9, 0.0, 1.0, box, m, 0.5) == (-0.5, 0.0)
    assert leave(0.6, 0.0, 0.0, 1.0, box, m, 0.5) is None  # 0.62 m off: clear
    # The driver in the endgame: facing their platform 0.4 m off, it backs straight away; a
    # ring beyond it is reached round its corner.
    skills = replace(SKILLS, platform_box=(-1.524, 0.0, 0.305, 0.635), keep_clear_s=33.0)
    d = SkillDriver(skills, SPEC)
    end = SPEC.match_length_s
    v, w = d.command(frame([(0.0, 0.5)], x=0.8, y=0.0, heading=90.0, t=end - 20), pick(RING0))
    assert (v, w) == (-0.5 * skills.max_linear_mps, 0.0) and d.target is None
    d.reset()
    far = frame([(0.0, 3.0)], x=0.9, y=-1.5, t=end - 20)  # heading +y, ring at (0.9, 1.5)
    _, w = d.command(far, pick(RING0))
    assert w < 0  # turns left, for the corner at (0.67, -1.19)
    assert SkillDriver(replace(skills, keep_clear_s=0.0), SPEC).command(far, pick(RING0))[1] == 0


def test_a_robot_dragged_by_its_goal_lets_go_and_leaves_the_goals_a_while() -> None:
    """release_dragged_s: clamped, driving ahead (+y) at full speed yet carried sideways (a
    robot of the other alliance holds the goal too and pulls harder): after 2 s of it
    the controller opens the clamp and drives straight ahead for release_dragged_s, then passes
    over the goal options for RELEASED_NO_GOALS_S. Moving as commanded, or not at all (stuck),
    is not being dragged."""
    skills = replace(SKILLS, release_dragged_s=1.0)
    goal_ahead = pick(GOAL0)

    def run(step_xy: tuple[float, float], clamped: bool = True) -> SkillDriver:
        d = SkillDriver(skills, SPEC)
        for k in range(25):  # 2 s at 12 Hz, a ring ahead to drive at (not held)
            view = RobotView(
                x=step_xy[0] * k, y=step_xy[1] * k, heading_deg=0.0, alliance="red",
                time_s=20.0 + k / 12, rings_robot_xy=np.array([[0.0, 2.0]]),
                goals_robot_xy=np.array([[0.0, -1.5]]), goal_clamped=clamped,
            )  # fmt: skip
            d.command(build_frame(SPEC, view), pick(RING0))
        return d

    assert not run((0.0, 1.0 / 12)).release  # moved as told: 1 m/s ahead
    assert not run((0.0, 0.3 / 12)).release  # slower than told (speeding up, or held back)
    assert run((0.0, -0.5 / 12)).release  # 1 m backward while told ahead: dragged
    assert not run((0.0, 0.0)).release  # stuck: not dragged
    assert not run((0.04, 0.0), clamped=False).release  # no goal held: pushed, not dragged
    d = run((0.04, 0.0))  # 0.96 m sideways in 2 s, clamped: dragged
    assert d.release and d.target is None
    later = frame([(0.0, 2.0)], [(0.0, -1.5)], x=1.0, t=22.5)
    assert d.command(later, goal_ahead) == (0.5 * skills.max_linear_mps, 0.0) and d.release
    # Let go (the clamp open): the goal options are passed over for a while, then not.
    assert d.option(goal_ahead, frame([(0.0, 2.0)], [(0.0, -1.5)], t=24.0)) != GOAL0
    d.command(frame([(0.0, 2.0)], [(0.0, -1.5)], t=24.0), goal_ahead)
    assert not d.release
    assert d.option(goal_ahead, frame([(0.0, 2.0)], [(0.0, -1.5)], t=27.5)) == GOAL0
    with pytest.raises(ValueError, match="clamp flag"):
        SkillDriver(replace(skills, goal_options=0), ObservationSpec(n_stack=0))


def test_both_robots_of_an_alliance_end_up_on_their_board_apart() -> None:
    """The twin: both red robots of tipping_point_2v2 drive the platform skill from their starts
    (the other alliance idle), 6 seeded matches of 45 s: in 5 at least, both stand on the board
    at the hinge in their lanes, the board level; they touch each other at most once a match
    on average."""
    spec = replace(ALLIANCE_SPEC, match_length_s=120.0, n_other_robots=3)
    env = eval_env("capped", "training", spec, {"max_steps": 12 * 45}, world="tipping_point_2v2")
    cores = make_cores(env)
    core = cores["duel"]
    skills = replace(SHARED, platform_box=(0.0, -1.5, 0.6, 0.3))  # skill_settings fills it

    def platform(obs: np.ndarray) -> np.ndarray:
        return np.ones(1)

    on_board, touches = 0, 0
    try:
        for seed in range(6):
            red = [PolicyPlayer(platform, "platform", skills) for _ in range(2)]
            record = play_match(cores, red, [IdlePlayer(), IdlePlayer()], seed, "red")
            robots = core.world.robots[:2]
            lanes = sorted(round(r.y, 1) for r in robots)
            at_hinge = all(abs(r.x - BOARD[0]) < 0.1 for r in robots)
            level = abs(core.world.platforms["red"].tilt) < 0.05
            on_board += at_hinge and lanes == [-0.3, 0.4] and level
            touches += record.partner_collisions[0]
    finally:
        for c in cores.values():
            c.close()
    assert on_board >= 5 and touches <= 6, (on_board, touches)


def test_a_robot_that_stops_moving_backs_off() -> None:
    d = SkillDriver(SKILLS, SPEC)
    f_ring = [(0.0, 1.0)]
    out = [d.command(frame(rings=f_ring, t=10.0 + k / 12), pick(RING0)) for k in range(20)]
    assert out[0][0] > 0 and any(v < 0 for v, _ in out)


def test_config_is_checked_against_the_observation() -> None:
    with pytest.raises(ValueError, match="ring options"):
        SkillDriver(SkillConfig(ring_options=20), SPEC)
    with pytest.raises(ValueError, match="goal memory"):
        SkillDriver(SkillConfig(goal_options=1), ObservationSpec(n_stack=0))
    with pytest.raises(ValueError, match="unknown keys"):
        skill_config_from_dict({"ring_options": 2, "laser": True})
    with pytest.raises(ConfigError, match="ring_options"):
        make_config(skills={"ring_options": -1})
    with pytest.raises(ConfigError, match="unknown keys"):
        make_config(skills={"rings": 2})
    with pytest.raises(ConfigError, match="commit_goal_s"):
        make_config(skills={"commit_goal_s": -1.0})
    restored = skill_config_from_dict({"platform_box": [0, -1.5, 0.3, 0.6], "ring_options": 2})
    assert restored.platform_box == (0, -1.5, 0.3, 0.6)


def test_env_config_with_skills_has_one_action_per_option() -> None:
    cfg = make_config(skills={"ring_options": 3, "goal_options": 1})
    assert isinstance(cfg, EnvConfig) and cfg.skills is not None
    assert cfg.action_size == 5
    assert make_config().action_size == 2


def test_a_skill_player_collects_rings_and_takes_a_goal() -> None:
    # A rule in the skill space (nearest ring; a goal once it holds rings and no goal) against
    # an idle opponent: the controller alone must collect rings and clamp a goal.
    spec_env = eval_env(
        "capped",
        "training",
        ObservationSpec(n_stack=0, ring_memory=True, goal_memory=True),
        {"world": {"start_jitter_m": 0.0}, "max_steps": 12 * 25},
    )
    cores = make_cores(spec_env)
    core = cores["duel"]
    spec = core.spec
    skills = SkillConfig(ring_options=2, goal_options=1, platform=False)

    def rule(obs: np.ndarray) -> np.ndarray:
        held, clamped = obs[5] * spec.ring_capacity_norm, obs[6] > 0.5
        return pick_of(skills, 2 if held >= 2 and not clamped else 0)

    try:
        record = play_match(cores, PolicyPlayer(rule, "rule", skills), IdlePlayer(), 7, "red")
        robot = core.world.robots[0]
        assert record.rings[0] >= 4
        assert robot.carried_goal is not None
        assert record.score[0] > record.score[1]
    finally:
        for c in cores.values():
            c.close()


def pick_of(skills: SkillConfig, option: int) -> np.ndarray:
    a = np.zeros(skills.n_options)
    a[option] = 1.0
    return a


def test_skill_commands_match_pure_pursuit_geometry() -> None:
    # A ring 0.2 m ahead and 0.2 m right, inside the 0.3 m lookahead: the arc through it has
    # curvature 2 x / d^2 = 5 per metre. Beyond the lookahead the arc goes through the point
    # 0.3 m along the line to it: 2 sin(45 deg) / 0.3.
    d = SkillDriver(SKILLS, SPEC)
    v, w = d.command(frame(rings=[(0.2, 0.2)]), pick(RING0))
    assert w / v == pytest.approx(5.0, rel=1e-3)
    v, w = d.command(frame(rings=[(0.6, 0.6)]), pick(RING0))
    assert w / v == pytest.approx(2 * math.sin(math.pi / 4) / 0.3, rel=1e-3)
    assert abs(w) <= SKILLS.max_angular_rad_s + 1e-9
    assert math.isfinite(v)


def test_the_gymnasium_env_takes_skill_actions() -> None:
    from gymnasium.utils.env_checker import check_env

    from sim.env import TippingPointEnv

    env = TippingPointEnv(
        skills={"ring_options": 2, "goal_options": 1},
        observation={"n_stack": 0, "ring_memory": True, "goal_memory": True},
        max_steps=24,
    )
    try:
        check_env(env, skip_render_check=True)
        assert env.action_space.shape == (4,)
        env.reset(seed=0)
        start = np.array(env.world.robots[env.agent_index].xy)
        for _ in range(12):
            env.step(np.array([1.0, -1.0, -1.0, -1.0], dtype=np.float32))  # the nearest ring
        moved = np.linalg.norm(np.array(env.world.robots[env.agent_index].xy) - start)
        assert moved > 0.2
    finally:
        env.close()


def test_the_route_option_drives_to_the_routes_first_stop_and_the_teacher_names_it() -> None:
    from jetson.autonomy.skills import option_for

    spec = ObservationSpec(n_stack=0, ring_memory=True, route_slots=1)
    skills = SkillConfig(route_option=True, ring_options=2, goal_options=0, platform=False)
    assert skills.option_names() == ["route", "ring0", "ring1"]
    # The tour starts at the farther ring.
    f = frame(rings=[(-0.3, 0.8), (0.6, 1.5)], route=[(0.6, 1.5)], spec=spec)
    d = SkillDriver(skills, spec)
    _, w_route = d.command(f, np.array([1.0, 0.0, 0.0]))
    _, w_ring0 = d.command(f, np.array([0.0, 1.0, 0.0]))
    assert w_route > 0 > w_ring0
    assert option_for("ring", np.array([0.6, 1.5]), f, spec, skills) == 0
    assert option_for("ring", np.array([-0.3, 0.8]), f, spec, skills) == 1
    assert option_for("ring", np.array([2.0, 2.0]), f, spec, skills) is None
    with pytest.raises(ValueError, match="route slots"):
        SkillDriver(skills, ObservationSpec(n_stack=0))


def test_the_route_can_be_driven_through_its_next_stop_as_the_planner_drives() -> None:
    spec = ObservationSpec(n_stack=0, ring_memory=True, route_slots=2)
    plain = SkillConfig(route_option=True, ring_options=0, goal_options=0, platform=False)
    through = replace(plain, route_through_next=True)
    go = np.array([1.0])
    # The first stop just ahead, the next one to the right: onto the first stop alone the robot
    # drives straight; through it, it is already curving right for the next.
    f = frame(route=[(0.0, 0.2), (1.0, 0.2)], spec=spec)
    v_plain, w_plain = SkillDriver(plain, spec).command(f, go)
    v_through, w_through = SkillDriver(through, spec).command(f, go)
    assert w_plain == pytest.approx(0.0) and v_plain > 0.9
    assert w_through > 2.0 and v_through > 0.5
    # Without a second stop it drives as it did.
    g = frame(route=[(0.3, 1.0)], spec=spec)
    assert SkillDriver(through, spec).command(g, go) == SkillDriver(plain, spec).command(g, go)
    with pytest.raises(ValueError, match="2 route slots"):
        SkillDriver(through, ObservationSpec(n_stack=0, ring_memory=True, route_slots=1))


# With the intake flag (spec 5) the clamp is no longer the last scalar.
@pytest.mark.parametrize("spec", [SPEC, replace(SPEC, version=5, intake_flag=True)])
def test_a_committed_goal_manoeuvre_ignores_the_policy_until_the_clamp_closes(
    spec: ObservationSpec,
) -> None:
    skills = SkillConfig(ring_options=2, goal_options=2, platform=True, commit_goal_s=3.0)
    d = SkillDriver(skills, spec)
    f = frame(rings=[(0.0, 1.0)], goals=[(0.0, -0.6)], t=10.0, spec=spec)
    assert not d.committed(f)
    v, _ = d.command(f, pick(GOAL0))
    assert v < 0 and d.committed(f)
    # The policy now asks for the ring ahead: ignored, the robot keeps reversing to the goal,
    # which stays where it was in the field as the robot moves (0.1 m closer).
    f2 = frame(rings=[(0.0, 1.0)], goals=[(0.0, -0.5)], y=-0.1, t=10.5, spec=spec)
    v, w = d.command(f2, pick(RING0))
    assert v < 0 and w == pytest.approx(0.0, abs=1e-6)
    # The clamp closes: the next action decides again.
    view = RobotView(x=0.0, y=-0.6, heading_deg=0.0, alliance="red", time_s=11.0,
                     rings_robot_xy=np.array([[0.0, 1.6]]), goal_clamped=True)  # fmt: skip
    f3 = build_frame(spec, view)
    assert not d.committed(f3)
    v, _ = d.command(f3, pick(RING0))
    assert v > 0
    # Or its time runs out.
    d.command(f, pick(GOAL1 - 1))
    assert d.committed(frame(t=12.9, spec=spec)) and not d.committed(frame(t=13.1, spec=spec))
