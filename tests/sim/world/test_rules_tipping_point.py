"""The whole game's scoring (WorldConfig.game = "tipping_point"), one test per example of the VRC
Tipping Point manual (2021-22) and its Q&A that the twin can state, with the field file's point
values (sim/field/tipping_point.toml cites each rule)."""

from __future__ import annotations

import math
from collections.abc import Iterator

import numpy as np
import pytest

from sim.config import world_preset
from sim.world import rules
from sim.world.physics import World
from sim.world.state import DriveCommand, Foul

INCH = 0.0254
RED_PLATFORM = (-60 * INCH, 0.0)
FAR = [(0.0, 1.3), (0.4, 1.3), (-0.4, 1.3), (0.0, -1.3), (0.4, -1.3), (-0.4, -1.3), (0.0, 0.0)]


@pytest.fixture
def game() -> Iterator[World]:
    """A 2v2 whole-game world with no floor rings and no preloads, every goal in the neutral
    zone (scoring nothing), every robot parked on the centre line apart (on no platform)."""
    with World(world_preset("tipping_point_2v2", preloads=False)) as w:
        w.reset(np.random.default_rng(0))
        w.set_floor_rings(np.zeros((0, 2)))
        for i, (x, y) in enumerate(FAR):
            w.place_goal(i, x, y)
        w.place_robot(2, 0.9, -0.5, 0.0)
        w.place_robot(3, 0.9, 0.5, 0.0)
        w.place_robot(0, -0.9, -0.5, 0.0)
        w.place_robot(1, -0.9, 0.5, 0.0)
        yield w


def goal(w: World, name: str) -> int:
    return next(g.index for g in w.goals if g.spec.name == name)


def put_rings(w: World, index: int, low: int = 0, high: int = 0, base: int = 0) -> None:
    g = w.goals[index]
    g.rings, g.rings_high, g.rings_base = low + high + base, high, base


def test_nothing_scored_is_zero(game: World) -> None:
    s = game.score()
    assert s["red"].total == 0 and s["blue"].total == 0


def test_ring_values_high_branch_low_branch_base(game: World) -> None:
    """The scoring table [S]: a ring on a neutral goal's high branch 10, on any other branch 3, in
    a base 1; an alliance goal's rings count for its alliance wherever it ends."""
    red = goal(game, "red_north")
    put_rings(game, red, low=4, base=2)
    tall = goal(game, "neutral_tall")
    put_rings(game, tall, low=2, high=3, base=1)
    zone = game.field.home_zones["red"]
    game.place_goal(tall, zone.x0 + 0.5, 0.9)  # the neutral goal Scored in red's home zone
    s = game.score()["red"]
    assert s.rings == 4 + 2 + 2 + 3 + 1
    assert (s.rings_high, s.rings_low, s.rings_base) == (3, 6, 3)
    assert s.goals_in_zone == 1
    assert s.total == 3 * 10 + 6 * 3 + 3 * 1 + 20


def test_alliance_goal_rings_count_wherever_it_ends(game: World) -> None:
    """Rings on an Alliance Mobile Goal count for its alliance regardless of where it ends: in
    the neutral zone, or in the opponent's home zone (which scores it nothing for either)."""
    blue = goal(game, "blue_south")
    put_rings(game, blue, low=5)
    assert game.score()["blue"].total == 15
    red_zone = game.field.home_zones["red"]
    game.place_goal(blue, red_zone.x0 + 0.5, -0.9)
    s = game.score()
    assert s["blue"].total == 15 and s["blue"].goals_in_zone == 0
    assert s["red"].total == 0


def test_neutral_goal_rings_count_only_in_a_home_zone(game: World) -> None:
    """Rings on a Neutral Mobile Goal count only for the alliance whose Home Zone it ends in."""
    n = goal(game, "neutral_north")
    put_rings(game, n, low=3, high=1)
    assert game.score()["red"].total == 0 and game.score()["blue"].total == 0
    blue_zone = game.field.home_zones["blue"]
    game.place_goal(n, blue_zone.x1 - 0.5, 1.0)
    s = game.score()
    assert s["blue"].total == 3 * 3 + 10 + 20 and s["red"].total == 0


