"""What both environments share: actions to commands, observations, rewards, episode ends.

A MatchCore wraps one World. Every robot in it gets its own frame stack and reward; the Gymnasium
env drives one of them (and scripts or plays the rest), the PettingZoo env hands all of them to
agents. Rewards follow the original team's table (sim.config.RewardConfig), each component
reported separately.
"""

from __future__ import annotations

from collections.abc import Callable
from dataclasses import dataclass, field, replace
from typing import Any, Literal

import numpy as np

from jetson.autonomy.camera import MemoryCamera
from jetson.autonomy.geometry import (
    AllianceName,
    field_to_robot,
    heading_vector,
    robot_to_field,
    to_alliance_frame,
)
from jetson.autonomy.goal_memory import GoalMemory
from jetson.autonomy.observation import FrameStack, PartnerView, RobotView, build_frame
from jetson.autonomy.ring_memory import RingMemory
from jetson.autonomy.skills import SkillConfig, SkillDriver
from jetson.autonomy.spec import ObservationSpec
from sim.config import CameraConfig, RewardConfig, RobotConfig, WorldConfig, merge
from sim.errors import ConfigError
from sim.field import FieldSpec
from sim.goal_sight import visible_goals
from sim.rewards import goal_potential, park_potential, ring_potential
from sim.world import rules, sensors
from sim.world.physics import World
from sim.world.state import (
    RING_FLOOR,
    RING_HELD,
    AllianceScore,
    DriveCommand,
    GpsReading,
    StepEvents,
    WorldState,
)

REWARD_COMPONENTS = (
    "rings",
    "pin",
    "goals_end",
    "side_end",
    "elevated_end",
    "approach",
    "park",
    "clamp",
    "goal_approach",
    "score",
    "hurry",
    "partner",
)


@dataclass(frozen=True)
class EnvConfig:
    """Everything an environment is made from; nested tables map to the nested configs.

    observation None derives the spec from the world (match length, ring capacity) with the
    default layout. obs_noise applies the spec's uniform noise; gps_noise makes the robot's own
    pose a GPS reading (Gaussian noise and latency) instead of the truth. Actions are
    [linear, angular] in [-1, 1], scaled to the robot's speed limits (angular positive =
    clockwise), or with `skills` one score per skill, either followed by [intake] and/or [clamp]
    when action_intake / action_clamp (> 0 means on; clamp <= 0 releases). max_steps truncates
    episodes early (None: the match's own length).
    goal_start_share is a training curriculum: the share of episodes in which each robot starts
    with its back to one of its alliance's goals (clamp point 0.05-0.5 m from it, +-30 deg),
    so that a policy discovers the clamp, which an untrained robot driving forward never backs
    into. midgame_start_share is another: the share of episodes that start as the middle of a
    match, where a learned policy loses most to the planner
    (docs/notes/2026-11-22-training-skills.md, "Where the planner still wins"): a random 20-60 % of
    the floor rings gone, each robot holding some of them (up to a full intake) with its back to one
    of its goals. uncapped_share is the share of episodes in which every robot's intake never fills
    (the uncapped scenario's robots), so that a policy whose observation says whether its intake
    fills (spec intake_flag) learns both games; uncapped_reward (RewardConfig keys) overrides the
    reward in those matches, for the uncapped task is ring collection ("every ring collected
    counts"), not the goal game.
    """

    world: WorldConfig = field(default_factory=WorldConfig)
    observation: ObservationSpec | None = None
    reward: RewardConfig = field(default_factory=RewardConfig)
    obs_noise: bool = True
    gps_noise: bool = True
    end_on_pin: bool = True
    action_intake: bool = False
    action_clamp: bool = False
    # A skill action space (jetson/autonomy/skills.py): one score per option, a controller
    # drives the best.
    skills: SkillConfig | None = None
    max_steps: int | None = None
    goal_start_share: float = 0.0
    midgame_start_share: float = 0.0
    uncapped_share: float = 0.0
    uncapped_reward: dict[str, Any] = field(default_factory=dict)
    # Gymnasium env only: which robot learns and who plays against it.
    agent_alliance: Literal["red", "blue", "random"] = "red"
    opponent: Literal["none", "scripted", "policy"] = "scripted"

    def __post_init__(self) -> None:
        if self.agent_alliance not in ("red", "blue", "random"):
            raise ConfigError(
                f"agent_alliance must be red, blue or random: {self.agent_alliance!r}"
            )
        if self.opponent not in ("none", "scripted", "policy"):
            raise ConfigError(f"opponent must be none, scripted or policy: {self.opponent!r}")
        if self.max_steps is not None and self.max_steps < 1:
            raise ConfigError("max_steps must be at least 1 or None")
        if not 0.0 <= self.goal_start_share <= 1.0:
            raise ConfigError(f"goal_start_share must be in [0, 1], got {self.goal_start_share}")
        if not 0.0 <= self.midgame_start_share <= 1.0:
            raise ConfigError(
                f"midgame_start_share must be in [0, 1], got {self.midgame_start_share}"
            )
        if not 0.0 <= self.uncapped_share <= 1.0:
            raise ConfigError(f"uncapped_share must be in [0, 1], got {self.uncapped_share}")
        merge(self.reward, self.uncapped_reward, "env.uncapped_reward")  # names a bad key

    def match_reward(self, uncapped: bool) -> RewardConfig:
        """The reward of a match, by whether its intakes never fill (uncapped_share)."""
        return merge(self.reward, self.uncapped_reward) if uncapped else self.reward

    @property
    def action_size(self) -> int:
        """[linear, angular] or one score per skill, then [intake] and/or [clamp]."""
        head = self.skills.n_options if self.skills is not None else 2
        return head + self.actuator_size

    @property
    def actuator_size(self) -> int:
        """How many actuator inputs (intake, clamp) follow the drive or the skill scores."""
        return int(self.action_intake) + int(self.action_clamp)

    def actuators(self, tail: np.ndarray) -> tuple[bool, bool | None]:
        """(intake, clamp) from the action's last actuator_size values in [-1, 1]: the intake
        runs when > 0 (always, without action_intake); the clamp grabs when > 0 and releases
        otherwise (None, left to the auto clamp, without action_clamp)."""
        k = 0
        intake = True
        clamp = None
        if self.action_intake:
            intake = bool(tail[k] > 0)
            k += 1
        if self.action_clamp:
            clamp = bool(tail[k] > 0)
        return intake, clamp


