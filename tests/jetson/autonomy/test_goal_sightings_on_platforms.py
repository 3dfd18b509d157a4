"""Red and blue goal sightings on a platform's footprint are dropped once the pose is known
(jetson/autonomy/goal_sightings.py): both alliances' platforms, from either alliance's robot, and
nothing else; yellow ones are kept (no platform is yellow)."""

from __future__ import annotations

import numpy as np

from jetson.autonomy.field_layout import load_layout
from jetson.autonomy.geometry import field_to_robot
from jetson.autonomy.goal_sightings import off_the_platforms

LAYOUT = load_layout()
PLAT = LAYOUT.platform  # red's, in the field frame too: x -1.524, 2 ft deep, 50 in long


def sightings(
    field_xy: list[tuple[float, float]],
    robot: tuple[float, float],
    heading: float,
    codes: list[int] | None = None,
):
    local = field_to_robot(np.array(field_xy, dtype=np.float64), robot, heading)
    if codes is None:
        codes = [1 + k % 2 for k in range(len(field_xy))]  # red, blue, red...
    return np.column_stack([local, np.asarray(codes, dtype=np.float64)])


def test_red_and_blue_sightings_on_either_platform_are_dropped() -> None:
    robot, heading = (0.3, -0.2), 250.0
    field_xy = [
        (-1.40, 0.30),  # on red's board
        (1.60, -0.50),  # on blue's
        (-1.15, 0.30),  # in front of red's board, off it
        (0.0, 0.9),  # a neutral goal's spot
        (-1.52, 0.91),  # red_north's start, beside the board's end
    ]
    seen = sightings(field_xy, robot, heading)
    kept = off_the_platforms(seen, robot, heading, PLAT)
    np.testing.assert_allclose(kept, seen[2:])
    # A margin grows the footprints.
    assert len(off_the_platforms(seen, robot, heading, PLAT, margin_m=0.1)) == 2


def test_yellow_sightings_on_a_platform_are_kept() -> None:
    """A neutral goal pushed up a board (no platform is yellow): kept, on either board."""
    robot, heading = (0.3, -0.2), 250.0
    field_xy = [(-1.66, -0.1), (1.60, -0.50), (-1.40, 0.30)]
    seen = sightings(field_xy, robot, heading, codes=[0, 0, 1])
    np.testing.assert_allclose(off_the_platforms(seen, robot, heading, PLAT), seen[:2])


def test_none_and_no_sightings() -> None:
    assert off_the_platforms(np.zeros((0, 3)), (0.0, 0.0), 0.0, PLAT).shape == (0, 3)
    seen = sightings([(0.5, 0.5)], (0.0, 0.0), 90.0)
    np.testing.assert_array_equal(off_the_platforms(seen, (0.0, 0.0), 90.0, PLAT), seen)
