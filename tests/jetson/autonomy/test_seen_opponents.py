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
