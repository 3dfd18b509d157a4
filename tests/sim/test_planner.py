"""sim.baselines.planner: pure pursuit geometry, tour ordering, and the baseline collecting."""

from __future__ import annotations

import itertools

import numpy as np
import pytest

from jetson.autonomy.route import two_opt
from jetson.autonomy.skills import pursuit_point
from sim.baselines.planner import Planner, PlannerConfig
from sim.match import MatchCore, make_config
from sim.world.state import RING_FLOOR


def test_pursuit_point_is_on_the_path_at_the_lookahead() -> None:
    # Straight ahead, far: the point 0.3 m ahead.
    assert pursuit_point(np.array([[0.0, 2.0]]), 0.3) == pytest.approx((0.0, 0.3))
    # A path that turns: the circle meets the second leg.
    px, py = pursuit_point(np.array([[0.0, 0.2], [1.0, 0.2]]), 0.5)
    assert np.hypot(px, py) == pytest.approx(0.5) and py == pytest.approx(0.2)
    # The whole path inside the circle: its end.
    assert pursuit_point(np.array([[0.1, 0.1]]), 0.5) == pytest.approx((0.1, 0.1))


def test_two_opt_uncrosses_a_tour() -> None:
    pts = np.array([[0, 0], [1, 1], [1, 0], [0, 1], [0, 2]], dtype=float)
    pair = np.linalg.norm(pts[:, None] - pts[None], axis=2)
    crossed = [0, 1, 2, 3, 4]
    better = two_opt(crossed, pair, fixed_first=True)

    def length(order: list[int]) -> float:
        return float(sum(pair[a, b] for a, b in itertools.pairwise(order)))

    assert better[0] == 0 and sorted(better) == crossed
    assert length(better) < length(crossed) - 0.5


def _solo(seed: int = 0) -> MatchCore:
    cfg = make_config(world={"start_jitter_m": 0.1, "start_jitter_deg": 10.0, "blue": []})
    core = MatchCore(cfg)
    core.reset(np.random.default_rng(seed))
    return core


@pytest.mark.parametrize("strategy", ["route", "nearest"])
def test_planner_fills_ten_rings_fast(strategy: str) -> None:
    core = _solo(3)
    planner = Planner(PlannerConfig(strategy=strategy))
    planner.reset(core, 0)
    robot = core.world.robots[0]
    try:
        while robot.collected < 10 and core.world.time_s < 20.0:
            core.step([planner.act(core, 0)])
        assert robot.collected >= 10
        assert core.world.time_s < 8.0, "the two stars near the start: a few seconds"
    finally:
        core.close()


def test_planner_forgets_rings_it_sees_are_gone() -> None:
    core = _solo(0)
    planner = Planner()
    planner.reset(core, 0)
    try:
        known = len(planner.known)
        assert known == len(core.world.field.ring_positions), "starts from the field layout"
        core.world.set_floor_rings(np.zeros((0, 2)))  # every ring vanishes
        for _ in range(24):
            core.step([planner.act(core, 0)])
        assert len(planner.known) < known - 3, "what the camera looked at was forgotten"
        no_prior = Planner(PlannerConfig(prior=False))
        no_prior.reset(core, 0)
        cmd = no_prior.act(core, 0)
        assert cmd.linear == 0.0 and cmd.angular != 0.0, "nothing known: look around"
    finally:
        core.close()


def test_planner_clamps_a_goal_when_full_and_scores_it() -> None:
    core = _solo(1)
    planner = Planner()
    planner.reset(core, 0)
    world = core.world
    try:
        while world.time_s < 40.0:
            core.step([planner.act(core, 0)])
        robot = world.robots[0]
        assert robot.collected > 10, "past the 10-ring intake: rings went onto a goal"
        assert robot.carried_goal is not None
        assert world.score()["red"].rings > 0
        assert int((world.ring_state == RING_FLOOR).sum()) < 42 - 10
    finally:
        core.close()


def test_bad_planner_config_is_named() -> None:
    with pytest.raises(ValueError, match="strategy"):
        PlannerConfig(strategy="teleport")  # type: ignore[arg-type]