def make_config(config: EnvConfig | dict[str, Any] | None = None, **overrides: Any) -> EnvConfig:
    """An EnvConfig from a config, a plain dict (e.g. a TOML table) and/or keyword overrides.

    Nested tables merge into the nested configs: make_config(world={"fidelity": "high"}) keeps
    every other world setting.
    """
    base = config if isinstance(config, EnvConfig) else EnvConfig()
    data = {} if isinstance(config, EnvConfig) else dict(config or {})
    data.update(overrides)
    for key in ("observation", "skills"):  # None keeps the base's (a derived spec, no skills)
        if key in data and data[key] is None:
            del data[key]
    return merge(base, data, "env")


def default_spec(world: World) -> ObservationSpec:
    return derived_spec(world.match_length_s, [r.config.ring_capacity for r in world.robots])


def derived_spec(match_length_s: float, capacities: list[int | None]) -> ObservationSpec:
    """The default layout for a match: its length, and the largest intake as the held rings'
    unit (10 when no intake fills)."""
    caps = [c for c in capacities if c]
    return ObservationSpec(
        match_length_s=match_length_s, ring_capacity_norm=max(caps) if caps else 10
    )


def with_prior(spec: ObservationSpec, world: World) -> ObservationSpec:
    """A memory spec without its prior gets the field's starting layout (red's frame is the
    field frame, and the layout is the same seen from either side): the rings, the goals red
    could score with, the clamp's offset from the robots' size and, for a memory that forgets
    what the intake takes, the intake's reach."""
    if not spec.needs_prior:
        return spec

    def pairs(xy: np.ndarray) -> tuple[tuple[float, float], ...]:
        return tuple((float(x), float(y)) for x, y in np.round(xy, 4))

    if spec.ring_memory and not spec.prior_rings:
        spec = replace(spec, prior_rings=pairs(world.field.ring_positions))
    if spec.goal_memory and not spec.prior_goals:
        goals = [g.position for g in world.field.goals if g.alliance in (None, "red")]
        spec = replace(spec, prior_goals=pairs(np.asarray(goals, dtype=np.float64)))
    needs_robot = spec.goal_memory and spec.goal_clamp_offset_m <= 0
    needs_robot |= spec.ring_memory and spec.memory_forget_intake and not spec.memory_intake_zone
    needs_robot |= spec.ring_memory and spec.memory_push and not spec.memory_body
    if needs_robot and not world.robots:  # robots exist only after a reset
        world.reset(np.random.default_rng(0))
    if spec.goal_memory and spec.goal_clamp_offset_m <= 0:
        r = world.robots[0]
        offset = world.clamp_offset(r, world.goals[0]) if world.goals else r.config.length_m / 2
        spec = replace(spec, goal_clamp_offset_m=round(offset, 4))
    if spec.ring_memory and spec.memory_forget_intake and not spec.memory_intake_zone:
        (x0, x1), (y0, y1) = world.intake_rect(world.robots[0])
        spec = replace(spec, memory_intake_zone=tuple(round(v, 4) for v in (x0, x1, y0, y1)))
    if spec.ring_memory and spec.memory_push and not spec.memory_body:
        rc, rad = world.robots[0].config, world.field.ring.radius
        body = (rc.width_m / 2 + rad, rc.length_m / 2 + rad)
        spec = replace(spec, memory_body=tuple(round(v, 4) for v in body))
    return spec


