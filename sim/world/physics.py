"""The simulated field's physics: PyBullet bodies for walls, goals, robots and rings, and stepping.

    world = World(WorldConfig())            # owns a p.DIRECT client; or World(cfg, client=cid)
    world.reset(np.random.default_rng(7))
    events = world.step([DriveCommand(0.5, 0.0), DriveCommand()])   # one control step per robot

The game's rules (scoring, goal ownership, pins, fouls) are sim.world.rules, the platform's
see-saw model sim.world.seesaw, and the sensors (GPS, camera, visibility) sim.world.sensors:
functions over the state this class keeps. WorldConfig.game picks the ring race (the default) or
the whole game (see-saw platforms, rings placed by each robot's mechanism, tugs of war over a
goal, fouls, the autonomous bonus).

Two fidelities (WorldConfig.fidelity):

training
    Planar physics: no gravity and no floor contacts, so PyBullet only resolves robot, goal and
    wall contacts (floor friction on goals is linear damping). Rings are not bodies at all: their
    positions live in numpy, pickup is a rectangle test in the robot frame and visibility is the
    prism geometry of sim.visibility. This is what makes a 1260-step match take under a second.
high
    Gravity, a floor, 240 Hz physics and every ring a dynamic body that robots push around; pickup
    uses the rings' real positions and visibility uses PyBullet ray tests.

Robots are boxes driven like a differential drive: each control step the commanded (v, w) passes
through the acceleration and speed limits and becomes the body's velocity; collisions push back.
Command angular rates are rad/s, positive clockwise (heading increasing), as in the protocol.
Robots are indexed red first, then blue, in the order WorldConfig lists them.
"""

from __future__ import annotations

import contextlib
import math
from collections import deque

import numpy as np
import pybullet as p

from jetson.autonomy.geometry import (
    AllianceName,
    field_to_robot,
    heading_sin_cos,
    heading_to_yaw,
    push_out_of_box,
    quaternion_yaw,
    robot_to_field,
    wrap_heading,
    yaw_quaternion,
    yaw_to_heading,
)
from sim.config import RobotConfig, WorldConfig
from sim.errors import WorldError
from sim.field import FieldSpec, load_field
from sim.world import mechanisms, rules, seesaw
from sim.world.batch import ALLIANCE_CODES, game_consts
from sim.world.start import floor_rings, robot_starts
from sim.world.state import (
    POST_RADIUS,
    RING_FLOOR,
    RING_HELD,
    RING_SCORED,
    AllianceScore,
    AutonomousResult,
    DriveCommand,
    Foul,
    GoalState,
    PlatformState,
    RobotState,
    StepEvents,
    intake_rect,
)

_PARK_Z = -5.0  # collected ring bodies wait here, under the floor and out of every ray
_ONE = np.ones(1, dtype=bool)  # a World is a live batch of one for the compiled rules
_GOAL_DAMPING = 0.99  # training: stands in for floor friction (a pushed goal slides ~0.2 m)


