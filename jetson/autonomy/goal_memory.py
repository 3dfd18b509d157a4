"""The goal memory: where the mobile goals the robot could score with are (spec.goal_memory).

Nothing on the robot sees goals, so this is dead reckoning from the field's starting layout
(spec.prior_goals, alliance frame): when the clamp closes, the remembered goal nearest the clamp
point behind the robot is the one it holds and leaves the slots; when the clamp opens, the goal
stays at the clamp point; a goal whose place the robot's centre comes within goal_forget_m of
cannot be there any more (pushed away) and is forgotten.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from jetson.autonomy.geometry import field_to_robot, to_alliance_frame
from jetson.autonomy.observation import RobotView
from jetson.autonomy.spec import ObservationSpec


class GoalMemory:
    """Where the mobile goals the robot could score with are believed to be, in its alliance
    frame (see the module docstring). Fed every control step by observe(); the simulator and the
    Jetson keep one per robot when spec.goal_memory is on."""

    def __init__(self, spec: ObservationSpec) -> None:
        self.spec = spec
        self.known = np.zeros((0, 2))
        self.holding = False
        self.reset()

    def reset(self) -> None:
        """Back to the field's starting layout: a new match."""
        self.known = np.asarray(self.spec.prior_goals, dtype=np.float64).reshape(-1, 2)
        self.holding = False

    def observe(self, view: RobotView) -> RobotView:
        """Update the memory with the clamp's state and the robot's pose; return the view with
        the remembered goals (not the held one) in the robot frame."""
        if not self.spec.goal_memory:
            return view
        s = self.spec
        pos, heading = to_alliance_frame((view.x, view.y), view.heading_deg, view.alliance)
        assert heading is not None
        h = math.radians(heading)
        clamp_point = pos - s.goal_clamp_offset_m * np.array([math.sin(h), math.cos(h)])
        known = self.known
        if view.goal_clamped and not self.holding:
            # The goal now held is the remembered one nearest the clamp (if any is near enough to
            # be it: a goal the memory had lost track of may be the one clamped).
            if len(known):
                d = np.hypot(*(known - clamp_point).T)
                i = int(np.argmin(d))
                if d[i] <= 2 * s.goal_forget_m + s.goal_clamp_offset_m:
                    known = np.delete(known, i, axis=0)
        elif self.holding and not view.goal_clamped:
            known = np.concatenate([known, clamp_point[None, :]])
        self.holding = bool(view.goal_clamped)
        if len(known):
            known = known[np.hypot(*(known - pos).T) > s.goal_forget_m]
        self.known = known
        local = field_to_robot(known, pos, heading) if len(known) else np.zeros((0, 2))
        return replace(view, goals_robot_xy=local)
