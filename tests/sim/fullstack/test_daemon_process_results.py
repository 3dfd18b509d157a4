"""A camera result crosses from the daemon's process to the simulator's as one JSON row of a
turn's answer (sim/fullstack/daemon_process.py): the rings, the error and the goals the daemon's
goal detector and the robots its robot detector saw come back as they went."""

from __future__ import annotations

import json

import numpy as np

from jetson.camera_feed import Perceived
from sim.fullstack.daemon_process import result_of_row, result_row


def round_trip(index: int, p: Perceived) -> tuple[int, Perceived]:
    return result_of_row(json.loads(json.dumps(result_row(index, p))))


def test_a_result_with_goals_comes_back_whole() -> None:
    goals = np.array([[0.25, 1.5, 0.0], [-0.4, 2.1, 2.0]])
    robots = np.array([[0.6, 1.1, 2.0]])
    sent = Perceived(
        7, 12.5, np.array([[0.1, 0.6], [0.3, 0.9]]), 31, goals_robot=goals, robots_robot=robots
    )
    index, got = round_trip(40, sent)
    assert index == 40 and (got.id, got.stamp_s, got.frame_index, got.error) == (7, 12.5, 31, None)
    np.testing.assert_array_equal(got.rings_robot_xy, sent.rings_robot_xy)
    np.testing.assert_array_equal(got.goals_robot, goals)
    np.testing.assert_array_equal(got.robots_robot, robots)


def test_a_result_without_goals_or_rings_keeps_their_shapes() -> None:
    sent = Perceived(3, 1.0, np.zeros((0, 2)), 2, error="RuntimeError: no frame")
    _, got = round_trip(5, sent)
    assert got.rings_robot_xy.shape == (0, 2) and got.goals_robot.shape == (0, 3)
    assert got.robots_robot.shape == (0, 3)
    assert got.error == "RuntimeError: no frame"