def robot_view(
    world: WorldState,
    spec: ObservationSpec,
    index: int,
    pose: tuple[float, float, float],
    rings: np.ndarray,
    claims: list[tuple[float, float] | None] | None = None,
    in_view: np.ndarray | None = None,
) -> RobotView:
    """What robot `index` knows (MatchCore.view): `pose` (its GPS reading, field frame), the
    floor rings `rings` (indices) its camera sees, in its frame, the other robots (when the
    spec has slots for them), its intake and its clamp, and with spec.partner its alliance
    partner (partner_view: `claims`, each robot's claimed target by index); with
    spec.seen_opponents the other robots' slots hold the opponents its camera sees (`in_view`:
    sensors.robots_in_view's matrix, computed here when not given). sim.fast.players builds a
    fast match's views with it too."""
    r = world.robots[index]
    # Most steps see no ring: the frame conversion of nothing is nothing.
    seen = sensors.rings_in_robot_frame(world, index, rings) if len(rings) else np.zeros((0, 2))
    others = np.zeros((0, 2))
    if spec.n_other_robots:
        if spec.seen_opponents:  # the opponents whose plates its camera sees
            sees = (sensors.robots_in_view(world) if in_view is None else in_view)[index]
            pts = [(o.x, o.y) for o in world.robots if sees[o.index] and o.alliance != r.alliance]
        else:
            pts = [(o.x, o.y) for o in world.robots if o.index != index]
        if pts:
            others = field_to_robot(np.array(pts), r.xy, r.heading)
    return RobotView(
        x=pose[0],
        y=pose[1],
        heading_deg=pose[2],
        alliance=r.alliance,
        time_s=world.time_s,
        rings_robot_xy=seen,
        rings_held=r.held,
        others_robot_xy=others,
        goal_clamped=r.carried_goal is not None,
        intake_fills=r.config.ring_capacity is not None,
        tall=r.config.reaches_high_branch,
        partner=partner_view(world, index, claims) if spec.partner else None,
    )


def partner_of(alliances: list[AllianceName], index: int) -> int | None:
    """Robot `index`'s alliance partner: the first other robot of its alliance (None alone)."""
    mates = [k for k, a in enumerate(alliances) if a == alliances[index] and k != index]
    return mates[0] if mates else None


def partner_view(
    world: WorldState, index: int, claims: list[tuple[float, float] | None] | None = None
) -> PartnerView | None:
    """Robot `index`'s alliance partner as its reports over VEXlink would tell it, in the
    robot's frame: where it is, its clamp and rings, the target it claimed (`claims`: each
    robot's, field frame, by index). The twin's link is perfect: every report arrives fresh.
    None for a robot without a partner."""
    k = partner_of([o.alliance for o in world.robots], index)
    if k is None:
        return None
    r, p = world.robots[index], world.robots[k]
    claim = None if claims is None else claims[k]

    def local(xy: tuple[float, float]) -> tuple[float, float]:
        x, y = field_to_robot(np.array([xy]), r.xy, r.heading)[0]
        return float(x), float(y)

    return PartnerView(
        xy=local((p.x, p.y)),
        clamped=p.carried_goal is not None,
        rings=p.held,
        claim_xy=None if claim is None else local(claim),
    )


