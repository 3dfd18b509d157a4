"""Observation spec version 6's role_flag: the `tall` scalar tells one network playing both robots
of an alliance which of the two it drives (1 for the 24-inch robot that reaches the high branch),
from the robot's config in the twin and the daemon's [decision] role on the robot."""

from __future__ import annotations

import numpy as np
import pytest

from jetson.autonomy.observation import RobotView, build_frame
from jetson.autonomy.spec import ObservationSpec
from jetson.errors import ObservationError

SPEC = ObservationSpec(version=6, role_flag=True, n_stack=0)


def test_role_flag_needs_version_6_adds_one_scalar_and_changes_the_fingerprint() -> None:
    with pytest.raises(ObservationError, match="role_flag needs observation spec version 6"):
        ObservationSpec(version=5, role_flag=True)
    plain = ObservationSpec(version=6, n_stack=0)
    assert SPEC.size == plain.size + 1 and SPEC.scalars[-1] == "tall"
    assert SPEC.fingerprint() != plain.fingerprint()
    without_key = {k: v for k, v in plain.to_dict().items() if k != "role_flag"}
    assert ObservationSpec.from_dict(without_key).fingerprint() == plain.fingerprint()
    assert "high branch" in SPEC.describe()[SPEC.scalar_index("tall")]


def test_the_frame_says_which_robot_of_the_alliance_it_is() -> None:
    view = RobotView(x=0.0, y=0.0, heading_deg=0.0, alliance="red", time_s=1.0)
    k = SPEC.scalar_index("tall")
    assert build_frame(SPEC, view)[k] == 0.0
    view.tall = True
    assert build_frame(SPEC, view)[k] == 1.0


@pytest.mark.parametrize(("role", "tall"), [("24in", 1.0), ("15in", 0.0)])
def test_the_decision_fills_it_from_the_robots_role(role: str, tall: float) -> None:
    from jetson.decide import Decider, PerceptionInput
    from jetson.settings import DecisionConfig
    from jetson.testing import ProbePolicy
    from protocol.messages import Alliance, GpsStatus, MatchPhase, PoseFix, State

    state = State(
        seq=1, time_ms=0, phase=MatchPhase.AUTONOMOUS, phase_ms=0, alliance=Alliance.BLUE,
        x=0.0, y=0.0, heading=0.0, gps_error=0.01, gps_status=GpsStatus.OK,
        pose_fix=PoseFix.GPS, pose_std=0.01, heading_std=0.5,
    )  # fmt: skip
    policy = ProbePolicy(SPEC)
    policy.keep_observations = True
    Decider(policy, DecisionConfig(role=role)).decide(
        state, PerceptionInput(1, 0.0, np.zeros((0, 2)))
    )
    assert policy.observations[0][SPEC.scalar_index("tall")] == tall