def test_goal_in_home_zone_by_its_base_touching_the_zone(game: World) -> None:
    """A goal is Scored in a Home Zone when any part of its base touches the zone; an alliance
    goal only in its own alliance's zone, a neutral goal in either."""
    zone = game.field.home_zones["red"]
    n = goal(game, "neutral_south")
    rad = game.goals[n].spec.base_radius
    game.place_goal(n, zone.x1 + rad - 0.01, -1.0)  # the base overlaps the line by 1 cm
    assert game.score()["red"].goals_in_zone == 1
    game.place_goal(n, zone.x1 + rad + 0.01, -1.0)
    assert game.score()["red"].goals_in_zone == 0


def test_a_lifted_goal_is_not_scored_in_a_zone() -> None:
    """Q&A: only goals touching a tile (or the platform) count as Scored in a zone; a clamp that
    lifts the goal (RobotConfig.clamp_lifts) keeps it off the tiles until it sets it down."""
    from sim.config import ROBOTS, RobotConfig

    lifting = {n: RobotConfig(**{**rc.__dict__, "clamp_lifts": True}) for n, rc in ROBOTS.items()}
    with World(world_preset("tipping_point_1v1", preloads=False, robots=lifting)) as w:
        w.reset()
        w.set_floor_rings(np.zeros((0, 2)))
        r = w.robots[0]
        gi = goal(w, "red_north")
        g = w.goals[gi]
        assert w.score()["red"].goals_in_zone == 2  # both red goals start in red's zone
        w.place_goal(gi, -1.0, 0.8)
        w.place_robot(0, -1.0, 0.8 + g.spec.base_radius + r.config.length_m / 2 + 0.03, 0.0)
        w.step([DriveCommand(0.0, 0.0), DriveCommand(0.0, 0.0)])
        assert r.carried_goal == gi
        assert rules.goal_owner(w, g) == (None, False)
        assert w.score()["red"].goals_in_zone == 1
        w.step([DriveCommand(0.0, 0.0, clamp=False), DriveCommand(0.0, 0.0)])
        assert g.carried_by is None and w.score()["red"].goals_in_zone == 2


def park(w: World, index: int, dy: float, heading: float = 0.0) -> None:
    w.place_robot(index, RED_PLATFORM[0], RED_PLATFORM[1] + dy, heading)


def test_robot_elevated_on_its_balanced_platform(game: World) -> None:
    """Elevated: contacting its alliance's platform, the platform Balanced, touching nothing
    else: 30 a robot."""
    park(game, 1, 0.3)  # the 15" robot at the hinge
    game.settle_platforms()
    s = game.score()["red"]
    assert s.balanced and s.robots_elevated == 1 and s.total == 30


def test_two_robots_and_a_goal_elevated(game: World) -> None:
    """Both robots side by side on the balanced platform, the 24" robot holding a red goal: two
    Elevated robots (60) and an Elevated goal (40, in Possession of an Elevated robot)."""
    gi = goal(game, "red_south")
    r = game.robots[0]
    g = game.goals[gi]
    game.place_goal(gi, -1.0, -0.9)
    game.place_robot(0, -1.0, -0.9 + g.spec.base_radius + r.config.length_m / 2 + 0.03, 0.0)
    game.step([DriveCommand(), DriveCommand(), DriveCommand(), DriveCommand()])
    assert r.carried_goal == gi
    park(game, 0, -0.3)  # facing along the wall, its goal hanging past the board's end
    park(game, 1, 0.35)
    game.settle_platforms()
    s = game.score()["red"]
    assert s.balanced, game.platforms["red"]
    assert (s.robots_elevated, s.goals_elevated, s.goals_in_zone) == (2, 1, 0)
    assert s.total == 2 * 30 + 40


def test_not_balanced_means_nothing_elevated(game: World) -> None:
    """A platform tipped to one side is not Balanced: the robot on it scores nothing."""
    park(game, 1, 0.3)
    game.set_tilt("red", math.radians(10))
    s = game.score()["red"]
    assert not s.balanced and s.robots_elevated == 0 and s.total == 0


def test_contact_with_the_tiles_is_transitive(game: World) -> None:
    """A goal resting across the board's edge touches the tiles: the platform is not Balanced,
    so the robot on it is not Elevated (the manual's Figure: contact is transitive)."""
    park(game, 1, 0.3)
    n = goal(game, "neutral_south")
    plat = game.field.platform("red")
    game.place_goal(n, plat.center[0] + plat.size[0] / 2, -0.4)  # half on, half off
    game.settle_platforms()
    assert game.score()["red"].robots_elevated == 0
    game.place_goal(n, -0.5, -1.0)
    game.settle_platforms()
    assert game.score()["red"].robots_elevated == 1


