"""The shortcuts a control step takes give exactly what the long way gives: one heading's vector,
one pose in the alliance frame, the frame of no points, a score that judges each robot and
platform once, the step's one score in every robot's info, each spec's frame layout."""

from __future__ import annotations

from collections.abc import Iterator

import numpy as np
import pytest

from jetson.autonomy.geometry import (
    field_to_robot,
    heading_sin_cos,
    heading_vector,
    pose_to_alliance_frame,
    to_alliance_frame,
)
from jetson.autonomy.observation import RobotView, build_frame
from jetson.autonomy.spec import ObservationSpec
from sim.baselines.scripted import GreedyChaser
from sim.config import world_preset
from sim.match import EnvConfig, MatchCore
from sim.players import ScriptedPlayer
from sim.world import rules
from sim.world.physics import World
from sim.world.state import AllianceScore, DriveCommand

INCH = 0.0254
HEADINGS = [0.0, -0.0, 90.0, 180.0, 359.999, 360.0, -45.0, 1e6, 7, True]


def _headings() -> list[float]:
    rng = np.random.default_rng(3)
    return HEADINGS + [float(h) for h in rng.uniform(-720.0, 720.0, 2000)]


def test_one_headings_vector_is_the_arrays_formula_to_the_bit() -> None:
    for h in _headings():
        r = np.radians(np.asarray(h, dtype=np.float64))
        want = np.stack([np.sin(r), np.cos(r)], axis=-1)
        got = heading_vector(h)
        assert got.shape == (2,) and got.dtype == np.float64
        assert got.tobytes() == want.tobytes(), h
        assert np.array(heading_sin_cos(h)).tobytes() == want.tobytes(), h


def test_pose_to_alliance_frame_is_to_alliance_frame() -> None:
    rng = np.random.default_rng(4)
    for alliance in ("red", "blue"):
        for x, y, h in zip(*rng.uniform(-2.0, 2.0, (2, 500)), _headings(), strict=False):
            xy, heading = to_alliance_frame((x, y), h, alliance)
            got = pose_to_alliance_frame(x, y, h, alliance)
            assert got == (float(xy[0]), float(xy[1]), heading)
    with pytest.raises(ValueError, match="green"):
        pose_to_alliance_frame(0.0, 0.0, 0.0, "green")  # type: ignore[arg-type]


def test_no_points_in_the_robot_frame_are_no_points() -> None:
    out = field_to_robot(np.zeros((0, 2)), (0.3, -0.2), 40.0)
    assert out.shape == (0, 2) and out.dtype == np.float64
    one = field_to_robot(np.array([[1.0, 0.0]]), (0.0, 0.0), 90.0)  # straight ahead, 1 m
    assert one == pytest.approx(np.array([[0.0, 1.0]]))


def _score_the_long_way(w: World) -> dict[str, tuple[int, ...]]:
    """Each alliance's rings, goals in its zone, goals and robots elevated and Balanced, from the
    public rules asked once per alliance and goal, as the score once asked them."""
    out = {}
    for a in rules.ALLIANCES:
        rings = in_zone = up = 0
        for g in w.goals:
            owner, elevated = rules.goal_owner(w, g)
            if g.spec.alliance == a or (g.spec.alliance is None and owner == a):
                rings += g.rings
            if owner == a:
                up += elevated
                in_zone += not elevated
        robots = sum(1 for r in w.robots if r.alliance == a and rules.robot_elevated(w, r))
        balanced = a in w.platforms and rules.platform_balanced(w, a)
        out[a] = (rings, in_zone, up, robots, int(balanced))
    return out


def _score_tuple(s: dict[str, AllianceScore]) -> dict[str, tuple[int, ...]]:
    return {
        a: (x.rings, x.goals_in_zone, x.goals_elevated, x.robots_elevated, int(x.balanced))
        for a, x in s.items()
    }


