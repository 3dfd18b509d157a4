"""Training-fidelity physics and rules for a batch of matches, in numpy.

Every array's first axis is the match (B), the second the robot (R, red first, as World lists
them), the goal (G, the field file's order) or the ring (N). One step does for every match at
once what sim.world.physics.World does for one in training fidelity:

1. the commands pass the acceleration and speed limits (a non-finite command is a stop);
2. `substeps` times: robots move at their commanded (v, w), free goals slide and slow (the
   floor friction World models as damping), then contacts are resolved: robot against robot
   (boxes, by the separating axis of least overlap, shared by mass), robot against goal (box
   against disc: a free goal is pushed out and takes the robot's speed along the push; a
   carried goal pushes back on both robots), goal against goal, and the walls;
3. the clamps take and let go of goals, carried goals follow their clamps, intakes take the
   rings their zones reach (nearest the bumper first), held rings move onto carried goals;
4. the rules: pins (sim.world.rules.pin_step) and the score (rules.ring_race_score).

Where World asks PyBullet (contacts, the solver's pushes), this models them geometrically, so
the two agree closely but not bit for bit; everything else (limits, clamp, intake, transfer,
the rules, the start's randomness) is the same arithmetic. The ring race only: the whole game's
see-saws, tugs of war and fouls are not batched yet (ConfigError names what is not).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.geometry import AllianceName, wrap_heading
from sim.config import RobotConfig, WorldConfig
from sim.errors import ConfigError
from sim.field import FieldSpec, load_field
from sim.world import rules

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
Bool = NDArray[np.bool_]

# World's linear damping of a goal in training fidelity (its floor friction). PyBullet's bodies
# are multibodies, whose damping is a drag d (1 + |v|) v per unit mass (Bullet's btMultiBody:
# DAMPING_K1_LINEAR and DAMPING_K2_LINEAR are both the damping), integrated each substep.
_GOAL_DAMPING = 0.99
# How much of a wall contact's overlap the contact itself undoes, by turning and moving the
# robot together; the walls' clamp (_contain) moves it out of the rest. Fitted to PyBullet's
# training fidelity (a robot turning against a wall).
_POSITION_SHARE = 0.5
_UNLIMITED = 1 << 30  # the room of an intake that never fills


@dataclass
class FastEvents:
    """What one step did in every match (robot indices as World's)."""

    collected: I64  # (B, R) rings each robot took in
    scored: I64  # (B, R) rings each robot moved onto its goal
    clamped: I64  # (B, R) the goal each robot's clamp took this step, -1 none
    pins: Bool  # (B, P) each red-blue pair (FastWorld.pin_pairs) pinned this step
    match_over: Bool  # (B,) the match is over (it ended with this step or before)


def unsupported(config: WorldConfig) -> list[str]:
    """What of `config` the batched backend does not model (empty: it plays this world)."""
    out = []
    if config.game != "ring_race":
        out.append(f"game = {config.game!r} (the fast path plays the ring race)")
    if config.fidelity != "training":
        out.append("fidelity = 'high' (the fast path is training fidelity)")
    if config.occlude_with_rings:
        out.append("occlude_with_rings (rings hiding rings)")
    if config.isolation_s > 0:
        out.append("an isolation period (isolation_s > 0)")
    for name in (*config.red, *config.blue):
        rc = config.robots[name]
        if rc.gps.latency_s > config.control_dt:
            out.append(f"robot {name}: GPS latency longer than one control step")
    return out


class FastWorld:
    """A batch of `n_matches` ring-race matches in training fidelity (module docstring)."""

    def __init__(
        self,
        config: WorldConfig | None = None,
        n_matches: int = 1,
        *,
        field_spec: FieldSpec | None = None,
    ) -> None:
        self.config = config or WorldConfig()
        missing = unsupported(self.config)
        if missing:
            raise ConfigError("the fast backend does not model: " + "; ".join(missing))
        if n_matches < 1:
            raise ConfigError(f"n_matches must be at least 1, got {n_matches}")
        self.field = field_spec or load_field(self.config.field)
        self.n = n_matches
        cfg = self.config
        self.dt = cfg.control_dt
        self.substeps = cfg.substeps
        self.match_length_s = cfg.isolation_s + (
            cfg.interaction_s or self.field.rules.interaction_s
        )
        self.pin_time_s = cfg.pin_time_s or self.field.rules.pin_time_s
        self.lineup: list[tuple[AllianceName, str]] = [("red", n) for n in cfg.red] + [
            ("blue", n) for n in cfg.blue
        ]
        self.robot_configs: list[RobotConfig] = [cfg.robots[name] for _, name in self.lineup]
        self.alliances: tuple[AllianceName, ...] = tuple(a for a, _ in self.lineup)
        rcs = self.robot_configs
        self.n_robots = len(rcs)
        self.half_w = np.array([rc.width_m / 2 for rc in rcs])
        self.half_l = np.array([rc.length_m / 2 for rc in rcs])
        self.mass = np.array([rc.mass_kg for rc in rcs])
        self.max_v = np.array([rc.max_linear_mps for rc in rcs])
        self.max_w = np.array([rc.max_angular_rad_s for rc in rcs])
        self.acc_v = np.array([rc.max_linear_accel for rc in rcs]) * self.dt
        self.acc_w = np.array([rc.max_angular_accel for rc in rcs]) * self.dt
        self.capacity = np.array(
            [_UNLIMITED if rc.ring_capacity is None else rc.ring_capacity for rc in rcs]
        )
        self.front_clamp = np.array([rc.clamp == "front" for rc in rcs])
        self.radius = np.array([rc.radius_m for rc in rcs])  # the footprint's bounding circle
        self.goal_radius = np.array([g.base_radius for g in self.field.goals])
        self.goal_mass = np.array([g.mass_kg for g in self.field.goals])
        self.n_goals = len(self.field.goals)
        reds = [i for i, a in enumerate(self.alliances) if a == "red"]
        blues = [i for i, a in enumerate(self.alliances) if a == "blue"]
        self.pin_pairs: list[tuple[int, int]] = [(a, b) for a in reds for b in blues]
        pairs = [(i, j) for i in range(self.n_robots) for j in range(i + 1, self.n_robots)]
        self._pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)
        self._pin_index = np.array(
            [pairs.index(p) for p in self.pin_pairs], dtype=np.int64
        ).reshape(-1)
        self.ring_radius = self.field.ring.radius
        self.ring_z = self.field.ring.thickness / 2
        self._allocate()

    # --- state ------------------------------------------------------------------------------

    def _allocate(self) -> None:
        b, r, g = self.n, self.n_robots, self.n_goals
        n_rings = len(self.field.ring_positions)
        if self.config.match_loads:
            n_rings += 2 * self.field.ring.match_loads_per_alliance
        self.x = np.zeros((b, r))
        self.y = np.zeros((b, r))
        self.heading = np.zeros((b, r))  # degrees, clockwise from +y
        self.v = np.zeros((b, r))
        self.w = np.zeros((b, r))
        self.measured_v = np.zeros((b, r))
        self.measured_w = np.zeros((b, r))
        self.held = np.zeros((b, r), dtype=np.int64)
        self.collected = np.zeros((b, r), dtype=np.int64)
        self.room_cap = np.tile(self.capacity, (b, 1))  # per match: uncapped matches differ
        self.carried = np.full((b, r), -1, dtype=np.int64)
        self.transfer = np.zeros((b, r))
        self.intake_on = np.ones((b, r), dtype=bool)
        self.gx = np.zeros((b, g))
        self.gy = np.zeros((b, g))
        self.gvx = np.zeros((b, g))
        self.rvx = np.zeros((b, r))  # the robots' field-frame velocity within a step
        self.rvy = np.zeros((b, r))
        self.rw = np.zeros((b, r))  # and turn rate (rad/s clockwise)
        self.gvy = np.zeros((b, g))
        self.carrier = np.full((b, g), -1, dtype=np.int64)
        self.goal_rings = np.zeros((b, g), dtype=np.int64)
        self.ring_xy = np.zeros((b, n_rings, 2))
        self.ring_floor = np.zeros((b, n_rings), dtype=bool)
        self.pin_timers = np.zeros((b, len(self.pin_pairs)))
        self.steps = np.zeros(b, dtype=np.int64)
        self.time_s = np.zeros(b)
        self.over = np.zeros(b, dtype=bool)
        # The pose one control step ago, for the GPS's latency (World keeps a history).
        self.prev_pose = np.zeros((b, r, 3))
        self.prev_time = np.zeros(b)

    @property
    def room(self) -> I64:
        return np.maximum(0, self.room_cap - self.held)

    def reset(self, seeds: Iterable[int | np.random.Generator] | None = None) -> None:
        """Every match anew; match k draws its start from seeds[k] exactly as World.reset
        draws from the same generator (so the same seed starts the same match)."""
        seeds = list(range(self.n)) if seeds is None else list(seeds)
        if len(seeds) != self.n:
            raise ConfigError(f"reset needs {self.n} seeds, got {len(seeds)}")
        self.reset_matches(np.arange(self.n), seeds)

    def reset_matches(
        self, which: NDArray[np.int64], seeds: list[int | np.random.Generator]
    ) -> list[np.random.Generator]:
        """Start matches `which` anew, one seed (or generator) each; returns the generators,
        advanced past the start's draws as World.reset leaves its own."""
        cfg = self.config
        f = self.field
        rngs = [
            s if isinstance(s, np.random.Generator) else np.random.default_rng(s) for s in seeds
        ]
        starts = [f.start(a, name) for a, name in self.lineup]
        base_rings = f.ring_positions
        spots = f.match_load_spots[: f.ring.match_loads_per_alliance] if cfg.match_loads else None
        lim = f.half - f.ring.radius
        preload = f.ring.preloads_per_robot if cfg.preloads else 0
        for k, rng in zip(which, rngs, strict=True):
            for i, st in enumerate(starts):
                jit = cfg.start_jitter_m
                x = st.position[0] + (rng.uniform(-jit, jit) if jit > 0 else 0.0)
                y = st.position[1] + (rng.uniform(-jit, jit) if jit > 0 else 0.0)
                hj = cfg.start_jitter_deg
                h = float(wrap_heading(st.heading + (rng.uniform(-hj, hj) if hj > 0 else 0)))
                self.x[k, i], self.y[k, i], self.heading[k, i] = x, y, h
            xy = base_rings.copy()
            if cfg.ring_jitter_m > 0:
                xy += rng.uniform(-cfg.ring_jitter_m, cfg.ring_jitter_m, xy.shape)
                np.clip(xy, -lim, lim, out=xy)
            if spots is not None:
                xy = np.concatenate([xy, spots, -spots])
            self.ring_xy[k] = xy
        which = np.asarray(which, dtype=np.int64)
        for name in ("v", "w", "measured_v", "measured_w", "transfer", "pin_timers"):
            getattr(self, name)[which] = 0.0
        self.held[which] = preload
        self.collected[which] = 0
        self.room_cap[which] = self.capacity
        self.carried[which] = -1
        self.intake_on[which] = True
        self.gx[which] = [g.position[0] for g in f.goals]
        self.gy[which] = [g.position[1] for g in f.goals]
        self.gvx[which] = 0.0
        self.gvy[which] = 0.0
        self.carrier[which] = -1
        self.goal_rings[which] = 0
        self.ring_floor[which] = True
        self.steps[which] = 0
        self.time_s[which] = 0.0
        self.over[which] = False
        self.prev_pose[which] = np.stack([self.x[which], self.y[which], self.heading[which]], -1)
        self.prev_time[which] = 0.0
        return rngs

    # --- stepping ---------------------------------------------------------------------------

    def step(
        self,
        linear: F64,
        angular: F64,
        intake: Bool | None = None,
        clamp: NDArray[np.int8] | None = None,
    ) -> FastEvents:
        """One control step of every match. linear (m/s), angular (rad/s clockwise): (B, R);
        intake (B, R) runs the intake (default on); clamp (B, R): 1 grab, 0 release, -1 leave
        it to the auto clamp (default -1). A match already over does not move."""
        b, r = self.n, self.n_robots
        live = ~self.over
        lin = np.asarray(linear, dtype=np.float64).reshape(b, r)
        ang = np.asarray(angular, dtype=np.float64).reshape(b, r)
        bad = ~(np.isfinite(lin) & np.isfinite(ang)) | ~live[:, None]
        lin = np.where(bad, 0.0, np.clip(lin, -self.max_v, self.max_v))
        ang = np.where(bad, 0.0, np.clip(ang, -self.max_w, self.max_w))
        self.v += np.clip(lin - self.v, -self.acc_v, self.acc_v)
        self.w += np.clip(ang - self.w, -self.acc_w, self.acc_w)
        self.v[~live] = 0.0
        self.w[~live] = 0.0
        self.gvx[~live] = 0.0
        self.gvy[~live] = 0.0
        on = np.ones((b, r), dtype=bool) if intake is None else np.asarray(intake, dtype=bool)
        self.intake_on = on.reshape(b, r)
        before = np.stack([self.x, self.y, self.heading], -1)
        h = self.dt / self.substeps
        # As World sets each body's velocity once a control step (PyBullet keeps it in the
        # field frame through the substeps, where contacts change it).
        rad = np.radians(self.heading)
        self.rvx = self.v * np.sin(rad)
        self.rvy = self.v * np.cos(rad)
        self.rw = self.w.copy()
        for _ in range(self.substeps):
            self.x += self.rvx * h
            self.y += self.rvy * h
            self.heading += np.degrees(self.rw) * h
            free = self.carrier < 0
            speed = np.hypot(self.gvx, self.gvy)
            damp = np.maximum(0.0, 1.0 - _GOAL_DAMPING * (1.0 + speed) * h)
            self.gvx *= damp
            self.gvy *= damp
            self.gx += np.where(free, self.gvx, 0.0) * h
            self.gy += np.where(free, self.gvy, 0.0) * h
            self._follow_clamps()
            self._contacts()
        self.heading = np.asarray(wrap_heading(self.heading), dtype=np.float64)
        dx, dy = self.x - before[..., 0], self.y - before[..., 1]
        h0 = np.radians(before[..., 2])
        self.measured_v = (dx * np.sin(h0) + dy * np.cos(h0)) / self.dt
        turned = (self.heading - before[..., 2] + 180.0) % 360.0 - 180.0
        self.measured_w = np.radians(turned) / self.dt
        self.prev_pose = np.where(live[:, None, None], before, self.prev_pose)
        self.prev_time = np.where(live, self.time_s, self.prev_time)
        self.steps += live
        self.time_s = np.where(live, self.steps * self.dt, self.time_s)
        events = FastEvents(
            collected=np.zeros((b, r), dtype=np.int64),
            scored=np.zeros((b, r), dtype=np.int64),
            clamped=np.full((b, r), -1, dtype=np.int64),
            pins=np.zeros((b, len(self.pin_pairs)), dtype=bool),
            match_over=self.over.copy(),
        )
        want = np.full((b, r), -1, dtype=np.int8) if clamp is None else np.asarray(clamp)
        self._clamp(want.reshape(b, r), live, events)
        self._follow_clamps()
        self._intake(live, events)
        if self.config.push_rings:
            self._push_rings()
        self._transfer(live, events)
        if self.pin_pairs:
            touching = self._touching()
            timers, pinned = rules.pin_step(self.pin_timers, touching, self.dt, self.pin_time_s)
            self.pin_timers = np.where(live[:, None], timers, self.pin_timers)
            events.pins = pinned & live[:, None]
        ended = live & (self.time_s >= self.match_length_s - 1e-9)
        self.over |= ended
        events.match_over = self.over.copy()
        return events

    # --- contacts ---------------------------------------------------------------------------

    def _axes(self) -> tuple[F64, F64]:
        """Each robot's forward and right unit vectors, (B, R, 2)."""
        rad = np.radians(self.heading)
        s, c = np.sin(rad), np.cos(rad)
        return np.stack([s, c], -1), np.stack([c, -s], -1)

    def _box_overlap(
        self, bi: I64, i: I64, j: I64, with_point: bool = False
    ) -> tuple[F64, F64] | tuple[F64, F64, F64]:
        """Robots i and j of matches bi (C,): the least overlap of their boxes over the four
        separating axes (negative: the gap between them) and that axis (C, 2), pointing from
        robot i to robot j; with_point, also where they touch (C, 2): the corner of the one box
        deepest in the other's face (the middle of an edge lying flat against it)."""
        rad_i = np.radians(self.heading[bi, i])
        rad_j = np.radians(self.heading[bi, j])
        fi = np.stack([np.sin(rad_i), np.cos(rad_i)], -1)
        ri = np.stack([fi[:, 1], -fi[:, 0]], -1)
        fj = np.stack([np.sin(rad_j), np.cos(rad_j)], -1)
        rj = np.stack([fj[:, 1], -fj[:, 0]], -1)
        d = np.stack([self.x[bi, j] - self.x[bi, i], self.y[bi, j] - self.y[bi, i]], -1)
        axes = np.stack([fi, ri, fj, rj], 1)  # (C, 4, 2)

        def reach(f: F64, r: F64, k: I64) -> F64:
            along = np.abs(np.einsum("cad,cd->ca", axes, f))
            across = np.abs(np.einsum("cad,cd->ca", axes, r))
            return self.half_l[k][:, None] * along + self.half_w[k][:, None] * across

        sep = np.einsum("cad,cd->ca", axes, d)
        overlap = reach(fi, ri, i) + reach(fj, rj, j) - np.abs(sep)
        best = np.argmin(overlap, axis=1)
        rows = np.arange(len(bi))
        sign = np.sign(sep[rows, best])
        sign = np.where(sign == 0, 1.0, sign)
        normal = axes[rows, best] * sign[:, None]
        if not with_point:
            return overlap[rows, best], normal

        ci = np.stack([self.x[bi, i], self.y[bi, i]], -1)
        cj = np.stack([self.x[bi, j], self.y[bi, j]], -1)
        on_i = best < 2  # the reference face is i's (else j's); the other box's face meets it
        ref_c = np.where(on_i[:, None], ci, cj)
        inc_c = np.where(on_i[:, None], cj, ci)
        n_ref = np.where(on_i[:, None], normal, -normal)  # out of the reference face
        ref_f = np.where(on_i[:, None], fi, fj)
        inc_f = np.where(on_i[:, None], fj, fi)
        inc_r = np.where(on_i[:, None], rj, ri)
        k_ref = np.where(on_i, i, j)
        k_inc = np.where(on_i, j, i)
        along_ref = np.abs(np.einsum("cd,cd->c", ref_f, n_ref)) > 0.5  # the face is a front/back
        h_n = np.where(along_ref, self.half_l[k_ref], self.half_w[k_ref])
        h_t = np.where(along_ref, self.half_w[k_ref], self.half_l[k_ref])
        tangent = np.stack([-n_ref[:, 1], n_ref[:, 0]], -1)
        # The incident face: the other box's face turned most against the reference normal.
        a = np.einsum("cd,cd->c", inc_f, n_ref)
        b = np.einsum("cd,cd->c", inc_r, n_ref)
        use_f = np.abs(a) >= np.abs(b)
        axis = np.where(use_f[:, None], inc_f, inc_r)
        other = np.where(use_f[:, None], inc_r, inc_f)
        h_axis = np.where(use_f, self.half_l[k_inc], self.half_w[k_inc])
        h_other = np.where(use_f, self.half_w[k_inc], self.half_l[k_inc])
        face = inc_c - (np.sign(np.where(use_f, a, b)) * h_axis)[:, None] * axis
        ends = np.stack([face + h_other[:, None] * other, face - h_other[:, None] * other], 1)
        # Clip the incident edge to the reference face's extent, keep what is inside it.
        s = np.einsum("ckd,cd->ck", ends - ref_c[:, None], tangent)
        ds = s[:, 1] - s[:, 0]
        safe = np.where(np.abs(ds) < 1e-12, 1.0, ds)
        t0 = np.clip((-h_t - s[:, 0]) / safe, 0.0, 1.0)
        t1 = np.clip((h_t - s[:, 0]) / safe, 0.0, 1.0)
        lo, hi = np.minimum(t0, t1), np.maximum(t0, t1)
        lo = np.where(np.abs(ds) < 1e-12, 0.0, lo)
        hi = np.where(np.abs(ds) < 1e-12, 1.0, hi)
        p_lo = ends[:, 0] + lo[:, None] * (ends[:, 1] - ends[:, 0])
        p_hi = ends[:, 0] + hi[:, None] * (ends[:, 1] - ends[:, 0])
        depth_lo = h_n - np.einsum("cd,cd->c", p_lo - ref_c, n_ref)
        depth_hi = h_n - np.einsum("cd,cd->c", p_hi - ref_c, n_ref)
        w_lo, w_hi = np.maximum(depth_lo, 0.0), np.maximum(depth_hi, 0.0)
        total = w_lo + w_hi
        mix = np.where(total > 1e-12, w_hi / np.where(total > 1e-12, total, 1.0), 0.5)
        point = p_lo + mix[:, None] * (p_hi - p_lo)
        return overlap[rows, best], normal, point

    def _touching(self) -> Bool:
        """Red-blue pairs within pin_contact_m hull to hull (World._touching), (B, P_pin)."""
        pairs = np.array(self.pin_pairs, dtype=np.int64).reshape(-1, 2)
        n_p = len(pairs)
        bi = np.repeat(np.arange(self.n), n_p)
        i, j = np.tile(pairs[:, 0], self.n), np.tile(pairs[:, 1], self.n)
        least, _ = self._box_overlap(bi, i, j)
        return (-least <= self.config.pin_contact_m).reshape(self.n, n_p)

    def _contacts(self) -> None:
        """Every contact of this substep at once: robot-robot boxes, robot-goal box-disc,
        goal-goal discs (a bounding-circle test first, so only pairs that may touch are
        worked out), each resolved by _resolve; then the walls."""
        parts = [self._robot_robot_contacts()] if len(self._pairs) else []
        if self.n_goals:
            parts.append(self._robot_goal_contacts())
            if self.n_goals > 1:
                parts.append(self._goal_goal_contacts())
        parts = [c for c in parts if len(c[0])]
        if parts:
            self._resolve(*(np.concatenate(k) for k in zip(*parts, strict=True)))
        self._contain()

    def _robot_robot_contacts(self) -> tuple[I64, F64, F64, I64, I64, F64]:
        i, j = self._pairs[:, 0], self._pairs[:, 1]
        reach = self.radius[i] + self.radius[j]
        d2 = (self.x[:, j] - self.x[:, i]) ** 2 + (self.y[:, j] - self.y[:, i]) ** 2
        bi, pi = np.nonzero(d2 < reach**2)
        least, axis, point = self._box_overlap(bi, i[pi], j[pi], with_point=True)  # type: ignore[misc]
        keep = least > 0
        bi, pi = bi[keep], pi[keep]
        return bi, axis[keep], least[keep], i[pi], j[pi], point[keep]

    def _robot_goal_contacts(self) -> tuple[I64, F64, F64, I64, I64, F64]:
        """Box against disc for the robots and goals that touch (not a robot and the goal in
        its own clamp): the match, the normal from robot to goal, the depth, the bodies (robot
        index; goal g as body R + g) and the contact point (the box's point nearest the
        goal's centre)."""
        r = self.n_robots
        dx = self.gx[:, None, :] - self.x[:, :, None]  # (B, R, G)
        dy = self.gy[:, None, :] - self.y[:, :, None]
        reach = self.radius[:, None] + self.goal_radius[None]
        near = (dx**2 + dy**2 < reach**2) & (
            self.carrier[:, None, :] != np.arange(r)[None, :, None]
        )
        bi, ri, gi = np.nonzero(near)
        dx, dy = dx[bi, ri, gi], dy[bi, ri, gi]
        rad = np.radians(self.heading[bi, ri])
        fx, fy = np.sin(rad), np.cos(rad)
        rx, ry = fy, -fx
        lx = dx * rx + dy * ry  # across (right)
        ly = dx * fx + dy * fy  # along the heading
        hw, hl = self.half_w[ri], self.half_l[ri]
        px, py = np.clip(lx, -hw, hw), np.clip(ly, -hl, hl)
        ex, ey = lx - px, ly - py
        dist = np.hypot(ex, ey)
        inside = dist < 1e-9
        # A centre inside the box leaves across the nearer side.
        side_x = hw - np.abs(lx) <= hl - np.abs(ly)
        safe = np.maximum(dist, 1e-12)
        nx = np.where(inside, np.where(side_x, np.where(lx >= 0, 1.0, -1.0), 0.0), ex / safe)
        ny = np.where(inside, np.where(side_x, 0.0, np.where(ly >= 0, 1.0, -1.0)), ey / safe)
        gr = self.goal_radius[gi]
        depth = np.where(inside, np.where(side_x, hw - np.abs(lx), hl - np.abs(ly)) + gr, gr - dist)
        keep = depth > 0
        normal = np.stack([nx * rx + ny * fx, nx * ry + ny * fy], -1)
        x0, y0 = self.x[bi, ri], self.y[bi, ri]
        point = np.stack([x0 + px * rx + py * fx, y0 + px * ry + py * fy], -1)
        return bi[keep], normal[keep], depth[keep], ri[keep], r + gi[keep], point[keep]

    def _goal_goal_contacts(self) -> tuple[I64, F64, F64, I64, I64, F64]:
        a, c = np.triu_indices(self.n_goals, 1)
        dx = self.gx[:, c] - self.gx[:, a]
        dy = self.gy[:, c] - self.gy[:, a]
        reach = self.goal_radius[a] + self.goal_radius[c]
        bi, pi = np.nonzero(dx**2 + dy**2 < reach**2)
        dx, dy = dx[bi, pi], dy[bi, pi]
        dist = np.hypot(dx, dy)
        safe = np.maximum(dist, 1e-12)
        normal = np.stack(
            [np.where(dist > 1e-12, dx / safe, 1.0), np.where(dist > 1e-12, dy / safe, 0.0)], -1
        )
        ga, gc = a[pi], c[pi]
        point = np.stack([self.gx[bi, ga], self.gy[bi, ga]], -1)
        point += normal * self.goal_radius[ga][:, None]
        r = self.n_robots
        return bi, normal, reach[pi] - dist, r + ga, r + gc, point

    def _resolve(
        self, bi: I64, normal: F64, depth: F64, first: I64, second: I64, point: F64
    ) -> None:
        """Push every touching pair (C contacts: match bi, bodies first and second) apart by
        mass and stop its approach at the contact point: an inelastic impulse through both
        bodies' masses and, for robots, inertia (no point, NaN: through the masses alone).
        Bodies: robots 0..R-1, goals R..R+G-1. A goal in a clamp pushes with its own mass at
        its robot's speed and is put back in the clamp after (it never moves its robot), as
        World's carried goal body is."""
        r = self.n_robots
        k = r + self.n_goals
        ma, mc = first, second
        robot_mass, robot_inertia = self._body_mass()

        def body(m: I64) -> tuple[F64, F64, F64, F64, F64, F64, F64]:
            """Mass, 1/inertia (0: a goal does not turn), position, velocity, turn rate."""
            robot = m < r
            ri, gi = np.where(robot, m, 0), np.where(robot, 0, m - r)
            mass = np.where(robot, robot_mass[bi, ri], self.goal_mass[gi])
            inv_i = np.where(robot, 1.0 / robot_inertia[bi, ri], 0.0)
            x = np.where(robot, self.x[bi, ri], self.gx[bi, gi])
            y = np.where(robot, self.y[bi, ri], self.gy[bi, gi])
            vx = np.where(robot, self.rvx[bi, ri], self.gvx[bi, gi])
            vy = np.where(robot, self.rvy[bi, ri], self.gvy[bi, gi])
            w = np.where(robot, self.rw[bi, ri], 0.0)
            return mass, inv_i, x, y, vx, vy, w

        nx, ny = normal[:, 0], normal[:, 1]
        lever = np.isfinite(point[:, 0])
        m_a, i_a, x_a, y_a, vx_a, vy_a, w_a = body(ma)
        m_c, i_c, x_c, y_c, vx_c, vy_c, w_c = body(mc)
        # A body already against a wall does not give way toward it (the wall holds it, and
        # its friction there keeps it from sliding along): it stands like the wall.
        wall_x, wall_y = self._at_walls()
        held_a = _into_wall(wall_x[bi, ma], wall_y[bi, ma], -nx, -ny)
        held_c = _into_wall(wall_x[bi, mc], wall_y[bi, mc], nx, ny)
        both = held_a & held_c
        held_a &= ~both
        held_c &= ~both
        m_a = np.where(held_a, np.inf, m_a)
        m_c = np.where(held_c, np.inf, m_c)
        i_a = np.where(held_a, 0.0, i_a)
        i_c = np.where(held_c, 0.0, i_c)
        ax = np.where(lever, point[:, 0] - x_a, 0.0)
        ay = np.where(lever, point[:, 1] - y_a, 0.0)
        cx = np.where(lever, point[:, 0] - x_c, 0.0)
        cy = np.where(lever, point[:, 1] - y_c, 0.0)
        a_n, c_n = ax * ny - ay * nx, cx * ny - cy * nx
        # Speeds at the contact (a clockwise turn w moves a point at arm (x, y) by w (y, -x)).
        rel = (vx_c + w_c * cy - vx_a - w_a * ay) * nx + (vy_c - w_c * cx - vy_a + w_a * ax) * ny
        inv_a, inv_c = 1.0 / m_a, 1.0 / m_c
        eff = inv_a + inv_c + a_n**2 * i_a + c_n**2 * i_c
        j = np.where(rel < 0, -rel / eff, 0.0)
        # The overlap is undone in part the same way, through masses and inertias (turning as
        # well as moving the bodies: Box2D's position solver), the rest by moving them apart.
        share = _POSITION_SHARE * depth / eff
        apart = (1.0 - _POSITION_SHARE) * depth / (inv_a + inv_c)
        size = self.n * k
        flat_a, flat_c = bi * k + ma, bi * k + mc

        def total(values_a: F64, values_c: F64) -> F64:
            return (
                np.bincount(flat_a, values_a, size) + np.bincount(flat_c, values_c, size)
            ).reshape(self.n, k)

        move = share + apart
        dx = total(-move * inv_a * nx, move * inv_c * nx)
        dy = total(-move * inv_a * ny, move * inv_c * ny)
        dvx = total(-j * inv_a * nx, j * inv_c * nx)
        dvy = total(-j * inv_a * ny, j * inv_c * ny)
        dturn = total(j * a_n * i_a, -j * c_n * i_c)
        dturn_pos = total(share * a_n * i_a, -share * c_n * i_c)
        self.x += dx[:, :r]
        self.y += dy[:, :r]
        self.heading += np.degrees(dturn_pos[:, :r])
        self.rvx += dvx[:, :r]
        self.rvy += dvy[:, :r]
        self.rw += dturn[:, :r]
        free = self.carrier < 0
        self.gx += np.where(free, dx[:, r:], 0.0)
        self.gy += np.where(free, dy[:, r:], 0.0)
        self.gvx += np.where(free, dvx[:, r:], 0.0)
        self.gvy += np.where(free, dvy[:, r:], 0.0)
        self._follow_clamps()

    def _at_walls(self) -> tuple[I64, I64]:
        """Which wall each body (robots, then goals) touches: -1, 0 or +1 along x and y
        (B, R + G) each."""
        lim = self.field.half - 1e-4
        fwd, right = self._axes()
        ex = self.half_l * np.abs(fwd[..., 0]) + self.half_w * np.abs(right[..., 0])
        ey = self.half_l * np.abs(fwd[..., 1]) + self.half_w * np.abs(right[..., 1])
        x = np.concatenate([self.x, self.gx], 1)
        y = np.concatenate([self.y, self.gy], 1)
        rx = np.concatenate([ex, np.broadcast_to(self.goal_radius, self.gx.shape)], 1)
        ry = np.concatenate([ey, np.broadcast_to(self.goal_radius, self.gy.shape)], 1)
        wx = np.where(x + rx >= lim, 1, np.where(x - rx <= -lim, -1, 0))
        wy = np.where(y + ry >= lim, 1, np.where(y - ry <= -lim, -1, 0))
        return wx, wy

    def _body_mass(self) -> tuple[F64, F64]:
        """Each robot's mass and moment of inertia about its centre (a box), (B, R)."""
        mass = np.broadcast_to(self.mass, (self.n, self.n_robots))
        return mass, mass * ((2 * self.half_w) ** 2 + (2 * self.half_l) ** 2) / 12.0

    def _wall_impulses(self) -> None:
        """A robot meeting a wall: the wall takes out the speed of its deepest corner into it,
        through the robot's mass and inertia, so a robot turning against a wall is stopped
        turning as well as pushed (what PyBullet's contact does). The goal in its clamp is
        only kept inside (_contain), as World does. Only robots whose bounding circle reaches
        a wall are worked out."""
        lim = self.field.half
        near = np.maximum(np.abs(self.x), np.abs(self.y)) + self.radius > lim
        bi, ri = np.nonzero(near)
        if not len(bi):
            return
        rad = np.radians(self.heading[bi, ri])
        fwd = np.stack([np.sin(rad), np.cos(rad)], -1)
        right = np.stack([fwd[:, 1], -fwd[:, 0]], -1)
        x, y = self.x[bi, ri], self.y[bi, ri]
        centre = np.stack([x, y], -1)
        sa = np.array([1.0, 1.0, -1.0, -1.0])[None, :, None]
        sb = np.array([1.0, -1.0, -1.0, 1.0])[None, :, None]
        hl = self.half_l[ri][:, None, None]
        hw = self.half_w[ri][:, None, None]
        pts = centre[:, None] + sa * hl * fwd[:, None] + sb * hw * right[:, None]  # (C, 4, 2)
        mass, inertia = self._body_mass()
        m, inert = mass[bi, ri], inertia[bi, ri]
        vx, vy, w = self.rvx[bi, ri], self.rvy[bi, ri], self.rw[bi, ri]
        rows = np.arange(len(bi))
        turn = np.zeros(len(bi))  # radians clockwise, the position correction's
        for axis in (0, 1):
            for side in (-1.0, 1.0):
                pen = side * pts[..., axis] - lim
                k = np.argmax(pen, axis=1)
                depth = pen[rows, k]
                hit = depth > 0
                if not hit.any():
                    continue
                px, py = pts[rows, k, 0] - x, pts[rows, k, 1] - y
                nx, ny = (-side, 0.0) if axis == 0 else (0.0, -side)
                rxn = px * ny - py * nx
                eff = 1.0 / m + rxn**2 / inert
                u = (vx + w * py) * nx + (vy - w * px) * ny
                j = np.where(hit & (u < 0), -u / eff, 0.0)
                vx = vx + j * nx / m
                vy = vy + j * ny / m
                w = w - rxn * j / inert
                # Out of the wall through mass and inertia alike (the deepest corner leaves it).
                push = np.where(hit, _POSITION_SHARE * depth / eff, 0.0)
                x = x + push * nx / m
                y = y + push * ny / m
                turn -= rxn * push / inert
                pts = pts + np.stack([push * nx / m, push * ny / m], -1)[:, None]
        self.rvx[bi, ri] = vx
        self.rvy[bi, ri] = vy
        self.rw[bi, ri] = w
        self.x[bi, ri] = x
        self.y[bi, ri] = y
        self.heading[bi, ri] += np.degrees(turn)

    def _contain(self) -> None:
        """Robots (with the goal each carries) and free goals inside the walls (World._contain)."""
        self._wall_impulses()
        lim = self.field.half
        fwd, right = self._axes()
        ex = self.half_l * np.abs(fwd[..., 0]) + self.half_w * np.abs(right[..., 0])
        ey = self.half_l * np.abs(fwd[..., 1]) + self.half_w * np.abs(right[..., 1])
        lo_x, hi_x = self.x - ex, self.x + ex
        lo_y, hi_y = self.y - ey, self.y + ey
        holding = self.carried >= 0
        if holding.any():
            gi = np.where(holding, self.carried, 0)
            cx, cy = self.clamp_points(gi)
            rad = self.goal_radius[gi]
            lo_x = np.where(holding, np.minimum(lo_x, cx - rad), lo_x)
            hi_x = np.where(holding, np.maximum(hi_x, cx + rad), hi_x)
            lo_y = np.where(holding, np.minimum(lo_y, cy - rad), lo_y)
            hi_y = np.where(holding, np.maximum(hi_y, cy + rad), hi_y)
        sx = np.maximum(0.0, -lim - lo_x) - np.maximum(0.0, hi_x - lim)
        sy = np.maximum(0.0, -lim - lo_y) - np.maximum(0.0, hi_y - lim)
        self.x += sx
        self.y += sy
        free = self.carrier < 0
        gl = lim - self.goal_radius
        nx, ny = np.clip(self.gx, -gl, gl), np.clip(self.gy, -gl, gl)
        self.gvx = np.where(free & (nx != self.gx), 0.0, self.gvx)
        self.gvy = np.where(free & (ny != self.gy), 0.0, self.gvy)
        self.gx = np.where(free, nx, self.gx)
        self.gy = np.where(free, ny, self.gy)
        self._follow_clamps()

    # --- goals ------------------------------------------------------------------------------

    def clamp_offsets(self, goal: I64) -> F64:
        """Robot centre to the centre of goal `goal` (B, R) in its clamp (World.clamp_offset)."""
        return self.half_l + self.goal_radius[goal] + 0.005

    def clamp_points(self, goal: I64) -> tuple[F64, F64]:
        """Where goal `goal` (B, R) sits in each robot's clamp (World.clamp_point)."""
        back = self.clamp_offsets(goal) * np.where(self.front_clamp, 1.0, -1.0)
        rad = np.radians(self.heading)
        return self.x + back * np.sin(rad), self.y + back * np.cos(rad)

    def _follow_clamps(self) -> None:
        holding = self.carried >= 0
        if not holding.any():
            return
        gi = np.where(holding, self.carried, 0)
        cx, cy = self.clamp_points(gi)
        bi, ri = np.nonzero(holding)
        g = gi[bi, ri]
        self.gx[bi, g] = cx[bi, ri]
        self.gy[bi, g] = cy[bi, ri]
        self.gvx[bi, g] = self.rvx[bi, ri]
        self.gvy[bi, g] = self.rvy[bi, ri]

    def _clamp(self, want: NDArray[np.int8], live: Bool, events: FastEvents) -> None:
        """World._clamp for every match, robot by robot in index order (a goal the first
        robot takes is gone for the second)."""
        auto = self.config.auto_clamp
        for i, rc in enumerate(self.robot_configs):
            grab = np.where(want[:, i] < 0, auto, want[:, i] > 0) & live
            release = (want[:, i] == 0) & (self.carried[:, i] >= 0) & live
            if release.any():
                g = self.carried[release, i]
                self.carrier[np.flatnonzero(release), g] = -1
                self.carried[release, i] = -1
            take = grab & (self.carried[:, i] < 0)
            if not take.any():
                continue
            rad = np.radians(self.heading[:, i : i + 1])
            fs, fc = np.sin(rad), np.cos(rad)
            dx = self.gx - self.x[:, i : i + 1]
            dy = self.gy - self.y[:, i : i + 1]
            across = dx * fc - dy * fs
            ahead = dx * fs + dy * fc
            gap = (ahead if rc.clamp == "front" else -ahead) - rc.length_m / 2 - self.goal_radius
            ok = (
                (gap >= -0.03)
                & (gap <= rc.clamp_reach_m)
                & (np.abs(across) <= rc.clamp_half_width_m)
            )
            ok &= (self.carrier < 0) & take[:, None]
            found = ok.any(axis=1)
            if not found.any():
                continue
            best = np.argmin(np.where(ok, gap, np.inf), axis=1)
            rows = np.flatnonzero(found)
            self.carried[rows, i] = best[rows]
            self.carrier[rows, best[rows]] = i
            events.clamped[rows, i] = best[rows]

    # --- rings ------------------------------------------------------------------------------

    def _local(self, i: int) -> tuple[F64, F64]:
        """Every ring in robot i's frame: across (right) and along (forward), (B, N)."""
        rad = np.radians(self.heading[:, i : i + 1])
        s, c = np.sin(rad), np.cos(rad)
        px = self.ring_xy[..., 0] - self.x[:, i : i + 1]
        py = self.ring_xy[..., 1] - self.y[:, i : i + 1]
        return px * c - py * s, px * s + py * c

    def _intake(self, live: Bool, events: FastEvents) -> None:
        """World._intake: rings in the intake's zone, nearest the bumper first, up to the room."""
        rad = self.ring_radius
        for i, rc in enumerate(self.robot_configs):
            room = self.room[:, i]
            can = live & self.intake_on[:, i] & (room > 0) & (self.v[:, i] >= -0.05)
            if not can.any():
                continue
            lx, ly = self._local(i)
            front = rc.length_m / 2
            inside = (np.abs(lx) <= rc.intake_width_m / 2) & (ly >= front - rad)
            inside &= (ly <= front + rc.intake_depth_m + rad) & self.ring_floor & can[:, None]
            counts = inside.sum(axis=1)
            if not counts.any():
                continue
            rows = np.flatnonzero(counts)
            key = np.where(inside[rows], ly[rows], np.inf)
            order = np.argsort(key, axis=1, kind="stable")
            rank = np.empty_like(order)
            np.put_along_axis(rank, order, np.arange(key.shape[1])[None], axis=1)
            taken = inside[rows] & (rank < room[rows, None])
            self.ring_floor[rows] &= ~taken
            n_taken = taken.sum(axis=1)
            self.held[rows, i] += n_taken
            self.collected[rows, i] += n_taken
            events.collected[rows, i] += n_taken

    def _push_rings(self) -> None:
        """World._push_rings: floor rings under a robot's body move out across the nearer side."""
        rad = self.ring_radius
        lim = self.field.half - rad
        for i in range(self.n_robots):
            hx, hy = self.half_w[i] + rad, self.half_l[i] + rad
            lx, ly = self._local(i)
            inside = (np.abs(lx) < hx) & (np.abs(ly) < hy) & self.ring_floor
            if not inside.any():
                continue
            sideways = hx - np.abs(lx) <= hy - np.abs(ly)
            nlx = np.where(inside & sideways, np.where(lx >= 0, hx, -hx), lx)
            nly = np.where(inside & ~sideways, np.where(ly >= 0, hy, -hy), ly)
            rad_h = np.radians(self.heading[:, i : i + 1])
            s, c = np.sin(rad_h), np.cos(rad_h)
            fx = self.x[:, i : i + 1] + nlx * c + nly * s
            fy = self.y[:, i : i + 1] - nlx * s + nly * c
            self.ring_xy[..., 0] = np.where(inside, np.clip(fx, -lim, lim), self.ring_xy[..., 0])
            self.ring_xy[..., 1] = np.where(inside, np.clip(fy, -lim, lim), self.ring_xy[..., 1])

    def _transfer(self, live: Bool, events: FastEvents) -> None:
        """World._transfer: a held ring onto the carried goal every ring_transfer_s."""
        active = (self.carried >= 0) & (self.held > 0) & live[:, None]
        self.transfer = np.where(
            active, self.transfer + self.dt, np.where(live[:, None], 0.0, self.transfer)
        )
        period = np.array([rc.ring_transfer_s for rc in self.robot_configs])
        due = active & (self.transfer >= period)
        while due.any():
            self.transfer = np.where(due, self.transfer - period, self.transfer)
            self.held -= due
            events.scored += due
            bi, ri = np.nonzero(due)
            np.add.at(self.goal_rings, (bi, self.carried[bi, ri]), 1)
            due = due & (self.held > 0) & (self.transfer >= period)

    # --- the rules --------------------------------------------------------------------------

    def score(self) -> dict[str, tuple[I64, ...]]:
        """By alliance: (rings, goals in zone, goals elevated, robots elevated, total), (B,)."""
        return rules.ring_race_score(
            self.field,
            self.alliances,
            np.stack([self.x, self.y], -1),
            np.stack([self.gx, self.gy], -1),
            self.goal_rings,
            self.carrier,
        )

    def totals(self) -> tuple[I64, I64]:
        """Red's and blue's match score now, (B,) each."""
        s = self.score()
        return s["red"][4], s["blue"][4]

    def gps_pose(self) -> F64:
        """Each robot's pose latency_s ago (GPS, before noise), (B, R, 3): World's history
        interpolation, with one past pose (unsupported() refuses longer latencies)."""
        lat = np.array([rc.gps.latency_s for rc in self.robot_configs])
        now = np.stack([self.x, self.y, self.heading], -1)
        t = self.time_s[:, None] - lat[None]
        span = (self.time_s - self.prev_time)[:, None]
        late = (t < self.time_s[:, None]) & (self.steps[:, None] > 0)
        a = np.where(span > 0, (t - self.prev_time[:, None]) / np.where(span > 0, span, 1.0), 1.0)
        a = np.clip(a, 0.0, 1.0)
        prev = self.prev_pose
        dh = (now[..., 2] - prev[..., 2] + 180.0) % 360.0 - 180.0
        x = prev[..., 0] + a * (now[..., 0] - prev[..., 0])
        y = prev[..., 1] + a * (now[..., 1] - prev[..., 1])
        hd = prev[..., 2] + a * dh
        out = np.stack([x, y, hd], -1)
        # At the start only the first pose exists: World reads it.
        return np.where(late[..., None], out, np.where((self.steps == 0)[:, None, None], now, out))


def _into_wall(wall_x: I64, wall_y: I64, dx: F64, dy: F64) -> Bool:
    """Whether a push along (dx, dy) drives a body against the wall it touches."""
    return ((wall_x != 0) & (dx * wall_x > 1e-6)) | ((wall_y != 0) & (dy * wall_y > 1e-6))