def test_goal_resting_on_the_balanced_platform_is_elevated(game: World) -> None:
    park(game, 1, 0.3)
    n = goal(game, "neutral_north")
    put_rings(game, n, low=2)
    game.place_goal(n, RED_PLATFORM[0], -0.3)
    game.settle_platforms()
    s = game.score()["red"]
    assert s.balanced and s.goals_elevated == 1 and s.goals_in_zone == 0
    assert s.total == 30 + 40 + 2 * 3


def test_robot_on_the_wrong_platform_scores_nothing(game: World) -> None:
    """Robots and alliance goals score only on their own alliance's platform."""
    blue = game.field.platform("blue")
    game.place_robot(3, blue.center[0], 0.3, 0.0)  # a blue robot on blue's platform
    game.place_robot(1, blue.center[0], -0.3, 0.0)  # a red robot on it too
    game.settle_platforms()
    s = game.score()
    assert s["red"].robots_elevated == 0
    assert s["blue"].robots_elevated == 1 and s["blue"].total == 30


def test_autonomous_bonus_to_the_alliance_ahead() -> None:
    """The Autonomous Bonus: 20 to the alliance with more points when the period ends."""
    with World(world_preset("tipping_point_2v2", preloads=False, interaction_s=2.0)) as w:
        w.reset()
        w.set_floor_rings(np.zeros((0, 2)))
        put_rings(w, goal(w, "red_north"), low=1)
        idle = [DriveCommand(intake=False)] * 4
        while w.time_s < w.isolation_s - 1e-9:
            w.step(idle)
        assert w.autonomous is not None
        red, blue = w.autonomous["red"], w.autonomous["blue"]
        # Both alliances' goals start in their zones (40 each); red's ring makes it 43.
        assert (red.score, blue.score) == (43, 40)
        assert (red.bonus, blue.bonus) == (20, 0)
        s = w.score()
        assert s["red"].autonomous_bonus == 20 and s["red"].total == 43 + 20


def test_autonomous_tie_splits_the_bonus() -> None:
    """A tie, 0-0 included, gives each alliance half the bonus (10)."""
    with World(world_preset("tipping_point_2v2", preloads=False, interaction_s=2.0)) as w:
        w.reset()
        while not w.over:
            w.step([DriveCommand(intake=False)] * 4)
        assert w.autonomous is not None
        assert w.autonomous["red"].bonus == w.autonomous["blue"].bonus == 10
        s = w.score()
        assert s["red"].total == s["blue"].total == 40 + 10


def test_autonomous_win_point() -> None:
    """The Autonomous Win Point: the AWP line Cleared and a ring Scored on each alliance goal at
    the end of the period; both alliances can earn it, whoever wins the bonus."""
    with World(world_preset("tipping_point_2v2", preloads=False, interaction_s=2.0)) as w:
        w.reset()
        w.set_floor_rings(np.zeros((0, 2)))
        for name in ("red_north", "red_south", "blue_north"):
            put_rings(w, goal(w, name), low=1)
        # Red moves the goal on its AWP line off it (within its zone); blue leaves its own on it.
        south = goal(w, "red_south")
        g = w.goals[south]
        w.place_goal(south, g.x, g.y + 0.4)
        assert rules.awp_line_cleared(w, "red") and not rules.awp_line_cleared(w, "blue")
        while w.time_s < w.isolation_s - 1e-9:
            w.step([DriveCommand(intake=False)] * 4)
        assert w.autonomous is not None
        assert w.autonomous["red"].win_point and not w.autonomous["blue"].win_point
        assert w.score()["red"].autonomous_win_point


def test_awp_line_not_cleared_in_the_neutral_zone(game: World) -> None:
    south = goal(game, "red_south")
    game.place_goal(south, -0.5, -1.0)  # off the line, but its base is in the neutral zone
    assert not rules.awp_line_cleared(game, "red")
    game.place_goal(south, -1.2, -1.0)
    assert rules.awp_line_cleared(game, "red")