class World:
    def __init__(
        self,
        config: WorldConfig | None = None,
        *,
        field_spec: FieldSpec | None = None,
        client: int | None = None,
    ) -> None:
        self.config = config or WorldConfig()
        self.field = field_spec or load_field(self.config.field)
        self._owns_client = client is None
        self.client = p.connect(p.DIRECT) if client is None else client
        if self.client < 0:
            raise WorldError("could not start a PyBullet client")
        rules = self.field.rules
        self.interaction_s = self.config.interaction_s or rules.interaction_s
        self.isolation_s = self.config.isolation_s
        self.match_length_s = self.isolation_s + self.interaction_s
        self.pin_time_s = self.config.pin_time_s or rules.pin_time_s
        self.dt = self.config.control_dt
        self.substeps = self.config.substeps
        self.training = self.config.fidelity == "training"
        self.game = self.config.game == "tipping_point"  # the whole game, not the ring race
        self.lineup: list[tuple[AllianceName, str]] = [("red", n) for n in self.config.red] + [
            ("blue", n) for n in self.config.blue
        ]
        # The whole game's constants for its compiled rules (sim.world.batch).
        self.game_consts = game_consts(
            self.field, self.config, [(a, self.config.robots[n]) for a, n in self.lineup]
        )
        self.robots: list[RobotState] = []
        self.goals: list[GoalState] = []
        self.ring_xy = np.zeros((0, 2))
        self.ring_z = np.zeros(0)
        self.ring_state = np.zeros(0, dtype=np.int8)
        self.ring_owner = np.zeros(0, dtype=np.int16)  # robot (held) or goal (scored) index
        self.ring_bodies: list[int] = []
        self._ring_visuals: list[int] | None = None
        self._ring_visual_state: np.ndarray | None = None
        self._ring_visual_xy: np.ndarray | None = None
        self.time_s = 0.0
        self.steps = 0
        self.over = False
        self.pin_timers: dict[tuple[int, int], float] = {}  # sim.world.rules' pin clocks
        # The whole game (sim.world.state.WorldState documents them).
        self.platforms: dict[str, PlatformState] = {}
        self.fouls: list[Foul] = []
        self.autonomous: dict[str, AutonomousResult] | None = None
        self.foul_contacts: set[tuple[int, int, str]] = set()
        self._boards: dict[str, int] = {}  # alliance -> the hinged platform body
        self._tug: dict[int, float] = {}  # robot -> its speed's share in a tug of war
        self._dragged: set[int] = set()  # robots losing a tug of war (they neither drive nor turn)
        self._barrier: int | None = None
        self._ready = False
        # score() is asked for by every robot's info each step; it only changes when the world
        # does (a step or a scenario edit), so it is cached on those.
        self._edits = 0
        self._score_cache: tuple[tuple, dict[str, AllianceScore]] | None = None

    # --- lifecycle --------------------------------------------------------------------------

    def close(self) -> None:
        if self._owns_client and self.client >= 0:
            with contextlib.suppress(p.error):
                p.disconnect(physicsClientId=self.client)
            self.client = -1

    def __enter__(self) -> World:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    def reset(self, rng: np.random.Generator | None = None) -> None:
        """Rebuild the field for a new match. All randomness comes from `rng`."""
        rng = rng if rng is not None else np.random.default_rng(0)
        cid = self.client
        # Rebuilding (a few ms) rather than restoring keeps a reset match bit-identical to a new
        # one: no contact caches or constraint ids survive from the last match.
        p.resetSimulation(physicsClientId=cid)
        p.setGravity(0, 0, 0 if self.training else -9.81, physicsClientId=cid)
        if self.training:
            p.setPhysicsEngineParameter(
                fixedTimeStep=self.dt,
                numSubSteps=self.substeps,
                deterministicOverlappingPairs=1,
                physicsClientId=cid,
            )
        else:
            p.setPhysicsEngineParameter(
                fixedTimeStep=self.dt / self.substeps,
                numSubSteps=0,
                deterministicOverlappingPairs=1,
                physicsClientId=cid,
            )
        self._ring_visuals = None
        self._ring_visual_state = None
        self._edits += 1
        self.time_s = 0.0
        self.steps = 0
        self.over = False
        self.pin_timers = {}
        self.fouls = []
        self.autonomous = None
        self.foul_contacts = set()
        self._tug = {}
        self._dragged = set()
        self.platforms = (
            {
                p.alliance: PlatformState(p.alliance, seesaw.start_tilt(p, self.field.seesaw))
                for p in self.field.platforms
            }
            if self.game
            else {}
        )
        self._build_field()
        self._build_goals()
        self._build_robots(rng)
        self._build_rings(rng)
        if self.isolation_s > 0 and self.config.isolation_barrier:
            self._build_barrier()
        else:
            self._barrier = None
        for r in self.robots:
            r.history = deque(maxlen=max(4, int(r.config.gps.latency_s / self.dt) + 3))
            r.history.append((0.0, r.x, r.y, r.heading))
        self._ready = True

    # --- building ---------------------------------------------------------------------------

    def _rgba(self, rgb: tuple[int, int, int], alpha: float = 1.0) -> list[float]:
        return [rgb[0] / 255.0, rgb[1] / 255.0, rgb[2] / 255.0, alpha]

    def _static_box(
        self,
        center: tuple[float, float, float],
        half: tuple[float, float, float],
        rgb: tuple[int, int, int] | None,
        collide: bool,
    ) -> int:
        cid = self.client
        col = (
            p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=cid)
            if collide
            else -1
        )
        vis = (
            p.createVisualShape(
                p.GEOM_BOX, halfExtents=half, rgbaColor=self._rgba(rgb), physicsClientId=cid
            )
            if rgb is not None
            else -1
        )
        return p.createMultiBody(0, col, vis, basePosition=center, physicsClientId=cid)

    def _build_field(self) -> None:
        f = self.field
        half = f.half
        t = f.wall_thickness
        # Floor: a body in both fidelities (the camera sees it); it only collides in high.
        self.floor = self._static_box(
            (0, 0, -0.05), (half + t, half + t, 0.05), f.tile_rgb, not self.training
        )
        line_half = 0.0254
        for x0, y0, x1, y1 in f.lines:
            cx, cy = (x0 + x1) / 2, (y0 + y1) / 2
            hx = max(abs(x1 - x0) / 2, line_half)
            hy = max(abs(y1 - y0) / 2, line_half)
            self._static_box((cx, cy, 0.0005), (hx, hy, 0.0005), f.line_rgb, False)
        # Walls reach well below the floor in training so nothing squeezed against them can slip
        # under; their visible part is the field's wall height.
        depth = 0.5 if self.training else 0.0
        hz = (f.wall_height + depth) / 2
        zc = hz - depth
        self.walls = [
            self._static_box((sx * (half + t / 2), 0, zc), (t / 2, half + t, hz), f.wall_rgb, True)
            for sx in (-1, 1)
        ] + [
            self._static_box((0, sy * (half + t / 2), zc), (half + t, t / 2, hz), f.wall_rgb, True)
            for sy in (-1, 1)
        ]
        # Platforms are drawn but neither collide nor hide rings (a 3 in board hides little from
        # a camera 0.3 m up). The ring race draws a flat box (a robot "elevates" by ending the
        # match on it); the whole game a hinged board that sim.world.seesaw tips.
        self._boards = {}
        if self.game:
            for plat in f.platforms:
                self._boards[plat.alliance] = self._build_board(plat)
            return
        for plat in f.platforms:
            sx, sy = plat.size
            self._static_box(
                (plat.center[0], plat.center[1], plat.height / 2),
                (sx / 2, sy / 2, plat.height / 2),
                plat.rgb,
                False,
            )

    def _build_board(self, plat: object) -> int:
        """A see-saw: a fixed base at the hinge and the board on a revolute joint along y."""
        assert isinstance(plat, type(self.field.platforms[0]))
        cid = self.client
        sx, sy = plat.size
        thick = 0.01
        base_vis = p.createVisualShape(
            p.GEOM_BOX,
            halfExtents=(0.03, sy / 2, plat.height / 2),
            rgbaColor=self._rgba((40, 40, 40)),
            physicsClientId=cid,
        )
        board_vis = p.createVisualShape(
            p.GEOM_BOX,
            halfExtents=(sx / 2, sy / 2, thick / 2),
            rgbaColor=self._rgba(plat.rgb),
            physicsClientId=cid,
        )
        body = p.createMultiBody(
            0,
            -1,
            base_vis,
            basePosition=(plat.center[0], plat.center[1], plat.height / 2),
            linkMasses=[self.field.seesaw.board_mass_kg],
            linkCollisionShapeIndices=[-1],
            linkVisualShapeIndices=[board_vis],
            linkPositions=[(0.0, 0.0, plat.height / 2)],
            linkOrientations=[(0, 0, 0, 1)],
            linkInertialFramePositions=[(0, 0, 0)],
            linkInertialFrameOrientations=[(0, 0, 0, 1)],
            linkParentIndices=[0],
            linkJointTypes=[p.JOINT_REVOLUTE],
            linkJointAxis=[(0, 1, 0)],
            physicsClientId=cid,
        )
        self._set_board(plat.alliance, body)
        return body

    def _set_board(self, alliance: str, body: int | None = None) -> None:
        """Turn the hinged board to the model's tilt (positive: the field-side edge down)."""
        body = self._boards[alliance] if body is None else body
        plat = self.field.platform(alliance)  # type: ignore[arg-type]
        # About +y, a positive angle lowers the +x edge.
        angle = self.platforms[alliance].tilt * plat.field_side
        p.resetJointState(body, 0, angle, physicsClientId=self.client)

    def board_angle(self, alliance: str) -> float:
        """The hinged board's joint angle now (radians about +y), as PyBullet holds it."""
        return float(p.getJointState(self._boards[alliance], 0, physicsClientId=self.client)[0])

    def _build_goals(self) -> None:
        cid = self.client
        self.goals = []
        for i, g in enumerate(self.field.goals):
            rgba = self._rgba(g.rgb)
            if self.training:
                # Planar physics only needs the base's outline: a sphere whose equator is at
                # bumper height acts as a disc of the base's radius against robots, walls and
                # goals, and sphere-box contacts cost a fraction of cylinder ones.
                col = p.createCollisionShape(
                    p.GEOM_SPHERE,
                    radius=g.base_radius,
                    collisionFramePosition=[0, 0, g.base_radius],
                    physicsClientId=cid,
                )
            else:
                col = p.createCollisionShapeArray(
                    shapeTypes=[p.GEOM_CYLINDER, p.GEOM_CYLINDER],
                    radii=[g.base_radius, POST_RADIUS],
                    lengths=[g.base_height, g.height],
                    collisionFramePositions=[[0, 0, g.base_height / 2], [0, 0, g.height / 2]],
                    physicsClientId=cid,
                )
            vis = p.createVisualShapeArray(
                shapeTypes=[p.GEOM_CYLINDER, p.GEOM_CYLINDER],
                radii=[g.base_radius, POST_RADIUS],
                lengths=[g.base_height, g.height],
                rgbaColors=[rgba, rgba],
                visualFramePositions=[[0, 0, g.base_height / 2], [0, 0, g.height / 2]],
                physicsClientId=cid,
            )
            body = p.createMultiBody(
                g.mass_kg,
                col,
                vis,
                basePosition=(g.position[0], g.position[1], 0.0 if self.training else 0.001),
                baseInertialFramePosition=[0, 0, g.base_height / 2],
                physicsClientId=cid,
            )
            # Huge roll/pitch inertia: goals slide and spin but never tip (tipping is not part
            # of what the policy needs, and a tipped goal wedges the solver).
            inertia_xy = 1e3
            p.changeDynamics(
                body,
                -1,
                localInertiaDiagonal=[inertia_xy, inertia_xy, 0.5 * g.mass_kg * g.base_radius**2],
                lateralFriction=0.5,
                linearDamping=_GOAL_DAMPING if self.training else 0.04,
                angularDamping=_GOAL_DAMPING if self.training else 0.04,
                physicsClientId=cid,
            )
            self.goals.append(GoalState(i, g, body, g.position[0], g.position[1]))

    def _build_robots(self, rng: np.random.Generator) -> None:
        cid = self.client
        cfg = self.config
        self.robots = []
        counts = {"red": 0, "blue": 0}
        poses = robot_starts(self.field, cfg, self.lineup, rng)
        for index, ((alliance, name), (x, y, heading)) in enumerate(
            zip(self.lineup, poses, strict=True)
        ):
            rc = cfg.robots[name]
            slot = counts[alliance]
            counts[alliance] += 1
            half = (rc.width_m / 2, rc.length_m / 2, rc.height_m / 2)
            col = p.createCollisionShape(p.GEOM_BOX, halfExtents=half, physicsClientId=cid)
            alliance_rgb = (200, 40, 45) if alliance == "red" else (30, 80, 190)
            vis = p.createVisualShapeArray(
                shapeTypes=[p.GEOM_BOX, p.GEOM_BOX],
                # An alliance-coloured bumper stripe across the front, below the camera.
                halfExtents=[list(half), [half[0] * 0.9, 0.01, 0.04]],
                rgbaColors=[self._rgba(rc.rgb), self._rgba(alliance_rgb)],
                visualFramePositions=[[0, 0, 0], [0, half[1], 0.0]],
                physicsClientId=cid,
            )
            # Box local frame: x across, y along the heading, so yaw = heading_to_yaw - 90 deg
            # makes local +y point along the heading.
            body = p.createMultiBody(
                rc.mass_kg,
                col,
                vis,
                basePosition=(x, y, self._robot_z(rc)),
                baseOrientation=yaw_quaternion(self._body_yaw(heading)),
                physicsClientId=cid,
            )
            p.changeDynamics(
                body,
                -1,
                lateralFriction=0.0,
                linearDamping=0.0,
                angularDamping=0.0,
                physicsClientId=cid,
            )
            self.robots.append(RobotState(index, alliance, slot, rc, body, x, y, heading))

    @staticmethod
    def _body_yaw(heading: float) -> float:
        return heading_to_yaw(heading) - math.pi / 2

    @staticmethod
    def _body_heading(yaw: float) -> float:
        return yaw_to_heading(yaw + math.pi / 2)

    def _robot_z(self, rc: RobotConfig) -> float:
        return rc.height_m / 2 + (0.0 if self.training else 0.002)

    def _build_rings(self, rng: np.random.Generator) -> None:
        f = self.field
        cfg = self.config
        floor_xy = floor_rings(f, cfg, rng)
        n_floor = len(floor_xy)
        preload = f.ring.preloads_per_robot if cfg.preloads else 0
        n = n_floor + preload * len(self.robots)
        self.ring_xy = np.zeros((n, 2))
        self.ring_xy[:n_floor] = floor_xy
        self.ring_z = np.full(n, f.ring.thickness / 2)
        self.ring_state = np.full(n, RING_FLOOR, dtype=np.int8)
        self.ring_owner = np.full(n, -1, dtype=np.int16)
        for r in self.robots:
            lo = n_floor + r.index * preload
            self.ring_state[lo : lo + preload] = RING_HELD
            self.ring_owner[lo : lo + preload] = r.index
            r.held = preload
        self.ring_bodies = []
        if not self.training:
            self.ring_bodies = self._make_ring_bodies(dynamic=True)

    def _ring_mesh(self) -> tuple[list[list[float]], list[list[float]], list[int]]:
        ring = self.field.ring
        tube = (ring.outer_diameter - ring.inner_diameter) / 4
        major = ring.inner_diameter / 2 + tube
        nu, nv = 16, 8
        verts, norms, idx = [], [], []
        for i in range(nu):
            u = 2 * math.pi * i / nu
            for j in range(nv):
                v = 2 * math.pi * j / nv
                rr = major + tube * math.cos(v)
                verts.append([rr * math.cos(u), rr * math.sin(u), ring.thickness / 2 * math.sin(v)])
                norms.append([math.cos(v) * math.cos(u), math.cos(v) * math.sin(u), math.sin(v)])
        for i in range(nu):
            for j in range(nv):
                a = i * nv + j
                b = ((i + 1) % nu) * nv + j
                c = ((i + 1) % nu) * nv + (j + 1) % nv
                d = i * nv + (j + 1) % nv
                idx += [a, b, c, a, c, d]
        return verts, norms, idx

    def _make_ring_bodies(self, dynamic: bool) -> list[int]:
        cid = self.client
        ring = self.field.ring
        verts, norms, idx = self._ring_mesh()
        vis = p.createVisualShape(
            p.GEOM_MESH,
            vertices=verts,
            indices=idx,
            normals=norms,
            rgbaColor=self._rgba(ring.rgb),
            physicsClientId=cid,
        )
        col = -1
        if dynamic:
            col = p.createCollisionShape(
                p.GEOM_CYLINDER, radius=ring.radius, height=ring.thickness, physicsClientId=cid
            )
        bodies = []
        for i in range(len(self.ring_xy)):
            on_floor = self.ring_state[i] == RING_FLOOR
            pos = (
                (self.ring_xy[i, 0], self.ring_xy[i, 1], self.ring_z[i] + (0.001 if dynamic else 0))
                if on_floor
                else (0.0, 0.0, _PARK_Z - i * 0.2)
            )
            body = p.createMultiBody(
                ring.mass_kg if dynamic and on_floor else 0.0,
                col,
                vis,
                basePosition=pos,
                physicsClientId=cid,
            )
            if dynamic:
                p.changeDynamics(
                    body,
                    -1,
                    lateralFriction=0.6,
                    rollingFriction=0.001,
                    linearDamping=0.1,
                    angularDamping=0.1,
                    physicsClientId=cid,
                )
            bodies.append(body)
        return bodies

    def _build_barrier(self) -> None:
        """During the isolation period a wall on the centre line that only robots hit."""
        cid = self.client
        half = self.field.half
        col = p.createCollisionShape(p.GEOM_BOX, halfExtents=(0.01, half, 1.0), physicsClientId=cid)
        self._barrier = p.createMultiBody(0, col, -1, basePosition=(0, 0, 0.5), physicsClientId=cid)
        for g in self.goals:
            p.setCollisionFilterPair(self._barrier, g.body, -1, -1, 0, physicsClientId=cid)
        for b in self.ring_bodies:
            p.setCollisionFilterPair(self._barrier, b, -1, -1, 0, physicsClientId=cid)

    def _remove_barrier(self) -> None:
        if self._barrier is not None:
            p.removeBody(self._barrier, physicsClientId=self.client)
            self._barrier = None

    # --- stepping ---------------------------------------------------------------------------

    @property
    def phase(self) -> str:
        if self.over:
            return "over"
        return "isolation" if self.time_s < self.isolation_s else "interaction"

    def step(self, commands: list[DriveCommand]) -> StepEvents:
        """Advance one control step (1 / control_hz seconds)."""
        if not self._ready:
            raise WorldError("World.step() before reset()")
        if len(commands) != len(self.robots):
            raise WorldError(f"expected {len(self.robots)} commands, got {len(commands)}")
        events = StepEvents([0] * len(self.robots), [0] * len(self.robots))
        if self.over:
            events.match_over = True
            return events
        cid = self.client
        dt = self.dt
        for r, cmd in zip(self.robots, commands, strict=True):
            self._apply_limits(r, cmd, dt)
            r.intake_on = bool(cmd.intake)
        if self.game:
            self._tug_of_war()
        if self.training:
            self._set_velocities()
            p.stepSimulation(physicsClientId=cid)
        else:
            for _ in range(self.substeps):
                self._set_velocities()
                p.stepSimulation(physicsClientId=cid)
        before = [(r.x, r.y, r.heading) for r in self.robots]
        goals_before = [(g.x, g.y) for g in self.goals]
        self._read_poses()
        self._contain()
        if self.game:
            self._board_contacts(before)
            self._goal_board_contacts(goals_before)
        for r, (x0, y0, h0) in zip(self.robots, before, strict=True):
            h = math.radians(h0)
            r.measured_v = ((r.x - x0) * math.sin(h) + (r.y - y0) * math.cos(h)) / dt
            r.measured_w = math.radians((r.heading - h0 + 180.0) % 360.0 - 180.0) / dt
        was_isolation = self.time_s < self.isolation_s
        self.time_s = (self.steps + 1) * dt
        self.steps += 1
        if was_isolation and self.time_s >= self.isolation_s:
            self._remove_barrier()
            events.phase_changed = True
        for r, cmd in zip(self.robots, commands, strict=True):
            self._clamp(r, cmd, events)
        self._carry_goals([h0 for _, _, h0 in before])
        self._intake(events)
        if self.training and self.config.push_rings:
            self._push_rings()
        self._transfer(events)
        rules.update_pins(self, self._touching, events, dt)
        if self.game:
            self._step_tilts()
            for plat in self.field.platforms:
                self._set_board(plat.alliance)
            rules.update_fouls(self, self._touching, events)
            if events.phase_changed:  # the isolation (autonomous) period is judged as it ends
                self.autonomous = rules.autonomous_results(self)
        for r in self.robots:
            r.history.append((self.time_s, r.x, r.y, r.heading))
        if self.time_s >= self.match_length_s - 1e-9:
            self.over = True
            events.match_over = True
        return events

    def _board_contacts(self, before: list[tuple[float, float, float]]) -> None:
        """The whole game: robots drive onto a see-saw over its lowered field-side edge, leave it
        when they are off it, and are pushed back from it anywhere else (seesaw.board_contacts)."""
        state = rules.pack(self)
        x0 = np.array([[x for x, _, _ in before]])
        y0 = np.array([[y for _, y, _ in before]])
        moved = seesaw.board_contacts(self.game_consts, state, x0, y0, _ONE)
        for r in self.robots:
            code = int(state.on_platform[0, r.index])
            r.on_platform = None if code < 0 else rules.ALLIANCES[code]
            if moved[0, r.index]:
                r.x, r.y = float(state.x[0, r.index]), float(state.y[0, r.index])
                self._place(
                    r.body, r.x, r.y, self._robot_z(r.config), self._body_yaw(r.heading), True
                )

    def _goal_board_contacts(self, before: list[tuple[float, float]]) -> None:
        """The whole game: a free goal goes onto a see-saw only up its lowered field-side edge;
        one resting on the board stays; anywhere else the board stops it
        (seesaw.goal_board_contacts). Goals a robot holds move with it."""
        state = rules.pack(self)
        gx0 = np.array([[x for x, _ in before]])
        gy0 = np.array([[y for _, y in before]])
        moved = seesaw.goal_board_contacts(self.game_consts, state, gx0, gy0, _ONE)
        for g in self.goals:
            if moved[0, g.index]:
                g.x, g.y = float(state.gx[0, g.index]), float(state.gy[0, g.index])
                pos, q = p.getBasePositionAndOrientation(g.body, physicsClientId=self.client)
                self._place(g.body, g.x, g.y, pos[2], quaternion_yaw(q), stop=True)

    def _step_tilts(self) -> None:
        """The whole game: every see-saw swings one control step under its loads
        (seesaw.step_tilts)."""
        state = rules.pack(self)
        carried = np.array(
            [[-1 if r.carried_goal is None else r.carried_goal for r in self.robots]],
            dtype=np.int64,
        )
        seesaw.step_tilts(self.game_consts, state, carried, self.dt, _ONE)
        for name, plat in self.platforms.items():
            plat.tilt = float(state.tilt[0, ALLIANCE_CODES[name]])

    def _tug_of_war(self) -> None:
        """A goal clamped by robots of both alliances (training and high fidelity alike, a
        model): mechanisms.tug_of_war decides who drags whom; the winner becomes its carrier
        and the loser is dragged with the goal (_carry_goals)."""
        carrier = np.array([[_index(g.carried_by) for g in self.goals]], dtype=np.int64)
        contester = np.array([[_index(g.contested_by) for g in self.goals]], dtype=np.int64)
        v = np.array([[r.v for r in self.robots]])
        w = np.array([[r.w for r in self.robots]])
        share, dragged = mechanisms.tug_of_war(self.game_consts, carrier, contester, v, w, _ONE)
        for g in self.goals:
            g.carried_by = None if carrier[0, g.index] < 0 else int(carrier[0, g.index])
            g.contested_by = None if contester[0, g.index] < 0 else int(contester[0, g.index])
        self._tug = {i: float(f) for i, f in enumerate(share[0]) if not math.isnan(f)}
        self._dragged = {int(i) for i in np.flatnonzero(dragged[0])}

    def _apply_limits(self, r: RobotState, cmd: DriveCommand, dt: float) -> None:
        rc = r.config
        lin = float(cmd.linear)
        ang = float(cmd.angular)
        if not (math.isfinite(lin) and math.isfinite(ang)):
            # A NaN from a policy must never become a motor command: stop instead.
            lin = ang = 0.0
        lin = min(max(lin, -rc.max_linear_mps), rc.max_linear_mps)
        ang = min(max(ang, -rc.max_angular_rad_s), rc.max_angular_rad_s)
        dv = rc.max_linear_accel * dt
        dw = rc.max_angular_accel * dt
        r.v += min(max(lin - r.v, -dv), dv)
        r.w += min(max(ang - r.w, -dw), dw)

    def _set_velocities(self) -> None:
        cid = self.client
        for r in self.robots:
            h = math.radians(r.heading)
            v = r.v * self._tug[r.index] if r.index in self._tug else r.v
            w = 0.0 if r.index in self._dragged else r.w
            p.resetBaseVelocity(
                r.body,
                (v * math.sin(h), v * math.cos(h), 0.0),
                (0.0, 0.0, -w),
                physicsClientId=cid,
            )

    def _read_poses(self) -> None:
        cid = self.client
        for r in self.robots:
            pos, q = p.getBasePositionAndOrientation(r.body, physicsClientId=cid)
            r.x, r.y = pos[0], pos[1]
            r.heading = self._body_heading(quaternion_yaw(q))
            z0 = self._robot_z(r.config)
            tilted = abs(q[0]) > 1e-3 or abs(q[1]) > 1e-3
            if self.training and (tilted or abs(pos[2] - z0) > 1e-3):
                self._place(r.body, r.x, r.y, z0, self._body_yaw(r.heading))
            elif not self.training and (abs(q[0]) > 0.17 or abs(q[1]) > 0.17):
                # More than ~20 degrees of tilt: a box robot climbing a ring pile; set it down.
                self._place(r.body, r.x, r.y, z0, self._body_yaw(r.heading))
        for g in self.goals:
            pos, q = p.getBasePositionAndOrientation(g.body, physicsClientId=cid)
            g.x, g.y = pos[0], pos[1]
            if self.training and abs(pos[2]) > 1e-3:
                self._place(g.body, g.x, g.y, 0.0, quaternion_yaw(q))

    def _place(
        self, body: int, x: float, y: float, z: float, yaw: float, stop: bool = False
    ) -> None:
        """Set a body's pose. `stop`: it was set back out of an obstacle (a wall, a board) and
        stops there, as a body pinned against it does; otherwise it keeps its motion in the
        plane (its vertical velocity and tilt rate dropped): a goal set back on the floor
        slides on as it was sliding. (The velocity is read before the reset, which zeroes it.)"""
        cid = self.client
        lin, ang = ((0.0, 0.0, 0.0), (0.0, 0.0, 0.0))
        if not stop:
            lin, ang = p.getBaseVelocity(body, physicsClientId=cid)
        p.resetBasePositionAndOrientation(body, (x, y, z), yaw_quaternion(yaw), physicsClientId=cid)
        p.resetBaseVelocity(body, (lin[0], lin[1], 0.0), (0.0, 0.0, ang[2]), physicsClientId=cid)

    def _contain(self) -> None:
        """Keep every robot (with the goal it carries) and every goal inside the walls.

        The solver alone lets a robot whose velocity is set every step sink into a wall; this
        geometric clamp makes "cannot leave the field" exact.
        """
        lim = self.field.half
        for r in self.robots:
            sx, sy = self._inside_walls(r, with_goal=True)
            if sx or sy:
                r.x += sx
                r.y += sy
                self._place(
                    r.body, r.x, r.y, self._robot_z(r.config), self._body_yaw(r.heading), True
                )
        for g in self.goals:
            if g.carried_by is not None:
                continue
            rad = g.spec.base_radius
            nx = min(max(g.x, -lim + rad), lim - rad)
            ny = min(max(g.y, -lim + rad), lim - rad)
            if nx != g.x or ny != g.y:
                g.x, g.y = nx, ny
                pos, q = p.getBasePositionAndOrientation(g.body, physicsClientId=self.client)
                self._place(g.body, nx, ny, pos[2], quaternion_yaw(q), stop=True)

    def _inside_walls(self, r: RobotState, with_goal: bool = False) -> tuple[float, float]:
        """The smallest move (dx, dy) that takes the robot's footprint (and with_goal, the goal
        it carries) inside the walls."""
        lim = self.field.half
        lo_x, lo_y, hi_x, hi_y = seesaw.robot_box(r)
        if with_goal and r.carried_goal is not None:
            g = self.goals[r.carried_goal]
            gx, gy = self.clamp_point(r, g)
            rad = g.spec.base_radius
            lo_x, hi_x = min(lo_x, gx - rad), max(hi_x, gx + rad)
            lo_y, hi_y = min(lo_y, gy - rad), max(hi_y, gy + rad)
        sx = max(0.0, -lim - lo_x) - max(0.0, hi_x - lim)
        sy = max(0.0, -lim - lo_y) - max(0.0, hi_y - lim)
        return sx, sy

    # --- goals --------------------------------------------------------------------------------

    @staticmethod
    def clamp_offset(r: RobotState, g: GoalState) -> float:
        """Distance from the robot's centre to the centre of the goal its clamp holds."""
        return r.config.length_m / 2 + g.spec.base_radius + 0.005

    def clamp_point(self, r: RobotState, g: GoalState) -> tuple[float, float]:
        """Where a carried goal's centre sits: just behind the robot's back face (ahead of its
        front with RobotConfig.clamp = "front")."""
        back = self.clamp_offset(r, g)
        fx, fy = heading_sin_cos(r.heading)
        if r.config.clamp == "front":
            return r.x + back * fx, r.y + back * fy
        return r.x - back * fx, r.y - back * fy

    def _clamp(self, r: RobotState, cmd: DriveCommand, events: StepEvents) -> None:
        want = cmd.clamp if cmd.clamp is not None else (True if self.config.auto_clamp else None)
        if want is None:
            return
        if not want:
            if r.carried_goal is not None:
                self._release(r, events)
            return
        if r.carried_goal is not None:
            return
        rc = r.config
        h = math.radians(r.heading)
        fs, fc = math.sin(h), math.cos(h)
        front = rc.clamp == "front"
        best, best_d = None, math.inf
        for g in self.goals:
            if g.carried_by is not None and not self._contestable(r, g):
                continue
            dx, dy = g.x - r.x, g.y - r.y
            across = dx * fc - dy * fs
            ahead = dx * fs + dy * fc
            gap = (ahead if front else -ahead) - rc.length_m / 2 - g.spec.base_radius
            if -0.03 <= gap <= rc.clamp_reach_m and abs(across) <= rc.clamp_half_width_m:
                best, best_d = (g, gap) if gap < best_d else (best, best_d)
        if best is not None:
            if best.carried_by is None:
                best.carried_by = r.index
            else:  # the whole game: a tug of war with the other alliance's robot
                best.contested_by = r.index
            r.carried_goal = best.index
            p.setCollisionFilterPair(r.body, best.body, -1, -1, 0, physicsClientId=self.client)
            events.clamped.append((r.index, best.index))

    def _contestable(self, r: RobotState, g: GoalState) -> bool:
        """The whole game: a goal one robot holds can be clamped by one of the other alliance."""
        return (
            self.game
            and g.contested_by is None
            and g.carried_by is not None
            and self.robots[g.carried_by].alliance != r.alliance
        )

    def _release(self, r: RobotState, events: StepEvents) -> None:
        assert r.carried_goal is not None
        g = self.goals[r.carried_goal]
        if g.contested_by == r.index:
            g.contested_by = None
        else:
            g.carried_by, g.contested_by = g.contested_by, None
        r.carried_goal = None
        p.setCollisionFilterPair(r.body, g.body, -1, -1, 1, physicsClientId=self.client)
        events.released.append((r.index, g.index))

    def _carry_goals(self, headings_before: list[float] | None = None) -> None:
        """Carried goals follow their holders' clamps. A contested goal's other robot is dragged
        with it (_tug_of_war): it keeps its place relative to the holder, turning by as much as
        the holder turned since `headings_before` (the robots' headings before this step)."""
        cid = self.client
        for r in self.robots:
            if r.carried_goal is None:
                continue
            g = self.goals[r.carried_goal]
            if g.contested_by == r.index:
                continue  # the tug's loser: dragged below, with the goal
            xy = self.clamp_point(r, g)
            if g.contested_by is not None:
                other = self.robots[g.contested_by]
                if headings_before is not None:
                    turned = r.heading - headings_before[r.index]
                    other.heading = (headings_before[other.index] + turned) % 360.0
                sx, sy = self._drag(other, g, xy)
                if sx or sy:
                    # A wall stops the robot dragged: it pushes the whole chain back.
                    r.x += sx
                    r.y += sy
                    xy = (xy[0] + sx, xy[1] + sy)
                    self._place(
                        r.body, r.x, r.y, self._robot_z(r.config), self._body_yaw(r.heading), True
                    )
            g.x, g.y = xy
            pos, _ = p.getBasePositionAndOrientation(g.body, physicsClientId=cid)
            p.resetBasePositionAndOrientation(
                g.body,
                (g.x, g.y, pos[2]),
                yaw_quaternion(self._body_yaw(r.heading)),
                physicsClientId=cid,
            )
            # Moving with the robot during the next physics step, so it pushes what it meets.
            h = math.radians(r.heading)
            p.resetBaseVelocity(
                g.body,
                (r.v * math.sin(h), r.v * math.cos(h), 0.0),
                (0.0, 0.0, -r.w),
                physicsClientId=cid,
            )

    def _drag(
        self, r: RobotState, g: GoalState, goal_xy: tuple[float, float]
    ) -> tuple[float, float]:
        """Move a robot (at its heading) so its clamp holds a goal that will sit at goal_xy, and
        back inside the walls: the move the walls made (dx, dy; the chain goes with it)."""
        gx, gy = self.clamp_point(r, g)
        r.x += goal_xy[0] - gx
        r.y += goal_xy[1] - gy
        sx, sy = self._inside_walls(r)
        r.x += sx
        r.y += sy
        self._place(r.body, r.x, r.y, self._robot_z(r.config), self._body_yaw(r.heading), True)
        return sx, sy

    # --- rings --------------------------------------------------------------------------------

    def _sync_ring_bodies(self) -> None:
        """High fidelity: read the dynamic rings' positions back into the numpy table."""
        cid = self.client
        for i in np.flatnonzero(self.ring_state == RING_FLOOR):
            pos, _ = p.getBasePositionAndOrientation(self.ring_bodies[i], physicsClientId=cid)
            self.ring_xy[i] = pos[0], pos[1]
            self.ring_z[i] = pos[2]

    def intake_rect(self, r: RobotState) -> tuple[tuple[float, float], tuple[float, float]]:
        """Robot r's intake zone, robot frame (sim.world.state.intake_rect)."""
        return intake_rect(r.config, self.field.ring.radius)

    def _push_rings(self) -> None:
        """Training fidelity: floor rings inside a robot's footprint (grown by a ring radius)
        move out across the nearer side, to where the body would have shoved them; called
        after the intake, which takes the rings the front face reaches first."""
        rad = self.field.ring.radius
        half = self.field.half - rad
        for r in self.robots:
            floor = np.flatnonzero(self.ring_state == RING_FLOOR)
            if len(floor) == 0:
                return
            hx = r.config.width_m / 2 + rad
            hy = r.config.length_m / 2 + rad
            local = field_to_robot(self.ring_xy[floor], (r.x, r.y), r.heading)
            out, moved = push_out_of_box(local, hx, hy)
            if moved.any():
                xy = robot_to_field(out[moved], (r.x, r.y), r.heading)
                self.ring_xy[floor[moved]] = np.clip(xy, -half, half)

    def _intake(self, events: StepEvents) -> None:
        if not self.training:
            self._sync_ring_bodies()
        floor = np.flatnonzero(self.ring_state == RING_FLOOR)
        if len(floor) == 0:
            return
        # A ring on the floor can be taken only while low (high fidelity: not on top of a pile
        # higher than the intake's lip).
        low = self.ring_z[floor] < self.field.ring.thickness * 2.5
        floor = floor[low]
        for r in self.robots:
            # Reversing, a robot passes over rings (training rings are not bodies) and they
            # come out under its front bumper: an intake takes rings coming in, not going out.
            if not r.intake_on or r.room <= 0 or len(floor) == 0 or r.v < -0.05:
                continue
            (x0, x1), (y0, y1) = self.intake_rect(r)
            local = field_to_robot(self.ring_xy[floor], (r.x, r.y), r.heading)
            inside = (local[:, 0] >= x0) & (local[:, 0] <= x1)
            inside &= (local[:, 1] >= y0) & (local[:, 1] <= y1)
            if not inside.any():
                continue
            cand = floor[inside]
            order = np.argsort(local[inside, 1], kind="stable")  # nearest the bumper first
            taken = cand[order[: r.room]]
            self.ring_state[taken] = RING_HELD
            self.ring_owner[taken] = r.index
            r.held += len(taken)
            r.collected += len(taken)
            events.collected[r.index] += len(taken)
            if self.ring_bodies:
                for i in taken:
                    self._park_ring(int(i))
            floor = np.setdiff1d(floor, taken, assume_unique=True)

    def _park_ring(self, i: int) -> None:
        cid = self.client
        body = self.ring_bodies[i]
        p.changeDynamics(body, -1, mass=0.0, physicsClientId=cid)
        p.resetBasePositionAndOrientation(
            body, (0.0, 0.0, _PARK_Z - i * 0.2), (0, 0, 0, 1), physicsClientId=cid
        )

    def _transfer(self, events: StepEvents) -> None:
        for r in self.robots:
            if r.carried_goal is None or r.held == 0:
                r.transfer_timer = 0.0
                continue
            r.transfer_timer += self.dt
            while r.held > 0 and r.transfer_timer >= r.config.ring_transfer_s:
                r.transfer_timer -= r.config.ring_transfer_s
                mine = np.flatnonzero((self.ring_state == RING_HELD) & (self.ring_owner == r.index))
                i = int(mine[0])
                self.ring_state[i] = RING_SCORED
                self.ring_owner[i] = r.carried_goal
                r.held -= 1
                g = self.goals[r.carried_goal]
                if self.game:
                    self._place_ring(r.config, g)
                g.rings += 1
                events.scored[r.index] += 1

    @staticmethod
    def _place_ring(rc: RobotConfig, g: GoalState) -> None:
        """The whole game: where the robot's mechanism puts a ring on the goal it holds
        (mechanisms.ring_slot; counted before g.rings grows)."""
        spec = g.spec
        slot = mechanisms.ring_slot(
            rc.loads == "base",
            rc.reaches_high_branch,
            g.rings_high,
            g.rings_low,
            spec.high_branch_capacity,
            spec.branch_capacity,
        )
        if slot == mechanisms.HIGH:
            g.rings_high += 1
        elif slot == mechanisms.BASE:
            g.rings_base += 1

    # --- rules (sim.world.rules) ----------------------------------------------------------

    def touching(self, i: int, j: int) -> bool:
        """Whether robots i and j are in contact (within pin_contact_m), as the pin rule and
        the fouls judge contact."""
        return self._touching(self.robots[i], self.robots[j])

    def _touching(self, a: RobotState, b: RobotState) -> bool:
        """Whether two robots are in contact (within pin_contact_m), for the pin rule."""
        margin = self.config.pin_contact_m
        d = math.hypot(a.x - b.x, a.y - b.y)
        touching = False
        if d <= a.config.radius_m + b.config.radius_m + margin:
            touching = bool(p.getClosestPoints(a.body, b.body, margin, physicsClientId=self.client))
        return touching

    def score(self) -> dict[str, AllianceScore]:
        """sim.world.rules.score for the current state, cached until the world changes."""
        key: tuple
        if self.game:
            key = (
                self.steps,
                self._edits,
                tuple([(g.rings, g.rings_high, g.rings_base) for g in self.goals]),
                tuple([s.tilt for s in self.platforms.values()]),
                len(self.fouls),
                tuple([r.on_platform for r in self.robots]),
            )
        else:
            key = (self.steps, self._edits, tuple([g.rings for g in self.goals]))
        if self._score_cache is not None and self._score_cache[0] == key:
            return dict(self._score_cache[1])
        out = rules.score(self)
        self._score_cache = (key, out)
        return dict(out)

    # --- scenarios (tests, datasets, the full-stack match) -------------------------------------

    def place_robot(self, index: int, x: float, y: float, heading_deg: float) -> None:
        """Teleport robot `index` (at rest); its carried goal follows."""
        self._edits += 1
        r = self.robots[index]
        r.x, r.y, r.heading = float(x), float(y), float(wrap_heading(heading_deg))
        r.v = r.w = r.measured_v = r.measured_w = 0.0
        p.resetBasePositionAndOrientation(
            r.body,
            (r.x, r.y, self._robot_z(r.config)),
            yaw_quaternion(self._body_yaw(r.heading)),
            physicsClientId=self.client,
        )
        p.resetBaseVelocity(r.body, (0, 0, 0), (0, 0, 0), physicsClientId=self.client)
        r.history.clear()
        r.history.append((self.time_s, r.x, r.y, r.heading))
        if self.game:  # set down by hand: on a board it overlaps (a scene for tests and tools)
            ex, ey = seesaw.robot_extents(self.game_consts, r.index, r.heading)
            code = seesaw.board_under(self.game_consts, r.x, r.y, ex, ey)
            r.on_platform = None if code < 0 else rules.ALLIANCES[code]
        if r.carried_goal is not None:
            self._carry_goals()

    def set_tilt(self, alliance: str, tilt_rad: float) -> None:
        """The whole game: set a see-saw's tilt (radians, positive: its field-side edge down)."""
        self._edits += 1
        self.platforms[alliance].tilt = float(tilt_rad)
        self._set_board(alliance)

    def settle_platforms(self, seconds: float = 2.0) -> None:
        """The whole game: let the see-saws swing under their loads for `seconds`, nothing else
        moving (a scene set up with place_robot/place_goal settles as the match would)."""
        self._edits += 1
        for _ in range(max(1, round(seconds / self.dt))):
            self._step_tilts()
        for alliance in self.platforms:
            self._set_board(alliance)

    def place_goal(self, index: int, x: float, y: float) -> None:
        self._edits += 1
        g = self.goals[index]
        if g.carried_by is not None:
            raise WorldError(f"goal {g.spec.name} is carried; release it first")
        g.x, g.y = float(x), float(y)
        z = 0.0 if self.training else 0.001
        cid = self.client
        p.resetBasePositionAndOrientation(g.body, (g.x, g.y, z), (0, 0, 0, 1), physicsClientId=cid)
        p.resetBaseVelocity(g.body, (0, 0, 0), (0, 0, 0), physicsClientId=cid)

    def set_floor_rings(self, xy: np.ndarray) -> None:
        """Replace every ring on the floor by rings at `xy` (N, 2); held and scored ones stay."""
        self._edits += 1
        pts = np.asarray(xy, dtype=np.float64).reshape(-1, 2)
        lim = self.field.half - self.field.ring.radius
        if pts.size and np.any(np.abs(pts) > lim):
            raise WorldError("a ring position lies outside the field")
        keep = self.ring_state != RING_FLOOR
        n_keep = int(keep.sum())
        n = n_keep + len(pts)
        state = np.concatenate([self.ring_state[keep], np.full(len(pts), RING_FLOOR, np.int8)])
        owner = np.concatenate([self.ring_owner[keep], np.full(len(pts), -1, np.int16)])
        ring_xy = np.concatenate([self.ring_xy[keep], pts]) if n else np.zeros((0, 2))
        cid = self.client
        for b in self.ring_bodies + (self._ring_visuals or []):
            p.removeBody(b, physicsClientId=cid)
        self.ring_xy = ring_xy
        self.ring_z = np.full(n, self.field.ring.thickness / 2)
        self.ring_state = state
        self.ring_owner = owner
        self._ring_visuals = None
        self._ring_visual_state = None
        self.ring_bodies = [] if self.training else self._make_ring_bodies(dynamic=True)

    # --- rendering support ------------------------------------------------------------------

    def ensure_ring_visuals(self) -> list[int]:
        """Bodies the camera can see for every ring (training creates them on first use)."""
        if self.ring_bodies:
            return self.ring_bodies
        if self._ring_visuals is None:
            self._ring_visuals = self._make_ring_bodies(dynamic=False)
            self._ring_visual_state = np.full(len(self.ring_xy), -1, dtype=np.int8)
            self._ring_visual_xy = self.ring_xy.copy()
        assert self._ring_visual_state is not None and self._ring_visual_xy is not None
        cid = self.client
        changed = self._ring_visual_state != self.ring_state
        # A floor ring a robot pushed (push_rings) moves without changing its state.
        changed |= np.any(self._ring_visual_xy != self.ring_xy, axis=1)
        for i in np.flatnonzero(changed):
            if self.ring_state[i] == RING_FLOOR:
                pos = (self.ring_xy[i, 0], self.ring_xy[i, 1], self.ring_z[i])
            else:
                pos = (0.0, 0.0, _PARK_Z - i * 0.2)
            p.resetBasePositionAndOrientation(
                self._ring_visuals[i], pos, (0, 0, 0, 1), physicsClientId=cid
            )
        self._ring_visual_state = self.ring_state.copy()
        self._ring_visual_xy = self.ring_xy.copy()
        return self._ring_visuals

    def body_kinds(self) -> dict[int, tuple[str, int]]:
        """Body id -> (kind, index) for segmentation: kind in ring, goal, robot."""
        out: dict[int, tuple[str, int]] = {}
        for i, b in enumerate(self.ring_bodies or self._ring_visuals or []):
            out[b] = ("ring", i)
        for g in self.goals:
            out[g.body] = ("goal", g.index)
        for r in self.robots:
            out[r.body] = ("robot", r.index)
        return out


def _index(i: int | None) -> int:
    return -1 if i is None else i
