"""Following a goal another robot carries (jetson/autonomy/carried_goal.py): motion seen again
and again is carried, a goal pushed once is not, and nothing moves while the robot turns."""

from __future__ import annotations

import numpy as np

from jetson.autonomy.carried_goal import CarriedGoalTracker


def run(tracker: CarriedGoalTracker, steps: int, heading_step: float) -> float:
    """A goal moving 0.25 m per 0.5 s along -y while a standing goal stays at (0, 1); the robot's
    heading changes `heading_step` degrees a sighting. Returns the last time."""
    p = np.array([0.5, 1.0])
    t, h = 10.0, 90.0
    for _ in range(steps):
        tracker.observe(t, h, [np.array([0.0, 1.0]), p.copy()])
        p = p + np.array([0.0, -0.25])
        t += 0.5
        h += heading_step
    return t - 0.5


def test_a_goal_seen_in_motion_again_and_again_is_carried_and_followed() -> None:
    tr = CarriedGoalTracker(carried_mps=0.25, carried_s=1.5)
    t = run(tr, 8, 0.0)
    carried = tr.carried(t)
    assert carried is not None
    assert np.allclose(carried.xy, [0.5, 1.0 - 0.25 * 7])
    assert tr.carried(t + 61.0) is None  # not seen for a minute: no longer followed


def test_a_goal_pushed_once_is_not_carried() -> None:
    tr = CarriedGoalTracker(carried_mps=0.25, carried_s=1.5)
    run(tr, 2, 0.0)  # one move
    t = 11.0
    for k in range(6):  # then it stands
        tr.observe(t + 0.5 * k, 90.0, [np.array([0.0, 1.0]), np.array([0.5, 0.75])])
    assert tr.track is not None and tr.carried(t + 2.5) is None


def test_nothing_moves_while_the_robot_turns() -> None:
    tr = CarriedGoalTracker(carried_mps=0.25, carried_s=1.5)
    t = run(tr, 8, 10.0)  # 10 degrees a sighting: never steady
    assert tr.track is None and tr.carried(t) is None


def test_a_followed_goal_looked_for_and_not_seen_is_dropped() -> None:
    """The robot looked where the followed goal was last seen and saw none: it is no longer
    followed (else the steal would go back to that spot until the track is a minute old); a
    look elsewhere leaves it alone."""
    tr = CarriedGoalTracker(carried_mps=0.25, carried_s=1.5)
    t = run(tr, 8, 0.0)
    last = tr.carried(t)
    assert last is not None
    tr.lost(last.xy + np.array([1.0, 0.0]))
    assert tr.carried(t) is not None
    tr.lost(last.xy + np.array([0.1, 0.0]))
    assert tr.track is None and tr.carried(t) is None
