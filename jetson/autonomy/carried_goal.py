"""Following a goal another robot carries, through the goal detector's sightings (numpy only).

The goal detector (jetson/perception/goals.py, or the twin's sim/goal_sight.py) reports where
goals stand and their colour, not which goal each one is, and no robots. A goal that a robot
carries is told from one standing or pushed aside by how it moves: seen in motion again and
again. The scripted alliance's steal (jetson/autonomy/alliance.py) follows the neutral goal the
other alliance keeps all match this way.

A sighting with no sighting near it 0.3-1.5 s before, and one that far at a carried goal's speed
(`carried_mps` to 1.5 m/s), is a goal in motion. A later sighting within 0.35 m of where the
followed goal was last seen is that goal, moving on or stopped. A goal seen in motion three times
or more over `carried_s` is carried (a goal pushed aside moves once), and stays followed while
it is seen. Nothing counts as in motion while the robot turned more than `steady_deg` in the last
1.5 s: the pose's lag then sweeps what it sees across the field, so standing goals would look
carried.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.geometry import angle_diff_deg

Vec = NDArray[np.float64]

WINDOW_S = 1.5  # sightings this old at most are compared
SAME_GOAL_M = 0.35  # a sighting this near the followed goal's last place is that goal
FORGET_S = 60.0  # a carried goal not seen this long is no longer followed
KEEP_S = 20.0  # a carried goal seen this recently is not replaced by another in motion


@dataclass
class Track:
    """The goal followed (alliance frame)."""

    xy: Vec  # where it was seen last
    seen: float  # when
    first_move: float  # when it was first seen in motion
    last_move: float  # and last
    moves: int = 1  # how many times (0.3 s apart at least)


class CarriedGoalTracker:
    """Follows one goal seen in motion (see the module docstring)."""

    def __init__(self, carried_mps: float, carried_s: float, steady_deg: float = 8.0) -> None:
        self.carried_mps = carried_mps
        self.carried_s = carried_s
        self.steady_deg = steady_deg
        self.reset()

    def reset(self) -> None:
        self.track: Track | None = None
        self._hist: list[tuple[float, Vec]] = []  # (time, where) of the goals seen lately
        self._headings: list[tuple[float, float]] = []  # (time, heading) of the last 1.5 s

    def carried(self, now: float) -> Track | None:
        """The goal followed, if it is carried (seen in motion 3 times or more over
        `carried_s`) and seen in the last minute."""
        tr = self.track
        if (
            tr is not None
            and tr.moves >= 3
            and tr.last_move - tr.first_move >= self.carried_s
            and now - tr.seen < FORGET_S
        ):
            return tr
        return None

    def lost(self, xy: Vec) -> None:
        """The robot looked where a goal was believed, near `xy`, and saw none: a followed goal
        last seen there has gone (it is no longer followed)."""
        tr = self.track
        if tr is not None and float(np.hypot(*(tr.xy - xy))) < SAME_GOAL_M:
            self.track = None

    def observe(self, now: float, heading_deg: float, seen: list[Vec]) -> None:
        """The goals of the colour followed seen at `now` (alliance frame), the robot heading
        `heading_deg`."""
        self._headings = [(t, h) for t, h in self._headings if now - t <= WINDOW_S]
        self._headings.append((now, heading_deg))
        steady = max(abs(angle_diff_deg(h, heading_deg)) for _, h in self._headings)
        steady_ok = steady < self.steady_deg
        hist = [(t, p) for t, p in self._hist if now - t <= WINDOW_S]

        def in_motion(p: Vec) -> bool:
            if not steady_ok:
                return False
            speeds = [float(np.hypot(*(q - p))) / (now - t) for t, q in hist if now - t >= 0.3]
            if not speeds:
                return False
            v = min(speeds)
            return v * 0.3 > 0.06 and self.carried_mps <= v <= 1.5

        tr = self.track
        near = None
        if tr is not None and seen:
            near = min(range(len(seen)), key=lambda k: float(np.hypot(*(seen[k] - tr.xy))))
            if float(np.hypot(*(seen[near] - tr.xy))) >= SAME_GOAL_M:
                near = None
        if tr is not None and near is not None:
            p = seen[near]
            if in_motion(p) and now - tr.last_move >= 0.3:
                tr.last_move, tr.moves = now, tr.moves + 1
            tr.xy, tr.seen = p.copy(), now
        keep = tr is not None and self.carried(now) is not None and now - tr.seen < KEEP_S
        if not keep:
            for k, p in enumerate(seen):
                if k != near and in_motion(p):
                    self.track = Track(p.copy(), now, now, now)
                    break
        self._hist = hist + [(now, p.copy()) for p in seen]
