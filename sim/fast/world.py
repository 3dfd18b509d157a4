"""Training-fidelity physics and rules for a batch of matches.

Every array's first axis is the match (B), the second the robot (R, red first, as World lists
them), the goal (G, the field file's order) or the ring (N). One step does for every match at
once what sim.world.physics.World does for one in training fidelity:

1. the commands pass the acceleration and speed limits (a non-finite command is a stop), and
   each robot's velocity is set once for the step, as World sets its body's;
2. `substeps` times (sim.fast.kernels.substeps, a compiled loop over the matches): robots move,
   free goals slide and slow (Bullet's multibody drag, World's floor friction), then the
   contacts: robot against robot (boxes: the axis of least overlap, the point where the faces
   meet), robot against goal (box against disc), goal against goal, each an inelastic impulse
   and a position correction through both bodies' masses and inertias; a goal in a clamp
   pushes with its own mass without moving its robot (World puts it back in the clamp); a body
   pushed against a wall stands like the wall across it and slides along it against the
   wall's friction; the walls stop robots' corners and keep everything in;
3. the clamps take and let go of goals, carried goals follow their clamps, intakes take the
   rings their zones reach (nearest the bumper first), held rings move onto carried goals, in
   numpy, one array operation per rule;
4. the rules: pins (sim.world.rules.pin_step) and the score (rules.ring_race_score).

The whole game (WorldConfig.game = "tipping_point") adds, on sim.world's compiled rules that World
calls too (sim.world.batch: the arrays they read): a tug of war before the substeps
(mechanisms.tug_of_war: the winner's speed share, the loser held), the isolation barrier and the
boards' contacts after them (seesaw.board_contacts, goal_board_contacts), goals contested and
their losers dragged after the clamps, rings placed by each mechanism (mechanisms.place_rings),
and at the step's end the boards' tilt (seesaw.step_tilts), the fouls (rules.game_fouls) and,
where the isolation period ended, its bonus and win point (rules.game_autonomous); the score is
rules.game_score.

Where World asks PyBullet (contacts, the solver's pushes), this models them with the same
masses, speeds and shapes, fitted to PyBullet's answers (docs/notes/2026-11-28-fast-backend.md),
so the two agree closely but not bit for bit; everything else (limits, clamp, intake, transfer,
the rules, the start's randomness) is the same arithmetic. What it does not model, ConfigError
names (unsupported()).
"""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.geometry import AllianceName, wrap_heading
from sim.config import RobotConfig, WorldConfig
from sim.errors import ConfigError, WorldError
from sim.fast import kernels
from sim.field import FieldSpec, load_field
from sim.world import mechanisms, rules, seesaw
from sim.world.batch import GameBatch, game_consts
from sim.world.sensors import interpolate_pose
from sim.world.start import floor_rings, robot_starts

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
# A body pushed against a wall slides along it against friction. A goal's is PyBullet's: Bullet
# multiplies the bodies' coefficients, the goal's 0.5 and the wall's default 0.5. A robot's
# (whose coefficient is 0) is fitted: in PyBullet a robot pushed into a wall by another stays put
# where a frictionless one drifts along it (tests/sim/fast/test_game.py's isolation scene), and
# the same 0.25 agrees as well with PyBullet's ring-race matches (the note of 2026-11-28).
_GOAL_WALL_FRICTION = 0.5 * 0.5
_ROBOT_WALL_FRICTION = 0.25
_UNLIMITED = 1 << 30  # the room of an intake that never fills
_BARRIER_HALF = 0.01  # half the isolation barrier's thickness (World._build_barrier)


@dataclass
class FastEvents:
    """What one step did in every match (robot indices as World's)."""

    collected: I64  # (B, R) rings each robot took in
    scored: I64  # (B, R) rings each robot moved onto its goal
    clamped: I64  # (B, R) the goal each robot's clamp took this step, -1 none
    pins: Bool  # (B, P) each red-blue pair (FastWorld.pin_pairs) pinned this step
    match_over: Bool  # (B,) the match is over (it ended with this step or before)
    fouls: Bool  # (B, R, 3) the whole game: each robot called for each foul kind this step
    phase_changed: Bool  # (B,) the isolation period ended with this step