def memory_camera(cam: CameraConfig, ring_z_m: float) -> MemoryCamera:
    """What the ring memory needs of a simulated robot's camera (memory_view "camera")."""
    return MemoryCamera.from_model(cam.intrinsics, cam.mount, near_m=cam.near_m, ring_z_m=ring_z_m)


@dataclass
class RobotStep:
    """One robot's share of a control step."""

    observation: np.ndarray
    reward: float
    components: dict[str, float]
    info: dict[str, Any]


def skill_settings(field: FieldSpec, alliance: AllianceName, robot: RobotConfig) -> dict[str, Any]:
    """What a SkillConfig takes from the field and the robot: the alliance's platform in its
    alliance frame (the same for both alliances), the robot's length and top speeds."""
    plat = field.platform(alliance)
    (cx, cy), _ = to_alliance_frame(plat.center, None, alliance)
    box = tuple(round(float(v), 4) for v in (cx, cy, plat.size[0] / 2, plat.size[1] / 2))
    return {
        "platform_box": box,
        "robot_length_m": round(robot.length_m, 4),
        "max_linear_mps": round(robot.max_linear_mps, 4),
        "max_angular_rad_s": round(robot.max_angular_rad_s, 4),
    }


def skill_command(
    config: EnvConfig, driver: SkillDriver, obs: np.ndarray, action: np.ndarray
) -> DriveCommand:
    """A skill action (one score per skill, then the actuators: EnvConfig.actuators) -> the
    DriveCommand the skill's controller drives, carrying the intake and the clamp, so that a
    skill-driven robot releases a goal as a drive-action one does. Non-finite: a stop."""
    a = np.asarray(action, dtype=np.float64).reshape(-1)
    if not np.all(np.isfinite(a)):
        return DriveCommand(0.0, 0.0, intake=False, clamp=None)
    n = config.skills.n_options if config.skills is not None else len(a)
    v, w = driver.command(obs, a[:n])
    intake, clamp = config.actuators(np.clip(a[n:], -1.0, 1.0))
    return DriveCommand(v, w, intake, clamp)


def goal_start(
    rng: np.random.Generator,
    goals: list[tuple[float, float]],
    offsets: list[float],
    half: float,
) -> tuple[float, float, float] | None:
    """A start with the robot's back to one of `goals` (its clamp `offsets[k]` from the robot's
    centre): the goal drawn, then up to 20 tries of a direction away from it (turned up to 30
    degrees) and a gap of 0.05-0.5 m, the first that keeps the centre within `half` of the
    field's middle. (x, y, heading), or None when there is no goal or no try fits
    (EnvConfig.goal_start_share; MatchCore and sim.fast draw it alike)."""
    if not goals:
        return None
    k = int(rng.integers(len(goals)))
    gx, gy = goals[k]
    for _ in range(20):  # a direction that keeps the robot inside the walls
        # Facing away from the goal (its back toward it), then turned a little, moved off.
        away = float(rng.uniform(0.0, 360.0))
        heading = away + float(rng.uniform(-30.0, 30.0))
        f = heading_vector(away)
        d = offsets[k] + float(rng.uniform(0.05, 0.5))
        x, y = gx + d * float(f[0]), gy + d * float(f[1])
        if abs(x) < half and abs(y) < half:
            return x, y, heading
    return None


def midgame_start(
    rng: np.random.Generator,
    floor: np.ndarray,
    robots: list[tuple[int | None, int]],
    at_goal: Callable[[int, np.random.Generator], None],
) -> tuple[np.ndarray, list[np.ndarray]]:
    """The draws of a start some seconds in (EnvConfig.midgame_start_share): a random 20-60 %
    of the floor rings `floor` gone; robot by robot (capacity, room), up to a full intake of
    them in its intake (an intake that never fills: up to 10), then at_goal(robot, rng) puts
    its back to one of its goals. Returns the rings gone and each robot's share of them."""
    gone = rng.permutation(floor)[: int(len(floor) * rng.uniform(0.2, 0.6))]
    taken, shares = 0, []
    for index, (cap, room) in enumerate(robots):
        k = min(int(rng.integers(0, (cap if cap is not None else 10) + 1)), room)
        shares.append(gone[taken : taken + k])
        taken += len(shares[-1])
        at_goal(index, rng)
    return gone, shares