def test_isolation_contact_is_a_foul_that_forfeits_the_autonomous_period() -> None:
    """VEX AI: no contact with the other alliance's robots in the isolation period. The robot
    that drove into the other is charged; as <SG4> rules an autonomous violation, its opponent
    gets the Autonomous Bonus and the Win Point."""
    with World(world_preset("tipping_point_2v2", preloads=False, interaction_s=40.0)) as w:
        w.reset()
        w.set_floor_rings(np.zeros((0, 2)))
        w.place_goal(goal(w, "neutral_tall"), 0.0, 1.0)
        w.place_robot(1, -0.4, 0.0, 90.0)  # red's 15" faces blue's 15"
        w.place_robot(3, 0.1, 0.0, 90.0)  # blue's 15", facing away
        commands = [DriveCommand(intake=False)] * 4
        commands[1] = DriveCommand(0.5, intake=False)
        fouls: list[Foul] = []
        while w.time_s < w.isolation_s - 1e-9:
            fouls += w.step(commands).fouls
        assert [(f.robot, f.alliance, f.kind) for f in fouls] == [(1, "red", "isolation_contact")]
        assert w.autonomous is not None
        assert w.autonomous["blue"].bonus == 20 and w.autonomous["blue"].win_point
        assert w.autonomous["red"].bonus == 0 and not w.autonomous["red"].win_point
        s = w.score()
        assert s["red"].fouls == 1 and s["blue"].fouls == 0


def test_platform_protection_credits_an_elevated_robot() -> None:
    """<SG3>: in the last endgame_s seconds a robot may not touch the opposing platform; each
    violation credits the opponent one more Elevated robot (30)."""
    with World(world_preset("tipping_point_2v2", preloads=False, interaction_s=31.0)) as w:
        w.reset()
        w.set_floor_rings(np.zeros((0, 2)))
        blue = w.field.platform("blue")
        edge = blue.center[0] - blue.size[0] / 2
        r = w.robots[1]
        w.place_robot(1, edge - r.config.length_m / 2 - 0.3, 0.0, 90.0)  # red, facing blue's
        commands = [DriveCommand(intake=False)] * 4
        fouls: list[Foul] = []
        # It drives onto blue's platform (its field-side edge starts down) and stays there into
        # the endgame (the last 30 s from 16 s).
        for _ in range(12 * 18):
            commands[1] = DriveCommand(0.3 if w.time_s < 15.5 else 0.0, intake=False)
            fouls += w.step(commands).fouls
        assert [(f.robot, f.kind) for f in fouls] == [(1, "platform_protection")]
        assert fouls[0].time_s >= w.match_length_s - w.field.rules.endgame_s - 1e-9
        s = w.score()
        assert s["blue"].foul_credit == 1
        assert s["blue"].total == s["blue"].goals_in_zone * 20 + 30 + s["blue"].autonomous_bonus
        assert s["red"].fouls == 1
        assert rules.platform_contact_at_end(w) == {"red": False, "blue": False}  # not over
        # Still on blue's platform when the match ends: a violation at the end (<SG3> Note 2,
        # a Disqualification), reported; no second foul for the same contact.
        while not w.over:
            fouls += w.step(commands).fouls
        assert len(fouls) == 1
        assert rules.platform_contact_at_end(w) == {"red": True, "blue": False}


def test_platform_protection_credit_is_bounded_by_two_elevated_robots() -> None:
    """<SG3> (v2.2): each violation credits one additional Elevated robot, and an alliance still
    scores at most two Elevated robots: the credit fills what its own Elevated robots leave."""
    assert rules.platform_credit(1, 0, 2, 2) == 1  # bumped and drove away: one robot
    assert rules.platform_credit(9, 0, 2, 2) == 2  # bumped nine times: still two robots
    assert rules.platform_credit(3, 1, 2, 2) == 1  # one robot up: one more
    assert rules.platform_credit(5, 2, 2, 2) == 0  # both up: nothing to credit
    assert rules.platform_credit(0, 0, 2, 2) == 0
    assert rules.platform_credit(4, 0, 1, 2) == 1  # a 1v1 alliance: its one robot
    assert rules.platform_credit(4, 1, 2, 0) == 4  # elevated_robots_max = 0: no bound


def _blue_platform_fouls(w: World, n: int) -> None:
    for k in range(n):
        w.fouls.append(Foul(w.match_length_s - 20.0 + k, 2, "blue", "platform_protection"))


