"""The goal memory: where the mobile goals the robot could score with are (spec.goal_memory).

Dead reckoning from the field's starting layout (spec.prior_goals, alliance frame): when the
clamp closes, the remembered goal nearest the clamp point behind the robot is the one it holds
and leaves the slots; when the clamp opens, the goal stays at the clamp point; a goal whose
place the robot's centre comes within goal_forget_m of cannot be there any more (pushed away)
and is forgotten.

With spec.goal_sight the camera corrects it (the goal detector on the Jetson, sim.goal_sight in
the twin): each fresh result's goals the robot could score with (yellow ones and its alliance's)
move the remembered goal nearest each within goal_sight_merge_m to where it is seen, or join the
memory (a goal pushed somewhere new); a remembered goal within the detector's reach
(goal_sight_fov_deg about the heading, goal_sight_near_m to goal_sight_far_m away) that no
sighting matched is not there and is forgotten.
"""

from __future__ import annotations

import math
from dataclasses import replace

import numpy as np

from jetson.autonomy.geometry import field_to_robot, robot_to_field, to_alliance_frame
from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES
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

    def observe(
        self, view: RobotView, seen_from: tuple[float, float, float] | None = None
    ) -> RobotView:
        """Update the memory with the clamp's state and the robot's pose (and with goal_sight,
        the goals the camera saw from `seen_from`, the field-frame pose the frame was taken at;
        None: the view's pose); return the view with the remembered goals (not the held one) in
        the robot frame."""
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
        if s.goal_sight and view.goals_seen_robot is not None:
            x, y, h_deg = seen_from if seen_from is not None else (view.x, view.y, view.heading_deg)
            at, at_heading = to_alliance_frame((x, y), h_deg, view.alliance)
            assert at_heading is not None
            known = self._by_sight(known, view, at, at_heading)
        self.known = known
        local = field_to_robot(known, pos, heading) if len(known) else np.zeros((0, 2))
        return replace(view, goals_robot_xy=local)

    def _by_sight(
        self, known: np.ndarray, view: RobotView, pos: np.ndarray, heading: float
    ) -> np.ndarray:
        """`known` (alliance frame) corrected by the camera's goals seen from `pos`, `heading`
        (alliance frame) (module docstring)."""
        s = self.spec
        seen = np.asarray(view.goals_seen_robot, dtype=np.float64).reshape(-1, 3)
        ours = {GOAL_COLOUR_CODES["yellow"], GOAL_COLOUR_CODES[view.alliance]}
        seen = seen[[int(c) in ours for c in seen[:, 2]]] if len(seen) else seen
        local = field_to_robot(known, pos, heading) if len(known) else np.zeros((0, 2))
        dist = np.hypot(local[:, 0], local[:, 1])
        bearing = np.degrees(np.abs(np.arctan2(local[:, 0], local[:, 1])))
        in_reach = (bearing <= s.goal_sight_fov_deg / 2) & (dist >= s.goal_sight_near_m)
        in_reach &= dist <= s.goal_sight_far_m
        matched = np.zeros(len(known), dtype=bool)
        found = np.zeros((0, 2))
        if len(seen):
            found = robot_to_field(seen[:, :2], pos, heading)  # the alliance frame, as `known`
            if len(known):
                d = np.linalg.norm(known[:, None, :] - found[None, :, :], axis=2)
                matched = d.min(axis=1) <= s.goal_sight_merge_m
        known = known[~(matched | in_reach)]  # matched ones are replaced by their sighting
        return np.concatenate([known, found]) if len(found) else known