class MatchCore:
    def __init__(self, config: EnvConfig, world_config: WorldConfig | None = None, client=None):
        self.config = config
        self.world = World(world_config or config.world, client=client)
        self.spec = with_prior(
            config.observation or default_spec(self._probe_spec_world()), self.world
        )
        if abs(self.spec.match_length_s - self.world.match_length_s) > 1e-9:
            raise ConfigError(
                f"observation.match_length_s is {self.spec.match_length_s} but the match lasts "
                f"{self.world.match_length_s} s (isolation + interaction); set them equal (a "
                "policy's observation is fixed by its training: it plays the match it learned)"
            )
        # This match's reward: the config's, or in a match whose intakes never fill, its own.
        self._rewards = {False: config.reward, True: config.match_reward(True)}
        self.reward = config.reward
        self.uncapped = False  # this match's intakes never fill (EnvConfig.uncapped_share)
        self.stacks: list[FrameStack] = []
        self.memories: list[RingMemory] = []
        self.goal_memories: list[GoalMemory] = []
        self._shaping = self._shapings()
        self.totals: list[dict[str, float]] = []
        self.pins: list[int] = []
        self._gps_rngs: list[np.random.Generator] = []
        self._obs_rngs: list[np.random.Generator] = []
        self._gps_now: dict[int, GpsReading] = {}
        self.ended_by_pin = False
        self.drivers: list[SkillDriver] = []
        # Each robot's claimed target (field frame; None: nothing), the partner block's claim:
        # a skill-driven robot claims its skill's target (MatchCore.command).
        self.claims: list[tuple[float, float] | None] = []
        self._mates: list[int | None] = []  # each robot's alliance partner (partner_of)
        self._with_mate: list[bool] = []  # in contact with it last step (partner_contact)
        self._in_view: tuple[float, np.ndarray] | None = None  # (time, robots_in_view)

    def skill_driver(self, index: int, skills: SkillConfig) -> SkillDriver:
        """A fresh controller for robot `index`, its platform and size from this world."""
        r = self.world.robots[index]
        settings = skill_settings(self.world.field, r.alliance, r.config)
        return SkillDriver(replace(skills, **settings), self.spec)

    def _probe_spec_world(self) -> World:
        # Robots exist only after a reset; the spec needs their capacities.
        if not self.world.robots:
            self.world.reset(np.random.default_rng(0))
        return self.world

    @property
    def n_robots(self) -> int:
        return len(self.world.lineup)

    def close(self) -> None:
        self.world.close()

    # --- actions ---------------------------------------------------------------------------

    def command(self, index: int, action: Any) -> DriveCommand:
        """Policy action in [-1, 1]^n -> DriveCommand; anything non-finite becomes a stop."""
        a = np.asarray(action, dtype=np.float64).reshape(-1)
        if a.shape[0] != self.config.action_size:
            raise ValueError(
                f"action for robot {index} must have {self.config.action_size} values, "
                f"got shape {np.shape(action)}"
            )
        if not np.all(np.isfinite(a)):
            if self.claims:
                self.claims[index] = None  # a stop claims nothing (as the Jetson's decision)
            return DriveCommand(0.0, 0.0, intake=False, clamp=None)
        rc = self.world.robots[index].config
        if self.config.skills is not None:
            driver = self.drivers[index]
            cmd = skill_command(self.config, driver, self.stacks[index].observation(), a)
            self.claim(index, driver)
            return cmd
        a = np.clip(a, -1.0, 1.0)
        intake, clamp = self.config.actuators(a[2:])
        return DriveCommand(
            float(a[0]) * rc.max_linear_mps, float(a[1]) * rc.max_angular_rad_s, intake, clamp
        )

    def claim(self, index: int, driver: SkillDriver) -> None:
        """Robot `index` claims what its skill driver last drove to (SkillDriver.target), in the
        field frame from where the robot stands (as jetson.decide.Decider.claim does)."""
        r = self.world.robots[index]
        target = driver.target
        if target is None:
            self.claims[index] = None
            return
        xy = robot_to_field(np.asarray(target[1]), r.xy, r.heading)
        self.claims[index] = (float(xy[0]), float(xy[1]))

    # --- episode ----------------------------------------------------------------------------

    def reset(self, rng: np.random.Generator) -> list[np.ndarray]:
        self.world.reset(rng)
        # Each robot's GPS and observation noise has streams of its own, spawned from the
        # match's seed rather than drawn from `rng`: how many numbers one robot's observation
        # takes then changes nobody else's noise, so two players compared on the same seeds
        # meet the same field, the same opponent and the same noise.
        n = len(self.world.robots)
        streams = rng.spawn(2 * n)
        self._gps_rngs, self._obs_rngs = streams[:n], streams[n:]
        self._gps_now = {}
        uncapped = self.config.uncapped_share > 0 and rng.random() < self.config.uncapped_share
        if uncapped:
            for r in self.world.robots:
                r.config = replace(r.config, ring_capacity=None)
        self.uncapped = uncapped
        self.reward = self._rewards[uncapped]
        midgame = (
            self.config.midgame_start_share > 0 and rng.random() < self.config.midgame_start_share
        )
        if midgame:
            self._start_midgame(rng)
        elif self.config.goal_start_share > 0:
            for r in self.world.robots:
                if rng.random() < self.config.goal_start_share:
                    self._start_at_goal(r.index, rng)
        self.stacks = [FrameStack(self.spec) for _ in self.world.robots]
        self.claims = [None for _ in self.world.robots]
        self._in_view = None
        if self.config.skills is not None:
            self.drivers = [
                self.skill_driver(r.index, self.config.skills) for r in self.world.robots
            ]
        z = self.world.field.ring.thickness / 2
        self.memories = [
            RingMemory(self.spec, memory_camera(r.config.camera, z)) for r in self.world.robots
        ]
        self.goal_memories = [GoalMemory(self.spec) for _ in self.world.robots]
        self.totals = [dict.fromkeys(REWARD_COMPONENTS, 0.0) for _ in self.world.robots]
        self.pins = [0 for _ in self.world.robots]
        self.ended_by_pin = False
        self._margin = [self._score_margin(r.alliance) for r in self.world.robots]
        alliances = [r.alliance for r in self.world.robots]
        self._mates = [partner_of(alliances, i) for i in range(len(alliances))]
        self._with_mate = self._partners_touching()
        n = len(self.world.robots)
        self._potentials = {k: [fn(i) for i in range(n)] for k, fn in self._shaping.items()}
        return [s.reset(self.frame(i)) for i, s in enumerate(self.stacks)]

    def _start_midgame(self, rng: np.random.Generator) -> None:
        """The field as it might be some seconds in (midgame_start): part of the rings gone
        (some of them in the robots' intakes, counted as collected before the match's rewards
        start), every robot with its back to one of its goals."""
        w = self.world
        floor = np.flatnonzero(w.ring_state == RING_FLOOR)
        robots = [(r.config.ring_capacity, r.room) for r in w.robots]
        gone, taken = midgame_start(rng, floor, robots, self._start_at_goal)
        for r, mine in zip(w.robots, taken, strict=True):
            w.ring_state[mine] = RING_HELD
            w.ring_owner[mine] = r.index
            r.held += len(mine)
            r.collected += len(mine)
        left = np.setdiff1d(floor, gone)
        w.set_floor_rings(w.ring_xy[left])

    def _start_at_goal(self, index: int, rng: np.random.Generator) -> None:
        w = self.world
        r = w.robots[index]
        mine = [g for g in w.goals if g.spec.alliance == r.alliance]
        pose = goal_start(
            rng,
            [(g.x, g.y) for g in mine],
            [w.clamp_offset(r, g) for g in mine],
            w.field.half - r.config.radius_m,
        )
        if pose is not None:
            w.place_robot(index, *pose)

    def view(self, index: int) -> RobotView:
        w = self.world
        r = w.robots[index]
        if self.config.gps_noise:
            g = self.gps(index)
            pose = (g.x, g.y, g.heading_deg)
        else:
            pose = (r.x, r.y, r.heading)
        rings = sensors.visible_rings(w, index)
        in_view = None
        if self.spec.seen_opponents:  # one matrix a control step serves every robot's view
            if self._in_view is None or self._in_view[0] != w.time_s:
                self._in_view = (w.time_s, sensors.robots_in_view(w))
            in_view = self._in_view[1]
        return robot_view(w, self.spec, index, pose, rings, self.claims, in_view)

    def gps(self, index: int) -> GpsReading:
        """Robot `index`'s noisy GPS reading now. Read twice in one step (the frame, then a
        player that asks for the view), it is the same reading, as a real sensor's would be."""
        g = self._gps_now.get(index)
        if g is None or g.time_s != self.world.time_s:
            g = sensors.gps(self.world, index, self._gps_rngs[index])
            self._gps_now[index] = g
        return g

    def frame(self, index: int) -> np.ndarray:
        """The robot's observation frame now; call once per control step (it feeds the ring
        memory)."""
        rng = self._obs_rngs[index] if self.config.obs_noise else None
        view = self.memories[index].observe(self.view(index))
        if self.spec.goal_sight:  # the goals the camera sees correct the goal memory
            view.goals_seen_robot = visible_goals(self.world, index)
        view = self.goal_memories[index].observe(view)
        return build_frame(self.spec, view, rng)

    def _score_margin(
        self, alliance: AllianceName, score: dict[str, AllianceScore] | None = None
    ) -> float:
        """The alliance's lead in `score` (default: the world's score now)."""
        s = self.world.score() if score is None else score
        other = "blue" if alliance == "red" else "red"
        return float(s[alliance].total - s[other].total)

    def step(self, commands: list[DriveCommand]) -> tuple[list[RobotStep], bool, StepEvents]:
        """One control step for every robot; returns per-robot results and whether it ended."""
        w = self.world
        cfg = self.reward
        before = [r.collected for r in w.robots]
        events = w.step(commands)
        pinned = set()
        for a, b in events.pins:
            pinned.update((a, b))
        ended = events.match_over or (bool(events.pins) and self.config.end_on_pin)
        clamped = {i for i, g in events.clamped if self._goal_scores_for(g, w.robots[i].alliance)}
        if events.pins and self.config.end_on_pin:
            self.ended_by_pin = True
        end_rewards = ended and not self.ended_by_pin
        # Nothing below changes the world: one score serves every robot's reward and info.
        score = w.score()
        touching = self._partners_touching()
        met = [now and not was for now, was in zip(touching, self._with_mate, strict=True)]
        self._with_mate = touching
        results = []
        for r in w.robots:
            comp = dict.fromkeys(REWARD_COMPONENTS, 0.0)
            cap = cfg.ring_cap
            counted = (
                r.collected - before[r.index]
                if cap is None
                else min(r.collected, cap) - min(before[r.index], cap)
            )
            comp["rings"] = cfg.ring * counted
            if r.index in pinned:
                comp["pin"] = cfg.pin
                self.pins[r.index] += 1
            for name, potential in self._shaping.items():
                weight = getattr(cfg, name)
                if weight:
                    now = potential(r.index)
                    comp[name] = weight * (self._potentials[name][r.index] - now)
                    self._potentials[name][r.index] = now
            if cfg.hurry and cap is not None and before[r.index] < cap:
                comp["hurry"] = cfg.hurry * w.dt
            if cfg.clamp and r.index in clamped:
                comp["clamp"] = cfg.clamp
            if met[r.index]:
                comp["partner"] = cfg.partner_contact
            if cfg.score:
                margin = self._score_margin(r.alliance, score)
                comp["score"] = cfg.score * (margin - self._margin[r.index])
                self._margin[r.index] = margin
            if end_rewards:
                comp["goals_end"] = cfg.goal_end * self.goals_counting(r.alliance)
                if self.on_opponent_side(r.index):
                    comp["side_end"] = cfg.opponent_side_end
                if rules.robot_elevated(w, r):
                    comp["elevated_end"] = cfg.elevated_end
            for k, v in comp.items():
                self.totals[r.index][k] += v
            obs = self.stacks[r.index].push(self.frame(r.index))
            info = self.info(r.index, score)
            info["reward_components"] = comp
            results.append(RobotStep(obs, float(sum(comp.values())), comp, info))
        return results, ended, events

    def _partners_touching(self) -> list[bool]:
        """Whether each robot is in contact with its alliance partner now (False alone, and
        always when no reward pays partner_contact: nothing asks PyBullet then)."""
        if not self.reward.partner_contact:
            return [False] * len(self.world.robots)
        return [
            mate is not None and self.world.touching(i, mate) for i, mate in enumerate(self._mates)
        ]

    def _shapings(self) -> dict[str, Callable[[int], float]]:
        """The potential-based shapings: reward component (and its RewardConfig weight) ->
        potential. Each pays weight x (potential before - potential after) a step, so a match
        sums to the potential's change and nothing can be farmed."""
        return {
            "approach": self._ring_potential,
            "park": self._park_potential,
            "goal_approach": self._goal_potential,
        }

    def _ring_potential(self, index: int) -> float:
        """Distance (m) from the robot's front to the nearest ring on the floor; 0 when its
        intake is full or no ring is left (the approach shaping's potential:
        sim.rewards.ring_potential)."""
        if not self.reward.approach:
            return 0.0
        w = self.world
        r = w.robots[index]
        front = np.asarray(r.xy) + r.config.length_m / 2 * heading_vector(r.heading)
        room = np.array([[min(r.room, 1 << 30)]])
        return float(
            ring_potential(
                front[None, None], room, w.ring_xy[None], (w.ring_state == RING_FLOOR)[None]
            )[0, 0]
        )

    def _goal_scores_for(self, goal: int, alliance: AllianceName) -> bool:
        return self.world.goals[goal].spec.alliance in (None, alliance)

    def _goal_potential(self, index: int) -> float:
        """Distance (m) from the robot's clamp point to the nearest goal it could score with
        that no robot holds; 0 while it holds one or none is free (goal_approach's potential:
        sim.rewards.goal_potential)."""
        if not self.reward.goal_approach:
            return 0.0
        w = self.world
        r = w.robots[index]
        clamp = np.array([w.clamp_point(r, g) for g in w.goals]).reshape(1, 1, -1, 2)
        goals = np.array([(g.x, g.y) for g in w.goals]).reshape(1, -1, 2)
        eligible = np.array(
            [g.carried_by is None and self._goal_scores_for(g.index, r.alliance) for g in w.goals]
        ).reshape(1, 1, -1)
        holding = np.array([[r.carried_goal is not None]])
        return float(goal_potential(clamp, goals, eligible, holding)[0, 0])

    def _park_potential(self, index: int) -> float:
        """Distance (m) from the robot to its platform (shrunk by park_margin_m) in the match's
        last park_from_s seconds, else 0 (the park shaping's potential:
        sim.rewards.park_potential)."""
        cfg = self.reward
        w = self.world
        if not cfg.park or w.time_s < w.match_length_s - cfg.park_from_s:
            return 0.0
        r = w.robots[index]
        try:
            plat = w.field.platform(r.alliance)
        except ValueError:
            return 0.0
        half = [[max(v / 2 - cfg.park_margin_m, 0.0) for v in plat.size]]
        xy = np.array([[[r.x, r.y]]])
        return float(
            park_potential(xy, np.array([plat.center]), np.array(half), np.array([[True]]))[0, 0]
        )

    def goals_counting(self, alliance: AllianceName) -> int:
        """Mobile goals that count for the alliance in its own zone (RewardConfig.goal_zone)."""
        w = self.world
        n = 0
        for g in w.goals:
            if not self._goal_scores_for(g.index, alliance):
                continue
            if self.reward.goal_zone == "home":
                owner, _ = rules.goal_owner(w, g)
                n += owner == alliance
            else:
                n += (g.x < 0) == (alliance == "red")
        return n

    def on_opponent_side(self, index: int) -> bool:
        r = self.world.robots[index]
        return (r.x > 0) if r.alliance == "red" else (r.x < 0)

    def info(self, index: int, score: dict[str, AllianceScore] | None = None) -> dict[str, Any]:
        """Robot `index`'s info now; `score` is the world's score when the caller has it."""
        w = self.world
        r = w.robots[index]
        if score is None:
            score = w.score()
        return {
            "robot": r.name,
            "time_s": round(w.time_s, 6),
            "rings_collected": r.collected,
            "rings_held": r.held,
            "carrying_goal": -1 if r.carried_goal is None else r.carried_goal,
            "pins": self.pins[index],
            "score_red": score["red"].total,
            "score_blue": score["blue"].total,
            "reward_components": dict.fromkeys(REWARD_COMPONENTS, 0.0),
            "episode_reward_components": dict(self.totals[index]),
        }


def action_bounds(size: int) -> tuple[np.ndarray, np.ndarray]:
    return -np.ones(size, dtype=np.float32), np.ones(size, dtype=np.float32)