def test_many_platform_fouls_credit_at_most_two_robots(game: World) -> None:
    """Five <SG3> violations by blue, no red robot Elevated: red is credited two Elevated
    robots (60), not five; the fouls are all counted."""
    _blue_platform_fouls(game, 5)
    s = game.score()
    assert s["red"].foul_credit == 2 and s["red"].total == 60
    assert s["blue"].fouls == 5 and s["blue"].total == 0


def test_platform_fouls_credit_nothing_when_both_robots_are_elevated(game: World) -> None:
    """Both red robots Elevated on their Balanced platform: blue's violations add nothing (the
    alliance already scores its two Elevated robots); one robot Elevated: one more."""
    park(game, 0, -0.3)
    park(game, 1, 0.35)
    game.settle_platforms()
    before = game.score()["red"]
    assert before.robots_elevated == 2
    _blue_platform_fouls(game, 3)
    s = game.score()["red"]
    assert s.foul_credit == 0 and s.total == before.total
    game.place_robot(0, -0.9, -0.5, 0.0)  # the 24" off the platform
    game.settle_platforms()
    s = game.score()["red"]
    assert s.robots_elevated == 1 and s.foul_credit == 1 and s.total == 2 * 30


def test_a_field_may_leave_the_platform_credit_unbounded() -> None:
    """elevated_robots_max = 0 in the field file: every violation credits one robot."""
    from dataclasses import replace

    from sim.field import load_field

    field = load_field()
    field = replace(field, rules=replace(field.rules, elevated_robots_max=0))
    with World(world_preset("tipping_point_2v2", preloads=False), field_spec=field) as w:
        w.reset(np.random.default_rng(0))
        w.set_floor_rings(np.zeros((0, 2)))
        for i, (x, y) in enumerate(FAR):
            w.place_goal(i, x, y)
        _blue_platform_fouls(w, 5)
        assert w.score()["red"].foul_credit == 5


def test_ring_race_is_unchanged_by_the_whole_game_fields() -> None:
    """The ring race (the default) counts every ring as on a branch and ignores the whole
    game's fields (high branch, base, fouls, autonomous)."""
    with World(world_preset("ring_race")) as w:
        w.reset()
        g = w.goals[0]
        g.rings, g.rings_high, g.rings_base = 4, 2, 1
        s = w.score()["red"]
        assert s.rings == 4 and s.total == 4 * 3 + s.goals_in_zone * 20
        assert w.platforms == {} and w.autonomous is None


def test_platform_protection_is_transitive_through_a_robot_on_its_platform() -> None:
    """<SG3>: touching an opposing robot that stands on its own platform in the endgame is
    touching that platform."""
    with World(world_preset("tipping_point_2v2", preloads=False, interaction_s=31.0)) as w:
        w.reset()
        w.set_floor_rings(np.zeros((0, 2)))
        blue = w.field.platform("blue")
        w.place_robot(3, blue.center[0], 0.3, 0.0)  # blue's 15" on its platform
        w.settle_platforms()
        w.place_robot(1, blue.center[0], 0.3 + 0.381 + 0.6, 180.0)  # red's 15", north, off it
        commands = [DriveCommand(intake=False)] * 4
        fouls: list[Foul] = []
        while w.time_s < 15.9:
            fouls += w.step(commands).fouls
        assert fouls == []
        commands[1] = DriveCommand(0.3, intake=False)  # red drives south into blue's robot
        for _ in range(36):
            fouls += w.step(commands).fouls
        assert [(f.robot, f.kind) for f in fouls] == [(1, "platform_protection")]


def test_isolation_home_zone_foul_is_an_option() -> None:
    """<SG4>'s VRC rule (off for VEX AI by default): a robot in the opponent's home zone during
    the isolation period."""
    from dataclasses import replace

    from sim.field import load_field

    field = load_field()
    field = replace(field, rules=replace(field.rules, isolation_home_zone_foul=True))
    with World(world_preset("tipping_point_2v2", preloads=False), field_spec=field) as w:
        w.reset()
        w.set_floor_rings(np.zeros((0, 2)))
        w.place_robot(1, w.field.home_zones["blue"].x0 + 0.3, -0.9, 90.0)
        fouls = w.step([DriveCommand(intake=False)] * 4).fouls
        assert [(f.robot, f.kind) for f in fouls] == [(1, "isolation_home_zone")]
        assert not w.step([DriveCommand(intake=False)] * 4).fouls  # once, as it starts
