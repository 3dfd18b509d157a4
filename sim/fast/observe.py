"""Observations of every robot of every match in a FastWorld, as the robot's spec lays them out.

    obs = FastObserver(world, spec, obs_noise=True, gps_noise=True, rng=rng)
    stacked = obs.reset()                      # (B, R, spec.size) float32, after world.reset
    stacked = obs.push()                       # after each world.step

What MatchCore.view and jetson.autonomy.observation.build_frame do for one robot, done for all
at once: the rings each camera sees (sim.visibility's frustum and prism occlusion, the
arithmetic the twin's training fidelity runs, compiled: sim.fast.kernels), the GPS pose (its
latency and Gaussian noise), then the frame: the time, the pose in the alliance frame, the
rings held, the nearest other robots and the nearest seen rings in the robot frame, each with
the spec's noise; FrameStack's newest-first stack. Without noise a frame equals build_frame's
value for value (tested).
With spec.partner the partner block holds each robot's alliance partner (sim.match.partner_view:
where it is, its clamp and rings, the target it claimed, from `claims`: each robot's claimed
target in the field frame, NaN for none, which whoever drives the robots fills).
With spec.ring_memory the ring slots hold the seen and the remembered rings and the route slots
the route's first stops, from every robot's ring memory; with spec.goal_memory the goal slots
and the clamp flag come from every robot's goal memory (sim.fast.memory: RingMemory and
GoalMemory batched).
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.spec import SEEN, ObservationSpec
from sim.config import CameraConfig
from sim.errors import ConfigError
from sim.fast.kernels import nearest_seen, threads_for, visible_rings
from sim.fast.memory import FastGoalMemory, FastRingMemory, unsupported_memory
from sim.fast.world import FastWorld
from sim.match import memory_camera, partner_of
from sim.visibility import plates_in_view
from sim.world.state import POST_RADIUS

F32 = NDArray[np.float32]
F64 = NDArray[np.float64]
Bool = NDArray[np.bool_]


def unsupported_spec(spec: ObservationSpec) -> list[str]:
    """What of `spec` the batched observation does not build (empty: all of it)."""
    return unsupported_memory(spec)


class FastObserver:
    """Every robot's stacked observation in a FastWorld (module docstring)."""

    def __init__(
        self,
        world: FastWorld,
        spec: ObservationSpec,
        *,
        obs_noise: bool = True,
        gps_noise: bool = True,
        rng: np.random.Generator | None = None,
    ) -> None:
        missing = unsupported_spec(spec)
        if missing:
            raise ConfigError(
                "the fast backend does not build these observation features yet: "
                + ", ".join(missing)
            )
        self.world = world
        self.spec = spec
        self.obs_noise = obs_noise
        self.gps_noise = gps_noise
        self.rng = rng if rng is not None else np.random.default_rng()
        self.stack = np.zeros((world.n, world.n_robots, spec.n_frames, spec.frame_size), np.float32)
        g = world.field.goals
        # Goals hide rings as two discs each: the base and the post (sim.world.sensors.obstacles).
        radius = np.concatenate([world.field.goal_base_radii, np.full(len(g), POST_RADIUS)])
        height = np.array([x.base_height for x in g] + [x.height for x in g], float)
        rcs = world.robot_configs
        self._boxes = np.array([(rc.width_m / 2, rc.length_m / 2, rc.height_m) for rc in rcs])
        self._discs = np.stack([radius, height], -1).reshape(-1, 2)
        self._cam = np.array([_camera_row(rc.camera) for rc in rcs]).reshape(-1, 14)
        self._blue = np.array([a == "blue" for a in world.alliances])
        self._tall = np.array([rc.reaches_high_branch for rc in rcs], np.float32)  # role_flag
        # Where sim.goal_sight looks at a goal: the middle of its base (one height for all).
        heights = {x.base_height for x in g}
        if spec.goal_sight and len(heights) > 1:
            raise ConfigError("the fast backend's goal sight needs one base height for all goals")
        self._goal_z = heights.pop() / 2 if heights else 0.0
        self.memory: FastRingMemory | None = None
        if spec.ring_memory:
            ring_z = world.field.ring.thickness / 2
            cams = [memory_camera(rc.camera, ring_z) for rc in rcs]
            self.memory = FastRingMemory(world, spec, cams)
        self.goal_memory = FastGoalMemory(world, spec) if spec.goal_memory else None
        self.seen_pose = np.zeros((world.n, world.n_robots, 3))
        # Each robot's alliance partner (-1: none) and claimed target (field frame, NaN: none).
        alliances = list(world.alliances)
        mates = [partner_of(alliances, i) for i in range(world.n_robots)]
        self._mate = np.array([-1 if m is None else m for m in mates], dtype=np.int64)
        self.claims = np.full((world.n, world.n_robots, 2), np.nan)
        self._opponent = np.array([[a != b for b in alliances] for a in alliances])
        self._sizes = np.array([(rc.width_m, rc.length_m, rc.height_m) for rc in rcs])
        self.seen_rings = np.zeros((world.n, world.n_robots, world.ring_xy.shape[1]), bool)

    # --- what the cameras see ---------------------------------------------------------------

    def visible(self) -> Bool:
        """(B, R, N): the floor rings each robot's camera sees (sensors.visible_rings: the
        frustum and the prism occlusion of sim.visibility, compiled: sim.fast.kernels)."""
        w = self.world
        with threads_for(w.n):
            return visible_rings(
                w.x, w.y, w.heading, w.w, w.ring_xy, w.ring_floor, w.ring_z,
                self._cam, self._boxes, w.gx, w.gy, self._discs,
            )  # fmt: skip

    def goals_in_view(self) -> Bool:
        """(B, R, G): the goals each robot's camera sees (sim.goal_sight.visible_goals in
        training fidelity: the middle of the base in the frustum, no robot in the way), by the
        rings' compiled test with the goals as points and no goal as an obstacle."""
        w = self.world
        goal_xy = np.stack([w.gx, w.gy], -1)
        every = np.ones(w.gx.shape, dtype=bool)
        none = np.zeros((w.n, 0))
        with threads_for(w.n):
            return visible_rings(
                w.x, w.y, w.heading, w.w, goal_xy, every, self._goal_z, self._cam, self._boxes,
                none, none, self._discs[:0],
            )  # fmt: skip

    def robots_in_view(self) -> Bool:
        """(B, R, R): whether robot i's camera sees robot j's licence plate
        (sim.visibility.plates_in_view, as sim.world.sensors.robots_in_view)."""
        w = self.world
        rcs = w.robot_configs
        cams = [rc.camera for rc in rcs]
        goals = np.stack([w.gx, w.gy], -1)
        return plates_in_view(w.x, w.y, w.heading, w.w, cams, self._sizes, goals, self._discs)

    # --- frames -----------------------------------------------------------------------------

    def pose(self) -> F64:
        """Each robot's own pose as its observation reads it, (B, R, 3): the GPS reading
        (latency, Gaussian noise) with gps_noise, else the truth."""
        w = self.world
        if not self.gps_noise:
            return np.stack([w.x, w.y, w.heading], -1)
        pose = w.gps_pose()
        sd_xy = np.array([rc.gps.noise_xy_m for rc in w.robot_configs])
        sd_h = np.array([rc.gps.noise_heading_deg for rc in w.robot_configs])
        noise = self.rng.normal(0.0, 1.0, pose.shape)
        pose[..., 0] += noise[..., 0] * sd_xy
        pose[..., 1] += noise[..., 1] * sd_xy
        pose[..., 2] = (pose[..., 2] + noise[..., 2] * sd_h) % 360.0
        return pose

    def frames(
        self, visible: Bool | None = None, pose: F64 | None = None, rows: Bool | None = None
    ) -> F32:
        """Every robot's frame now, (B, R, spec.frame_size) (build_frame's layout). With a
        ring memory this is the control step's one look: it feeds the memories of the matches
        in `rows` (B,) (default all), and only their frames are complete."""
        w = self.world
        spec = self.spec
        visible = self.visible() if visible is None else visible
        pose = self.pose() if pose is None else pose
        # What each robot's frame was built from, for players that read the same sensors (the
        # planner through sim.fast.matches): only the rows this look is for.
        keep = slice(None) if rows is None else rows
        self.seen_pose[keep] = pose[keep]
        self.seen_rings[keep] = visible[keep]
        unit = spec.length_unit_m
        noisy = self.obs_noise
        out = np.zeros((w.n, w.n_robots, spec.frame_size), dtype=np.float32)
        x, y, h = pose[..., 0], pose[..., 1], pose[..., 2]
        # The alliance frame: blue sees the field turned 180 degrees.
        x = np.where(self._blue, -x, x)
        y = np.where(self._blue, -y, y)
        h = np.where(self._blue, (h + 180.0) % 360.0, h)
        if noisy and spec.position_noise_m > 0:
            jitter = self.rng.uniform(-spec.position_noise_m, spec.position_noise_m, (*x.shape, 2))
            x, y = x + jitter[..., 0], y + jitter[..., 1]
        rad = np.radians(h)
        out[..., 0] = np.clip(w.time_s / spec.match_length_s, 0.0, 1.0)[:, None]
        out[..., 1] = x / unit
        out[..., 2] = y / unit
        out[..., 3] = np.cos(rad)
        out[..., 4] = np.sin(rad)
        out[..., 5] = w.held / spec.ring_capacity_norm
        if spec.intake_flag:
            fills = w.room_cap < (1 << 30)
            out[..., spec.scalar_index("fills")] = fills
        if spec.role_flag:
            out[..., spec.scalar_index("tall")] = self._tall
        if spec.n_other_robots and w.n_robots > 1:
            true_h = np.radians(w.heading)
            s, c = np.sin(true_h)[..., None], np.cos(true_h)[..., None]
            dx = w.x[:, None, :] - w.x[:, :, None]  # (B, R, R): robot j from robot i
            dy = w.y[:, None, :] - w.y[:, :, None]
            local = np.stack([dx * c - dy * s, dx * s + dy * c], -1)
            shown = ~np.eye(w.n_robots, dtype=bool)[None]
            if spec.seen_opponents:  # the opponents whose plates the camera sees
                shown = self.robots_in_view() & self._opponent[None]
            d2 = np.where(shown, dx**2 + dy**2, np.inf)
            count = min(spec.n_other_robots, w.n_robots - 1)
            order = np.argsort(d2, axis=-1, kind="stable")[..., :count]
            near = np.take_along_axis(local, order[..., None], -2)
            ok = np.isfinite(np.take_along_axis(d2, order, -1)) * SEEN
            self._write(out, len(spec.scalars), near, ok)
        if spec.partner:
            self._write_partner(out)
        active = np.ones(w.n, dtype=bool) if rows is None else rows
        if self.goal_memory is not None:
            out[..., spec.scalar_index("clamped")] = w.carried >= 0
            seen = self.goals_in_view() if spec.goal_sight else None
            goals, count = self.goal_memory.observe(active, pose, seen)
            ok = np.where(np.arange(spec.n_goals) < count[..., None], SEEN, 0.0)
            self._write(out, spec.goal_offset, goals, ok, noise=False)
        if self.memory is None:
            with threads_for(w.n):
                near, seen = nearest_seen(w.x, w.y, w.heading, w.ring_xy, visible, spec.n_rings)
            ok = np.where(np.arange(spec.n_rings) < seen[..., None], SEEN, 0.0)
            self._write(out, spec.ring_offset, near, ok)
            return out
        slots = self.memory.observe(active, pose, visible)
        self._write(out, spec.ring_offset, slots.rings, slots.ring_ok)
        if spec.route_slots:
            route = slots.route
            if noisy and spec.relative_noise > 0:
                rel = spec.relative_noise
                route = route * (1.0 + self.rng.uniform(-rel, rel, route.shape))
            filled = np.arange(spec.route_slots) < slots.route_count[..., None]
            block = np.zeros((*route.shape[:-1], 3), dtype=np.float32)
            block[..., :2] = np.where(filled[..., None], route / unit, 0.0)
            block[..., 2] = filled
            lo = spec.route_offset
            out[..., lo : lo + 3 * spec.route_slots] = block.reshape((*out.shape[:2], -1))
        return out

    def _write(self, out: F32, offset: int, near: F64, ok: F64, noise: bool = True) -> None:
        """Slots (B, R, k, 2 robot-frame points, nearest first; ok: the slot's ok value, 0 for
        an empty one) into out[offset:] as (x, y, ok) triples, with the spec's relative noise
        unless noise is False (build_frame's _fill_slots)."""
        if noise and self.obs_noise and self.spec.relative_noise > 0:
            rel = self.spec.relative_noise
            near = near * (1.0 + self.rng.uniform(-rel, rel, near.shape))
        count = near.shape[-2]
        block = np.zeros((*near.shape[:-1], 3), dtype=np.float32)
        block[..., :2] = np.where(ok[..., None] > 0, near / self.spec.length_unit_m, 0.0)
        block[..., 2] = ok
        out[..., offset : offset + 3 * count] = block.reshape((*out.shape[:2], 3 * count))

    def _write_partner(self, out: F32) -> None:
        """Every robot's partner block (build_frame's _fill_partner; sim.match.partner_view):
        its partner's position and claim in the robot frame (the true poses, as the other
        robots' slots), each with own-position noise; its clamp and rings. Zeros alone."""
        w, spec = self.world, self.spec
        has = self._mate >= 0
        if not has.any():
            return
        mate = np.where(has, self._mate, np.arange(w.n_robots))
        rad = np.radians(w.heading)
        s, c = np.sin(rad), np.cos(rad)

        def local(px: F64, py: F64) -> F64:
            dx, dy = px - w.x, py - w.y
            xy = np.stack([dx * c - dy * s, dx * s + dy * c], -1)
            if self.obs_noise and spec.position_noise_m > 0:
                n = spec.position_noise_m
                xy = xy + self.rng.uniform(-n, n, xy.shape)
            return xy / spec.length_unit_m

        block = np.zeros((w.n, w.n_robots, 8), dtype=np.float32)
        block[..., 0:2] = local(w.x[:, mate], w.y[:, mate])
        block[..., 2] = 1.0
        block[..., 3] = w.carried[:, mate] >= 0
        block[..., 4] = w.held[:, mate] / spec.ring_capacity_norm
        claim = self.claims[:, mate]
        claimed = np.isfinite(claim).all(-1)
        block[..., 5:7] = np.where(claimed[..., None], local(claim[..., 0], claim[..., 1]), 0.0)
        block[..., 7] = claimed
        block[:, ~has] = 0.0
        lo = spec.partner_offset
        out[..., lo : lo + 8] = block

    # --- the stack --------------------------------------------------------------------------

    def reset(self, which: NDArray[np.int64] | None = None) -> F32:
        """Start the stacks of matches `which` (default all) from their frames now; returns
        every robot's stacked observation (B, R, spec.size)."""
        rows = np.arange(self.world.n) if which is None else np.asarray(which)
        active = np.zeros(self.world.n, dtype=bool)
        active[rows] = True
        for memory in (self.memory, self.goal_memory):
            if memory is not None:
                memory.reset(rows)
        self.claims[rows] = np.nan
        frame = self.frames(rows=active)
        self.stack[rows] = frame[rows][:, :, None, :]
        return self.observation()

    def push(self, keep: Bool | None = None) -> F32:
        """Push every match's frame now (newest first); matches where keep is False start
        their stack (and ring memories) anew (a match just reset)."""
        fresh = np.zeros(0, dtype=np.int64) if keep is None else np.flatnonzero(~keep)
        for memory in (self.memory, self.goal_memory):
            if memory is not None and len(fresh):
                memory.reset(fresh)
        self.claims[fresh] = np.nan
        frame = self.frames()
        self.stack[:, :, 1:] = self.stack[:, :, :-1].copy()
        self.stack[:, :, 0] = frame
        if len(fresh):
            self.stack[fresh] = frame[fresh][:, :, None, :]
        return self.observation()

    def observation(self) -> F32:
        """Every robot's stacked observation now, (B, R, spec.size): a copy."""
        return self.stack.reshape(self.world.n, self.world.n_robots, -1).copy()


def _camera_row(cam: CameraConfig) -> list[float]:
    """A camera as sim.fast.kernels.visible_rings reads it."""
    t = math.radians(cam.tilt_deg)
    turn = math.inf if cam.max_turn_rate_rad_s is None else cam.max_turn_rate_rad_s
    return [
        cam.forward_m, cam.right_m, cam.height_m, math.cos(t), math.sin(t),
        cam.fx, cam.fy, cam.cx, cam.cy, cam.width, cam.height, cam.near_m, cam.max_range_m, turn,
    ]  # fmt: skip
