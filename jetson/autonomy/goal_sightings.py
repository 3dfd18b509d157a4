"""The goal detector's sightings that can be trusted once the robot's pose is known.

The goal detector (jetson/perception/goals.py) runs on each frame without knowing where the robot
is; what is of a goal's colour and passes its shape tests is a goal to it. A piece of a platform
(red or blue, as the alliance goals are) cut by the image's edge can pass. The decision knows the
pose and the field's layout: a red or blue sighting whose middle lands on either platform's
footprint may be such a piece, so it is dropped before the strategy reads the sightings. A
yellow one is kept: no platform is yellow (`python -m sim.goal_survey` found no false yellow
sighting), and a neutral goal pushed up a board is one the strategy needs to know of (it blocks
the 24"'s lane there, jetson/autonomy/alliance.py).

The layout's platform is the alliance's own, in the alliance frame; the other alliance's is the
same rotated by 180 degrees about the field's centre, so the two footprints are the same pair
in the field frame whichever the alliance.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.field_layout import PlatformLayout
from jetson.autonomy.geometry import robot_to_field
from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES

Vec = NDArray[np.float64]


def off_the_platforms(
    goals_robot: Vec,
    robot_xy: tuple[float, float],
    heading_deg: float,
    platform: PlatformLayout,
    margin_m: float = 0.0,
) -> Vec:
    """The sightings (N, 3: x, y robot frame, colour code) that are yellow or whose field
    position is on neither platform's footprint (grown by `margin_m`), robot at `robot_xy`
    (field frame) facing `heading_deg`."""
    seen = np.asarray(goals_robot, dtype=np.float64).reshape(-1, 3)
    if not len(seen):
        return seen
    xy = robot_to_field(seen[:, :2], robot_xy, heading_deg).tolist()
    on = [platform.either_contains((x, y), margin_m) for x, y in xy]
    yellow = seen[:, 2].astype(int) == GOAL_COLOUR_CODES["yellow"]
    return seen[yellow | ~np.asarray(on, dtype=bool)]
