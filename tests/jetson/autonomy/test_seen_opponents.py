"""Observation spec version 6's seen_opponents: the other robots' slots hold the opponents the
camera sees (the robot detector's), and the decision fills them from a fresh camera result."""

from __future__ import annotations

import numpy as np
import pytest

from jetson.autonomy.spec import ObservationSpec
from jetson.errors import ObservationError

SPEC = ObservationSpec(version=6, n_other_robots=2, seen_opponents=True, n_stack=0)


def test_seen_opponents_needs_version_6_and_slots_and_changes_the_fingerprint() -> None:
    with pytest.raises(ObservationError, match="seen_opponents needs"):
        ObservationSpec(version=5, n_other_robots=2, seen_opponents=True)
    with pytest.raises(ObservationError, match="n_other_robots >= 1"):
        ObservationSpec(version=6, seen_opponents=True)
    every = ObservationSpec(version=6, n_other_robots=2, n_stack=0)
    assert SPEC.fingerprint() != every.fingerprint() and SPEC.size == every.size
    without_key = {k: v for k, v in every.to_dict().items() if k != "seen_opponents"}
    assert ObservationSpec.from_dict(without_key).fingerprint() == every.fingerprint()
    lines = SPEC.describe()
    assert "opponent the camera sees" in lines[len(SPEC.scalars)]
    assert "other robot" in every.describe()[len(every.scalars)]
    assert np.array_equal(SPEC.frame_names(), every.frame_names())


def test_the_decision_fills_the_slots_with_fresh_opponents_only() -> None:
    from jetson.decide import Decider, PerceptionInput
    from jetson.perception.robots import ROBOT_ALLIANCE_CODES
    from jetson.testing import ProbePolicy
    from protocol.messages import Alliance, GpsStatus, MatchPhase, PoseFix, State

    def state(t_ms: int, alliance: Alliance = Alliance.RED) -> State:
        return State(
            seq=t_ms // 20 + 1, time_ms=t_ms, phase=MatchPhase.AUTONOMOUS, phase_ms=t_ms,
            alliance=alliance, x=0.0, y=0.0, heading=0.0, gps_error=0.01,
            gps_status=GpsStatus.OK, pose_fix=PoseFix.GPS, pose_std=0.01, heading_std=0.5,
        )  # fmt: skip

    red, blue = ROBOT_ALLIANCE_CODES["red"], ROBOT_ALLIANCE_CODES["blue"]
    # Our partner (red) 0.8 m ahead, blue robots 1.5 m ahead-left and 1.0 m ahead-right.
    robots = np.array([[0.0, 0.8, red], [-0.5, 1.5, blue], [0.6, 1.0, blue]])
    seen = PerceptionInput(1, 0.05, np.zeros((0, 2)), robots_robot=robots)
    policy = ProbePolicy(SPEC)
    policy.keep_observations = True
    d = Decider(policy)
    d.decide(state(0), seen)
    d.decide(state(100), PerceptionInput(2, 1.0, np.zeros((0, 2)), robots_robot=robots))  # stale
    d.decide(state(200, Alliance.BLUE), seen)  # as blue: the red one is the opponent
    lo, unit = len(SPEC.scalars), SPEC.length_unit_m
    fresh, stale, as_blue = (o[lo : lo + 6] for o in policy.observations)
    assert np.allclose(fresh, [0.6 / unit, 1.0 / unit, 1.0, -0.5 / unit, 1.5 / unit, 1.0])
    assert not stale.any()
    assert np.allclose(as_blue, [0.0, 0.8 / unit, 1.0, 0.0, 0.0, 0.0])
    # A policy whose slots hold every robot (no seen_opponents) is not given the camera's.
    every = ProbePolicy(ObservationSpec(version=6, n_other_robots=2, n_stack=0))
    every.keep_observations = True
    Decider(every).decide(state(0), seen)
    assert not every.observations[0][lo : lo + 6].any()
