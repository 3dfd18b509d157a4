"""The ring memory: the rings a robot knows about, seen or remembered (spec.ring_memory).

It starts from the field's starting layout (spec.prior_rings, alliance frame, metres), takes
every ring the camera reports, and forgets a remembered ring once the camera looks at its place
and does not see it, or once the robot takes it (its centre stands on it; with
memory_forget_intake, it is inside the intake's reach; with memory_push, a ring under the rest of
the body is moved out to the body's edge, as a bumper shoves it). Where the camera looks is a
cone around the robot's centre (memory_view "cone") or the camera's own picture ("camera",
given a MemoryCamera). With route_slots it also keeps the route's first stops (route.tour).
The simulator and the Jetson keep one per robot, so a policy sees the same memory on both.
"""

from __future__ import annotations

from dataclasses import replace

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import MemoryCamera
from jetson.autonomy.geometry import (
    field_to_robot,
    push_out_of_box,
    robot_to_field,
    to_alliance_frame,
)
from jetson.autonomy.observation import RobotView, as_points
from jetson.autonomy.route import tour
from jetson.autonomy.spec import ObservationSpec
from jetson.errors import ObservationError


class RingMemory:
    """The rings a robot knows about, in its alliance frame (see the module docstring).

    Fed the camera's rings every control step by observe(); both the simulator and the Jetson
    keep one per robot when spec.ring_memory is on, so a policy sees the same memory on both.
    `camera` is needed when spec.memory_view is "camera".
    """

    def __init__(self, spec: ObservationSpec, camera: MemoryCamera | None = None) -> None:
        if spec.ring_memory and spec.memory_forget_intake and not spec.memory_intake_zone:
            raise ObservationError(
                "memory_forget_intake needs memory_intake_zone (the simulator fills it from the "
                "robot; a saved policy.json carries it)"
            )
        if spec.ring_memory and spec.memory_push and not spec.memory_body:
            raise ObservationError(
                "memory_push needs memory_body (the simulator fills it from the robot; a saved "
                "policy.json carries it)"
            )
        if spec.memory_needs_camera and camera is None:
            raise ObservationError(
                "this spec's ring memory looks through the camera (memory_view = 'camera'): "
                "give RingMemory the camera's mount and intrinsics (MemoryCamera)"
            )
        self.spec = spec
        self.camera = camera
        self.known = np.zeros((0, 2))
        self.target: NDArray[np.float64] | None = None  # the route's first stop, alliance frame
        self.reset()

    def reset(self) -> None:
        """Back to the field's starting layout: a new match."""
        self.known = np.asarray(self.spec.prior_rings, dtype=np.float64).reshape(-1, 2)
        self.target = None

    def observe(
        self, view: RobotView, seen_from: tuple[float, float, float] | None = None
    ) -> RobotView:
        """Update the memory with the view's rings and return the view with the remembered
        rings (known, not in view) added. Nothing changes for a spec without ring_memory.

        `seen_from` is the pose (GPS field frame x, y, heading) the view's rings were seen
        from, when the camera's frame is older than the view's pose: the rings are then given
        in that pose's robot frame, are placed on the field from it, and only rings inside the
        camera's cone *then* can be found missing. Placed from the current pose instead, a
        frame 100 ms old taken while the robot turns at 4 rad/s lands 25 degrees off, matches
        nothing and wipes the memory of every ring it should have confirmed. Without
        ring_memory the rings are only moved into the view's robot frame."""
        if not self.spec.ring_memory:
            if seen_from is None or not len(view.rings_robot_xy):
                return view
            then = robot_to_field(view.rings_robot_xy, seen_from[:2], seen_from[2])
            return replace(
                view, rings_robot_xy=field_to_robot(then, (view.x, view.y), view.heading_deg)
            )
        s = self.spec
        pos, heading = to_alliance_frame((view.x, view.y), view.heading_deg, view.alliance)
        assert heading is not None
        cam_pos, cam_heading = pos, heading
        if seen_from is not None:
            cam_pos, cam_heading = to_alliance_frame(seen_from[:2], seen_from[2], view.alliance)
            assert cam_heading is not None
        seen_local = as_points(view.rings_robot_xy, "rings_robot_xy")
        seen = (
            robot_to_field(seen_local, cam_pos, cam_heading)
            if len(seen_local)
            else np.zeros((0, 2))
        )
        known = self.known
        if len(known):
            local = field_to_robot(known, pos, heading)
            if s.memory_forget_intake:
                x0, x1, y0, y1 = s.memory_intake_zone
                taken = (local[:, 0] >= x0) & (local[:, 0] <= x1)
                taken &= (local[:, 1] >= y0) & (local[:, 1] <= y1)
                if s.memory_push:
                    # Before the view test: a shoved ring is looked for where it now lies.
                    out, moved = push_out_of_box(local, *s.memory_body)
                    moved &= ~taken
                    if moved.any():
                        known = known.copy()
                        known[moved] = robot_to_field(out[moved], pos, heading)
            else:
                # Under the robot: collected, or pushed somewhere the camera will show.
                taken = np.hypot(local[:, 0], local[:, 1]) <= s.memory_forget_m
            cam = field_to_robot(known, cam_pos, cam_heading)
            if self.camera is not None and s.memory_view == "camera":
                in_view, lens_dist = self.camera.locate(cam)
                in_view &= lens_dist <= s.memory_far_m
            else:
                cam_dist = np.hypot(cam[:, 0], cam[:, 1])
                bearing = np.degrees(np.abs(np.arctan2(cam[:, 0], cam[:, 1])))
                in_view = (bearing <= s.memory_fov_deg / 2) & (cam_dist >= s.memory_near_m)
                in_view &= cam_dist <= s.memory_far_m
            matched = np.zeros(len(known), dtype=bool)
            if len(seen):
                d = np.linalg.norm(known[:, None, :] - seen[None, :, :], axis=2)
                matched = d.min(axis=1) <= s.memory_merge_m
            gone = (in_view & ~matched) | taken
            known = known[~gone]
        if len(seen):
            if len(known):
                d = np.linalg.norm(seen[:, None, :] - known[None, :, :], axis=2)
                stale = d.min(axis=0) <= s.memory_merge_m  # replaced by their fresh sighting
                known = known[~stale]
            known = np.concatenate([known, seen])
        self.known = known
        if seen_from is not None and len(seen):
            view = replace(view, rings_robot_xy=field_to_robot(seen, pos, heading))
        view = self._with_route(view, pos, heading)
        return self._with_remembered(view, known[: len(known) - len(seen)], pos, heading)

    def recall(self, view: RobotView) -> RobotView:
        """The view with every known ring as remembered, the memory unchanged: for a step with
        no camera frame (no rings seen is not the same as no picture)."""
        if not self.spec.ring_memory:
            return view
        pos, heading = to_alliance_frame((view.x, view.y), view.heading_deg, view.alliance)
        assert heading is not None
        return self._with_remembered(self._with_route(view, pos, heading), self.known, pos, heading)

    def _with_route(self, view: RobotView, pos: NDArray[np.float64], heading: float) -> RobotView:
        s = self.spec
        if not s.route_slots:
            return view
        known = self.known
        current = None
        if self.target is not None and len(known):
            d = np.linalg.norm(known - self.target, axis=1)
            if d.min() <= s.memory_merge_m:
                current = int(d.argmin())
        # As the planner plans: as many stops as the intake has room for (at least one; a
        # full intake's worth when it never fills).
        room = max(1, s.ring_capacity_norm - view.rings_held * view.intake_fills)
        order = tour(pos, heading, known, room, s.tour, current)
        self.target = known[order[0]].copy() if order else None
        stops = known[order[: s.route_slots]]
        local = field_to_robot(stops, pos, heading) if len(stops) else np.zeros((0, 2))
        return replace(view, route_robot_xy=local)

    @staticmethod
    def _with_remembered(
        view: RobotView, rings: NDArray[np.float64], pos: NDArray[np.float64], heading: float
    ) -> RobotView:
        remembered = field_to_robot(rings, pos, heading) if len(rings) else np.zeros((0, 2))
        return replace(view, rings_remembered_xy=remembered)
