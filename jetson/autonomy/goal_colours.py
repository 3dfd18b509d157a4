"""The colour codes of the mobile goals' bases, shared by the goal detector and the strategy.

A neutral goal's base is yellow, an alliance goal's its alliance's colour. The goal detector
(jetson/perception/goals.py) and the twin's geometric sighting (sim/goal_sight.py) report each
goal with one of these codes; the scripted alliance (jetson/autonomy/alliance.py) reads them.
The robot detector (jetson/perception/robots.py) codes a robot's alliance by its plate's colour
with the same red and blue. Data only, so perception does not import the strategy to agree with
it.
"""

from __future__ import annotations

GOAL_COLOUR_CODES: dict[str, int] = {"yellow": 0, "red": 1, "blue": 2}