def unsupported(config: WorldConfig) -> list[str]:
    """What of `config` the batched backend does not model (empty: it plays this world)."""
    out = []
    if config.fidelity != "training":
        out.append("fidelity = 'high' (the fast path is training fidelity)")
    if config.occlude_with_rings:
        out.append("occlude_with_rings (rings hiding rings)")
    for name in (*config.red, *config.blue):
        rc = config.robots[name]
        if rc.gps.latency_s > config.control_dt:
            out.append(f"robot {name}: GPS latency longer than one control step")
    return out


class FastWorld:
    """A batch of `n_matches` matches in training fidelity (module docstring)."""

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
        self.goal_radius = self.field.goal_base_radii.copy()
        self.goal_mass = np.array([g.mass_kg for g in self.field.goals])
        # Each robot's clamp point for each goal, (R, G) (World.clamp_offset): its signed
        # distance ahead of the robot's centre, negative behind a back clamp.
        offsets = self.half_l[:, None] + self.goal_radius[None] + 0.005
        self.clamp_offsets = offsets * np.where(self.front_clamp, 1.0, -1.0)[:, None]
        self.n_goals = len(self.field.goals)
        reds = [i for i, a in enumerate(self.alliances) if a == "red"]
        blues = [i for i, a in enumerate(self.alliances) if a == "blue"]
        self.pin_pairs: list[tuple[int, int]] = [(a, b) for a in reds for b in blues]
        pairs = [(i, j) for i in range(self.n_robots) for j in range(i + 1, self.n_robots)]
        self._pairs = np.array(pairs, dtype=np.int64).reshape(-1, 2)
        self.ring_radius = self.field.ring.radius
        self.ring_z = self.field.ring.thickness / 2
        # The whole game (sim.world.batch): its rules' constants and each robot's mechanism.
        self.game = cfg.game == "tipping_point"
        self.isolation_s = cfg.isolation_s
        self.barrier = cfg.isolation_s > 0 and cfg.isolation_barrier
        self.consts = game_consts(
            self.field, cfg, [(a, rc) for a, rc in zip(self.alliances, rcs, strict=True)]
        )
        self.loads_base = np.array([rc.loads == "base" for rc in rcs])
        self.reaches_high = np.array([rc.reaches_high_branch for rc in rcs])
        self.high_cap = np.array([g.high_branch_capacity for g in self.field.goals], np.int64)
        self.branch_cap = np.array([g.branch_capacity for g in self.field.goals], np.int64)
        self.start_tilt = np.zeros(2)
        for plat in self.field.platforms:
            code = 0 if plat.alliance == "red" else 1
            self.start_tilt[code] = seesaw.start_tilt(plat, self.field.seesaw) if self.game else 0
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
        # The whole game (GameBatch's arrays): a tug of war's second robot on each goal, the
        # rings on its high branch and in its base, the board each robot drove onto, the
        # boards' tilt, the fouls and the contacts going on, the autonomous period's result.
        self.contester = np.full((b, g), -1, dtype=np.int64)
        self.rings_high = np.zeros((b, g), dtype=np.int64)
        self.rings_base = np.zeros((b, g), dtype=np.int64)
        self.on_platform = np.full((b, r), -1, dtype=np.int64)
        self.tilt = np.zeros((b, 2))
        self.fouls = np.zeros((b, 2, 3), dtype=np.int64)
        self.foul_contacts = np.zeros((b, r, r + 1, 3), dtype=bool)
        self.auto_bonus = np.zeros((b, 2), dtype=np.int64)
        self.auto_win_point = np.zeros((b, 2), dtype=np.int64)
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
        preload = f.ring.preloads_per_robot if cfg.preloads else 0
        for k, rng in zip(which, rngs, strict=True):
            poses = robot_starts(f, cfg, self.lineup, rng)
            self.x[k], self.y[k], self.heading[k] = np.array(poses).reshape(-1, 3).T
            self.ring_xy[k] = floor_rings(f, cfg, rng)
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
        self.contester[which] = -1
        self.rings_high[which] = 0
        self.rings_base[which] = 0
        self.on_platform[which] = -1
        self.tilt[which] = self.start_tilt
        self.fouls[which] = 0
        self.foul_contacts[which] = False
        self.auto_bonus[which] = 0
        self.auto_win_point[which] = 0
        self.ring_floor[which] = True
        self.steps[which] = 0
        self.time_s[which] = 0.0
        self.over[which] = False
        self.prev_pose[which] = np.stack([self.x[which], self.y[which], self.heading[which]], -1)
        self.prev_time[which] = 0.0
        return rngs

    def place_robot(self, k: int, i: int, x: float, y: float, heading_deg: float) -> None:
        """Teleport robot i of match k (at rest; the goal in its clamp follows), as
        World.place_robot does."""
        self.x[k, i], self.y[k, i] = float(x), float(y)
        self.heading[k, i] = float(wrap_heading(heading_deg))
        self.v[k, i] = self.w[k, i] = self.measured_v[k, i] = self.measured_w[k, i] = 0.0
        self.prev_pose[k, i] = (self.x[k, i], self.y[k, i], self.heading[k, i])
        if self.game:  # set down by hand: on a board it overlaps, as World.place_robot
            ex, ey = seesaw.robot_extents(self.consts, i, float(self.heading[k, i]))
            self.on_platform[k, i] = seesaw.board_under(self.consts, float(x), float(y), ex, ey)
        g = int(self.carried[k, i])
        if g >= 0:
            back = float(self.clamp_offsets[i, g])
            rad = np.radians(self.heading[k, i])
            self.gx[k, g] = self.x[k, i] + back * np.sin(rad)
            self.gy[k, g] = self.y[k, i] + back * np.cos(rad)

    def place_goal(self, k: int, g: int, x: float, y: float) -> None:
        """Put free goal g of match k at (x, y), at rest, as World.place_goal does."""
        if self.carrier[k, g] >= 0:
            raise WorldError(f"goal {self.field.goals[g].name} is carried; release it first")
        self.gx[k, g], self.gy[k, g] = float(x), float(y)
        self.gvx[k, g] = self.gvy[k, g] = 0.0

    # --- stepping ---------------------------------------------------------------------------

    def step(
        self,
        linear: F64,
        angular: F64,
        intake: Bool | None = None,
        clamp: NDArray[np.int8] | F64 | None = None,
    ) -> FastEvents:
        """One control step of every match. linear (m/s), angular (rad/s clockwise): (B, R);
        intake (B, R) runs the intake (default on); clamp (B, R): 1 grab, 0 release, -1 leave
        it to the auto clamp (default -1). A match already over does not move."""
        b, r = self.n, self.n_robots
        live = ~self.over
        # Every input is checked before anything moves: a bad one leaves the world as it was.
        lin = _commands(linear, "linear", b, r)
        ang = _commands(angular, "angular", b, r)
        on = np.ones((b, r), dtype=bool) if intake is None else _commands(intake, "intake", b, r)
        want = np.full((b, r), -1.0) if clamp is None else _commands(clamp, "clamp", b, r)
        bad = ~(np.isfinite(lin) & np.isfinite(ang)) | ~live[:, None]
        lin = np.where(bad, 0.0, np.clip(lin, -self.max_v, self.max_v))
        ang = np.where(bad, 0.0, np.clip(ang, -self.max_w, self.max_w))
        self.v += np.clip(lin - self.v, -self.acc_v, self.acc_v)
        self.w += np.clip(ang - self.w, -self.acc_w, self.acc_w)
        self.v[~live] = 0.0
        self.w[~live] = 0.0
        self.gvx[~live] = 0.0
        self.gvy[~live] = 0.0
        self.intake_on = on.astype(bool)
        before = np.stack([self.x, self.y, self.heading], -1)
        goals_before = (self.gx.copy(), self.gy.copy())
        v, w = self.v, self.w
        if self.game:  # a tug of war slows its winner and holds its loser
            share, dragged = mechanisms.tug_of_war(
                self.consts, self.carrier, self.contester, self.v, self.w, live
            )
            v = np.where(np.isnan(share), self.v, self.v * share)
            w = np.where(dragged, 0.0, self.w)
        # As World sets each body's velocity once a control step (PyBullet keeps it in the
        # field frame through the substeps, where contacts change it).
        rad = np.radians(self.heading)
        self.rvx = v * np.sin(rad)
        self.rvy = v * np.cos(rad)
        self.rw = w.copy()
        state = (
            self.x, self.y, self.heading, self.rvx, self.rvy, self.rw,
            self.gx, self.gy, self.gvx, self.gvy, self._moving_clamps(), self.carrier,
            self.contester,
        )  # fmt: skip
        with kernels.threads_for(self.n):
            kernels.substeps(
                state, self.half_w, self.half_l, self.mass, self.radius, self.clamp_offsets,
                self.goal_radius, self.goal_mass, self.field.half, self.dt / self.substeps,
                self.substeps, _GOAL_DAMPING, _POSITION_SHARE, _GOAL_WALL_FRICTION,
                _ROBOT_WALL_FRICTION,
            )  # fmt: skip
        self.heading = np.asarray(wrap_heading(self.heading), dtype=np.float64)
        isolation = live & (self.time_s < self.isolation_s)
        if self.barrier and isolation.any():
            self._barrier(isolation)
        if self.game:
            gs = self.game_batch()
            seesaw.board_contacts(self.consts, gs, before[..., 0], before[..., 1], live)
            seesaw.goal_board_contacts(self.consts, gs, *goals_before, live)
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
            fouls=np.zeros((b, r, 3), dtype=bool),
            phase_changed=isolation & (self.time_s >= self.isolation_s),
        )
        self._clamp(want, live, events)
        self._follow_clamps(before[..., 2])
        self._intake(live, events)
        if self.config.push_rings:
            self._push_rings()
        self._transfer(live, events)
        if self.pin_pairs:
            touching = self._touching()
            timers, pinned = rules.pin_step(self.pin_timers, touching, self.dt, self.pin_time_s)
            self.pin_timers = np.where(live[:, None], timers, self.pin_timers)
            events.pins = pinned & live[:, None]
        if self.game:
            self._game_rules(live, events)
        ended = live & (self.time_s >= self.match_length_s - 1e-9)
        self.over |= ended
        events.match_over = self.over.copy()
        return events

    def game_batch(self) -> GameBatch:
        """The whole game's state of every match as its rules read it (the arrays themselves,
        not copies: the rules' in-place updates are this world's)."""
        return GameBatch(
            self.x, self.y, self.heading, self.v, self.on_platform, self.gx, self.gy,
            self.carrier, self.contester, self.goal_rings, self.rings_high, self.rings_base,
            self.tilt, self.fouls, self.auto_bonus, self.auto_win_point,
        )  # fmt: skip

    def _game_rules(self, live: Bool, events: FastEvents) -> None:
        """The whole game's end of a step: the boards swing, fouls are called, and where the
        isolation period ended its bonus and win point are judged (World's order)."""
        gs = self.game_batch()
        seesaw.step_tilts(self.consts, gs, self.carried, self.dt, live)
        contact = -self._overlap_matrix() <= self.config.pin_contact_m
        events.fouls = rules.game_fouls(
            self.consts, gs, self.time_s, contact, self.foul_contacts, live
        )
        judged = events.phase_changed
        if judged.any():
            points = np.ascontiguousarray(rules.game_score(self.consts, gs)[:, :, 4])
            bonus, win, _ = rules.game_autonomous(self.consts, gs, points)
            self.auto_bonus[judged] = bonus[judged]
            self.auto_win_point[judged] = win[judged]

    def _extents(self, robots: I64, heading_deg: F64) -> tuple[F64, F64]:
        """Half the x and y extents of robots' footprints' bounding boxes at headings (deg),
        as seesaw.robot_extents works them out for one."""
        rad = np.radians(heading_deg)
        c, s = np.abs(np.cos(rad)), np.abs(np.sin(rad))
        hw, hl = self.half_w[robots], self.half_l[robots]
        return hw * c + hl * s, hw * s + hl * c

    def _moving_clamps(self) -> I64:
        """(B, R): the goal each robot's clamp moves through the substeps, -1 none (a tug of
        war's loser holds its goal but is dragged with it after the step)."""
        g = np.where(self.carried >= 0, self.carried, 0)
        holder = np.take_along_axis(self.carrier, g, axis=1)
        mine = (self.carried >= 0) & (holder == np.arange(self.n_robots)[None])
        return np.where(mine, self.carried, -1)

    def _barrier(self, isolation: Bool) -> None:
        """The isolation period's centre-line wall that only robots hit (World's 2 cm thick
        body): a robot's footprint stays on its side of it."""
        ex, _ = self._extents(np.arange(self.n_robots), self.heading)
        wall = _BARRIER_HALF + ex
        right = self.x >= 0
        x = np.where(right, np.maximum(self.x, wall), np.minimum(self.x, -wall))
        np.copyto(self.x, x, where=isolation[:, None])

    # --- contacts ---------------------------------------------------------------------------

    def overlaps(self, pairs: NDArray[np.int64] | None = None) -> F64:
        """(B, P): the least overlap of each robot pair's boxes (negative: the gap between
        them); pairs (P, 2) of robot indices, default every pair."""
        pairs = self._pairs if pairs is None else np.asarray(pairs, dtype=np.int64).reshape(-1, 2)
        with kernels.threads_for(self.n):
            return kernels.pair_overlaps(
                self.x, self.y, self.heading, self.half_w, self.half_l, pairs
            )

    def _overlap_matrix(self) -> F64:
        """(B, R, R): every robot pair's least overlap (overlaps), both ways round."""
        out = np.full((self.n, self.n_robots, self.n_robots), -np.inf)
        if len(self._pairs):
            o = self.overlaps()
            out[:, self._pairs[:, 0], self._pairs[:, 1]] = o
            out[:, self._pairs[:, 1], self._pairs[:, 0]] = o
        return out

    def _touching(self) -> Bool:
        """Red-blue pairs within pin_contact_m hull to hull (World._touching), (B, P_pin)."""
        pairs = np.array(self.pin_pairs, dtype=np.int64).reshape(-1, 2)
        return -self.overlaps(pairs) <= self.config.pin_contact_m

    # --- goals ------------------------------------------------------------------------------

    def clamp_points(self, goal: I64) -> tuple[F64, F64]:
        """Where goal `goal` (B, R) sits in each robot's clamp (World.clamp_point)."""
        back = self.clamp_offsets[np.arange(self.n_robots)[None], goal]
        rad = np.radians(self.heading)
        return self.x + back * np.sin(rad), self.y + back * np.cos(rad)

    def _follow_clamps(self, headings_before: F64) -> None:
        """Carried goals to their carriers' clamps. A tug of war's loser (the goal's contester)
        is dragged with it (World._carry_goals): it keeps its place against the goal, turning by
        as much as the carrier turned since headings_before (B, R); a wall that stops it pushes
        the carrier and the goal back with it."""
        holding = self._moving_clamps() >= 0
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
        bi, g = np.nonzero((self.contester >= 0) & (self.carrier >= 0))
        if len(bi):
            self._drag(bi, g, headings_before)

    def _drag(self, bi: I64, g: I64, headings_before: F64) -> None:
        """The tug of war's losers (contesters of goals g in matches bi) to their goals."""
        win, lose = self.carrier[bi, g], self.contester[bi, g]
        turned = self.heading[bi, win] - headings_before[bi, win]
        h = (headings_before[bi, lose] + turned) % 360.0
        self.heading[bi, lose] = h
        back = self.clamp_offsets[lose, g]
        rad = np.radians(h)
        x = self.gx[bi, g] - back * np.sin(rad)
        y = self.gy[bi, g] - back * np.cos(rad)
        ex, ey = self._extents(lose, h)
        lim = self.field.half
        sx = np.maximum(0.0, -lim - (x - ex)) - np.maximum(0.0, x + ex - lim)
        sy = np.maximum(0.0, -lim - (y - ey)) - np.maximum(0.0, y + ey - lim)
        self.x[bi, lose], self.y[bi, lose] = x + sx, y + sy
        self.x[bi, win] += sx
        self.y[bi, win] += sy
        self.gx[bi, g] += sx
        self.gy[bi, g] += sy

    def _clamp(self, want: F64, live: Bool, events: FastEvents) -> None:
        """World._clamp for every match, robot by robot in index order (a goal the first
        robot takes is gone for the second)."""
        auto = self.config.auto_clamp
        for i, rc in enumerate(self.robot_configs):
            grab = np.where(want[:, i] < 0, auto, want[:, i] > 0) & live
            release = (want[:, i] == 0) & (self.carried[:, i] >= 0) & live
            if release.any():
                rows = np.flatnonzero(release)
                g = self.carried[rows, i]
                second = self.contester[rows, g] == i
                # The goal stays with the tug of war's other robot, if any.
                self.carrier[rows, g] = np.where(
                    second, self.carrier[rows, g], self.contester[rows, g]
                )
                self.contester[rows, g] = -1
                self.carried[rows, i] = -1
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
            free = self.carrier < 0
            if self.game:  # a goal one robot holds: one of the other alliance may clamp it too
                holder = self.consts.team[np.maximum(self.carrier, 0)]
                free |= (self.carrier >= 0) & (self.contester < 0) & (holder != self.consts.team[i])
            ok &= free & take[:, None]
            found = ok.any(axis=1)
            if not found.any():
                continue
            best = np.argmin(np.where(ok, gap, np.inf), axis=1)
            rows = np.flatnonzero(found)
            goal = best[rows]
            held = self.carrier[rows, goal] >= 0
            self.carrier[rows, goal] = np.where(held, self.carrier[rows, goal], i)
            self.contester[rows, goal] = np.where(held, i, self.contester[rows, goal])
            self.carried[rows, i] = goal
            events.clamped[rows, i] = goal

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
            if self.game:  # where each robot's mechanism puts it, robot by robot
                mechanisms.place_rings(
                    due, self.carried, self.goal_rings, self.rings_high, self.rings_base,
                    self.loads_base, self.reaches_high, self.high_cap, self.branch_cap,
                )  # fmt: skip
            else:
                bi, ri = np.nonzero(due)
                np.add.at(self.goal_rings, (bi, self.carried[bi, ri]), 1)
            due = due & (self.held > 0) & (self.transfer >= period)

    # --- the rules --------------------------------------------------------------------------

    def score(self) -> dict[str, tuple[I64, ...]]:
        """By alliance: (rings, goals in zone, goals elevated, robots elevated, total), (B,);
        the whole game's other fields are game_score's."""
        if self.game:
            rows = self.game_score()
            return {
                a: tuple(rows[:, k, f] for f in range(5)) for k, a in enumerate(rules.ALLIANCES)
            }
        return rules.ring_race_score(
            self.field,
            self.alliances,
            np.stack([self.x, self.y], -1),
            np.stack([self.gx, self.gy], -1),
            self.goal_rings,
            self.carrier,
        )

    def owners(self) -> tuple[I64, Bool, Bool]:
        """Each goal's owner (B, G: 0 none, 1 red, 2 blue), whether it is elevated (B, G) and
        whether each robot is (B, R), by this world's game's rules (rules.ring_race_owners,
        or the whole game's game_owners and game_judged)."""
        if self.game:
            gs = self.game_batch()
            owner, up = rules.game_owners(self.consts, gs)
            _, robots_up = rules.game_judged(self.consts, gs)
            return owner + 1, up, robots_up
        return rules.ring_race_owners(
            self.field,
            self.alliances,
            np.stack([self.x, self.y], -1),
            np.stack([self.gx, self.gy], -1),
            self.carrier,
        )

    def game_score(self) -> I64:
        """The whole game's score of every match, (B, 2, 12): by alliance (red, blue), the fields
        of sim.world.batch.SCORE_FIELDS (rules.game_score)."""
        return rules.game_score(self.consts, self.game_batch())

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
        out = np.stack(interpolate_pose(a, *np.moveaxis(prev, -1, 0), *np.moveaxis(now, -1, 0)), -1)
        # At the start only the first pose exists: World reads it.
        return np.where(late[..., None], out, np.where((self.steps == 0)[:, None, None], now, out))


def _commands(value: object, name: str, matches: int, robots: int) -> F64:
    """A (matches, robots) command array, or a ValueError naming the shape it must have."""
    arr = np.asarray(value, dtype=np.float64)
    if arr.shape != (matches, robots):
        raise ValueError(
            f"FastWorld.step: {name} must have shape ({matches}, {robots}) (matches, robots), "
            f"got {arr.shape}"
        )
    return arr
