"""Observations of every robot of every match in a FastWorld, as the robot's spec lays them out.

    obs = FastObserver(world, spec, obs_noise=True, gps_noise=True, rng=rng)
    stacked = obs.reset()                      # (B, R, spec.size) float32, after world.reset
    stacked = obs.push()                       # after each world.step

What MatchCore.view and jetson.autonomy.observation.build_frame do for one robot, done for all
at once: the rings each camera sees (sim.visibility's frustum and prism occlusion, the same
functions the twin's training fidelity calls), the GPS pose (its latency and Gaussian noise),
then the frame: the time, the pose in the alliance frame, the rings held, the nearest other
robots and the nearest seen rings in the robot frame, each with the spec's noise; FrameStack's
newest-first stack. Without noise a frame equals build_frame's value for value (tested).
Specs with memories or route slots (ring_memory, goal_memory, route_slots) are not batched yet:
ConfigError says so.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.spec import SEEN, ObservationSpec
from sim.errors import ConfigError
from sim.fast.world import FastWorld
from sim.visibility import boxes_blocked, camera_poses, discs_blocked, frustum
from sim.world.state import POST_RADIUS

F32 = NDArray[np.float32]
F64 = NDArray[np.float64]
Bool = NDArray[np.bool_]


def unsupported_spec(spec: ObservationSpec) -> list[str]:
    """What of `spec` the batched observation does not build (empty: all of it)."""
    out = []
    for name in ("ring_memory", "goal_memory", "route_slots"):
        if getattr(spec, name):
            out.append(name)
    return out


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
        self._disc_radius = np.array([x.base_radius for x in g] + [POST_RADIUS] * len(g))
        self._disc_height = np.array([x.base_height for x in g] + [x.height for x in g])
        rcs = world.robot_configs
        self._box_half = np.array([(rc.width_m / 2, rc.length_m / 2) for rc in rcs]).reshape(-1, 2)
        self._box_height = np.array([rc.height_m for rc in rcs])
        self._blue = np.array([a == "blue" for a in world.alliances])

    # --- what the cameras see ---------------------------------------------------------------

    def visible(self) -> Bool:
        """(B, R, N): the floor rings each robot's camera sees (sensors.visible_rings)."""
        w = self.world
        b, n = w.n, w.ring_xy.shape[1]
        out = np.zeros((b, w.n_robots, n), dtype=bool)
        pts = np.concatenate([w.ring_xy, np.full((b, n, 1), w.ring_z)], -1)
        for i, rc in enumerate(w.robot_configs):
            cam = rc.camera
            xy = np.stack([w.x[:, i], w.y[:, i]], -1)
            pos, rot = camera_poses(xy, w.heading[:, i], cam)
            mask, _, _ = frustum(pts, pos[:, None], rot[:, None], cam)
            mask &= w.ring_floor
            if cam.max_turn_rate_rad_s is not None:
                mask &= (np.abs(w.w[:, i]) <= cam.max_turn_rate_rad_s)[:, None]
            bi, ni = np.nonzero(mask)
            if len(bi):
                mask[bi, ni] = ~self._occluded(i, bi, pos[bi], pts[bi, ni])
            out[:, i] = mask
        return out

    def _occluded(self, robot: int, bi: NDArray[np.int64], cam: F64, target: F64) -> Bool:
        """Sight lines from robot `robot`'s camera in matches bi to targets (C, 3): blocked by
        another robot (a box) or a goal (its base and post, discs)."""
        w = self.world
        d3 = target - cam
        d, dz = d3[:, :2], d3[:, 2]
        t_max = 1.0 - 1e-6
        hit = np.zeros(len(bi), dtype=bool)
        with np.errstate(divide="ignore", invalid="ignore"):
            others = [k for k in range(w.n_robots) if k != robot]
            if others:
                xy = np.stack([w.x[bi][:, others], w.y[bi][:, others]], -1)
                half = np.broadcast_to(self._box_half[others], xy.shape)
                height = np.broadcast_to(self._box_height[others], xy.shape[:2])
                hit |= boxes_blocked(cam, d, dz, xy, w.heading[bi][:, others], half, height, t_max)
            if w.n_goals:
                gxy = np.stack([w.gx[bi], w.gy[bi]], -1)
                xy = np.concatenate([gxy, gxy], 1)
                radius = np.broadcast_to(self._disc_radius, xy.shape[:2])
                height = np.broadcast_to(self._disc_height, xy.shape[:2])
                hit |= discs_blocked(cam, d, dz, xy, radius, height, t_max)
        return hit

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

    def frames(self, visible: Bool | None = None, pose: F64 | None = None) -> F32:
        """Every robot's frame now, (B, R, spec.frame_size) (build_frame's layout)."""
        w = self.world
        spec = self.spec
        visible = self.visible() if visible is None else visible
        pose = self.pose() if pose is None else pose
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
        true_h = np.radians(w.heading)
        s, c = np.sin(true_h)[..., None], np.cos(true_h)[..., None]
        if spec.n_other_robots and w.n_robots > 1:
            dx = w.x[:, None, :] - w.x[:, :, None]  # (B, R, R): robot j from robot i
            dy = w.y[:, None, :] - w.y[:, :, None]
            local = np.stack([dx * c - dy * s, dx * s + dy * c], -1)
            others = ~np.eye(w.n_robots, dtype=bool)[None].repeat(w.n, 0)
            self._fill(out, len(spec.scalars), spec.n_other_robots, local, others)
        px = w.ring_xy[:, None, :, 0] - w.x[..., None]  # (B, R, N)
        py = w.ring_xy[:, None, :, 1] - w.y[..., None]
        local = np.stack([px * c - py * s, px * s + py * c], -1)
        self._fill(out, spec.ring_offset, spec.n_rings, local, visible)
        return out

    def _fill(self, out: F32, offset: int, slots: int, local: F64, present: Bool) -> None:
        """The nearest `slots` present points (B, R, M, 2 robot-frame) into out[offset:] as
        (x, y, 1) triples, nearest first, with the spec's relative noise (build_frame's
        _fill_slots; equal distances keep the points' order)."""
        d2 = np.where(present, local[..., 0] ** 2 + local[..., 1] ** 2, np.inf)
        count = min(slots, d2.shape[-1])
        if count < d2.shape[-1]:
            # The nearest `count` first (argpartition), then in order among themselves.
            near = np.argpartition(d2, count - 1, axis=-1)[..., :count]
            within = np.argsort(np.take_along_axis(d2, near, -1), axis=-1, kind="stable")
            order = np.take_along_axis(near, within, -1)
        else:
            order = np.argsort(d2, axis=-1, kind="stable")
        near = np.take_along_axis(local, order[..., None], -2)
        ok = np.take_along_axis(present, order, -1)
        if self.obs_noise and self.spec.relative_noise > 0:
            rel = self.spec.relative_noise
            near = near * (1.0 + self.rng.uniform(-rel, rel, near.shape))
        block = np.zeros((*near.shape[:-1], 3), dtype=np.float32)
        block[..., :2] = np.where(ok[..., None], near / self.spec.length_unit_m, 0.0)
        block[..., 2] = np.where(ok, SEEN, 0.0)
        out[..., offset : offset + 3 * count] = block.reshape((*out.shape[:2], 3 * count))

    # --- the stack --------------------------------------------------------------------------

    def reset(self, which: NDArray[np.int64] | None = None) -> F32:
        """Start the stacks of matches `which` (default all) from their frames now; returns
        every robot's stacked observation (B, R, spec.size)."""
        frame = self.frames()
        rows = np.arange(self.world.n) if which is None else np.asarray(which)
        self.stack[rows] = frame[rows][:, :, None, :]
        return self.observation()

    def push(self, keep: Bool | None = None) -> F32:
        """Push every match's frame now (newest first); matches where keep is False start
        their stack anew (a match just reset)."""
        frame = self.frames()
        self.stack[:, :, 1:] = self.stack[:, :, :-1].copy()
        self.stack[:, :, 0] = frame
        if keep is not None and not keep.all():
            rows = np.flatnonzero(~keep)
            self.stack[rows] = frame[rows][:, :, None, :]
        return self.observation()

    def observation(self) -> F32:
        """Every robot's stacked observation now, (B, R, spec.size): a copy."""
        return self.stack.reshape(self.world.n, self.world.n_robots, -1).copy()