@pytest.fixture
def elevated() -> Iterator[World]:
    """Red's two robots on its Balanced platform, the 24" one holding a red goal; a neutral goal
    with rings in blue's zone."""
    with World(world_preset("tipping_point_2v2", preloads=False)) as w:
        w.reset(np.random.default_rng(0))
        w.set_floor_rings(np.zeros((0, 2)))
        g = next(g for g in w.goals if g.spec.name == "red_south")
        r = w.robots[0]
        w.place_goal(g.index, -1.0, -0.9)
        w.place_robot(0, -1.0, -0.9 + g.spec.base_radius + r.config.length_m / 2 + 0.03, 0.0)
        w.place_robot(2, 0.9, -0.5, 0.0)
        w.place_robot(3, 0.9, 0.5, 0.0)
        w.step([DriveCommand() for _ in w.robots])
        assert r.carried_goal == g.index
        w.place_robot(0, -60 * INCH, -0.3, 0.0)
        w.place_robot(1, -60 * INCH, 0.35, 0.0)
        n = next(g for g in w.goals if g.spec.name == "neutral_north")
        n.rings = 3
        w.place_goal(n.index, 1.3, 1.0)
        w.settle_platforms()
        yield w


def test_the_score_judges_as_the_per_goal_rules_do(elevated: World) -> None:
    w = elevated
    s = w.score()
    assert s["red"].robots_elevated == 2 and s["red"].goals_elevated == 1
    assert _score_tuple(s) == _score_the_long_way(w)
    w.place_robot(0, -0.9, -0.5, 0.0)  # the 24" robot and its goal off: the 15" one stays up
    w.settle_platforms()
    s = w.score()
    assert s["red"].robots_elevated == 1 and s["red"].goals_elevated == 0
    assert _score_tuple(s) == _score_the_long_way(w)
    w.set_tilt("red", np.radians(10.0))  # no longer Balanced: nobody elevated
    s = w.score()
    assert s["red"].robots_elevated == 0 and not s["red"].balanced
    assert _score_tuple(s) == _score_the_long_way(w)


def test_the_score_judges_as_the_per_goal_rules_do_through_a_played_match() -> None:
    with World(world_preset("tipping_point_2v2")) as w:
        w.reset(np.random.default_rng(5))
        bots = [GreedyChaser(i) for i in range(len(w.robots))]
        while not w.over:
            w.step([b.act(w) for b in bots])
            if w.steps % 7 == 0:
                assert _score_tuple(w.score()) == _score_the_long_way(w), w.steps
        assert any(g.rings for g in w.goals), "the match must score something"


def test_every_robots_info_carries_the_steps_score() -> None:
    core = MatchCore(EnvConfig(world=world_preset("tipping_point_2v2"), end_on_pin=False))
    try:
        obs = core.reset(np.random.default_rng(1))
        players = [ScriptedPlayer() for _ in range(core.n_robots)]
        for i, p in enumerate(players):
            p.reset(core, i, np.random.default_rng((1, i)))
        for _ in range(240):
            results, _, _ = core.step([p.act(core, i, obs[i]) for i, p in enumerate(players)])
            obs = [r.observation for r in results]
            for i, r in enumerate(results):
                alone = core.info(i)
                assert r.info["reward_components"] == r.components
                alone["reward_components"] = r.components
                assert r.info == alone
        assert core.info(0)["score_red"] + core.info(0)["score_blue"] > 0
    finally:
        core.close()


def test_each_spec_gets_its_own_frame_layout() -> None:
    small = ObservationSpec(n_rings=3, n_other_robots=1)
    wide = ObservationSpec(n_rings=8, goal_memory=True, n_goals=2, intake_flag=True)
    view = RobotView(
        x=0.5,
        y=-0.25,
        heading_deg=30.0,
        alliance="red",
        time_s=1.0,
        rings_robot_xy=np.array([[0.0, 1.0]]),
        goal_clamped=True,
        goals_robot_xy=np.array([[0.0, -0.5]]),
        intake_fills=False,
    )
    for _ in range(3):  # in turn: neither spec's layout is taken for the other's
        for spec in (small, wide):
            f = build_frame(spec, view)
            assert f.shape == (spec.frame_size,)
            ring = spec.ring_offset
            assert f[ring : ring + 3] == pytest.approx([0.0, 1.0 / spec.length_unit_m, 1.0])
            if spec.goal_memory:
                assert f[spec.scalar_index("clamped")] == 1.0
                assert f[spec.scalar_index("fills")] == 0.0
                goal = spec.goal_offset
                assert f[goal : goal + 3] == pytest.approx([0.0, -0.5 / spec.length_unit_m, 1.0])
