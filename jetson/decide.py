"""The decision: one State (and the newest perception) in, one Command's worth of driving out.

Pure and deterministic (no I/O, no clock: the caller passes the perception's age), so that
`pete-jetson replay` can re-run a recorded session through exactly this code.

- Phase gating: the policy drives only in `drive_phases`; otherwise the answer is a stop.
- The observation is jetson.autonomy's, built as in training: own pose in the alliance frame,
  rings in the robot frame, no noise; the ring and goal memories when the policy's spec has them
  (the goal memory follows State.goal_clamped; a Brain without a clamp sensor reads as open).
- A skill policy (its policy.json names skills) scores options; jetson.autonomy.skills' controller
  drives the best one from the same observation, as it did in training.
  A perception result older than `perception_max_age_s`, or none, gives no rings: empty slots,
  as the policy saw rings it could not see. The same holds for the goals the camera reports
  (`[camera] goals`, read by the scripted alliance, jetson/scripted.py): an old result has none.
- A camera result is 50-150 ms old when it is used (exposure, detection, the frame's wait for the
  next one). With `frame_pose` its rings are placed from the pose of that moment (PoseHistory:
  the States' GPS poses, interpolated), then seen from the newest pose: turning at 4 rad/s, the
  newest pose puts them 25 degrees off, and the ring memory then forgets the rings it should
  have confirmed.
- With a spec that has the partner block (version 6), the partner's newest report over VEXlink
  (jetson.partner.PartnerInput, from the loop) fills it while the report is at most
  `partner_max_age_s` old; an older one, or none (the link down), leaves it empty: the robot
  plays alone, as it learned to when the partner's reports stopped.
- With a spec whose other-robot slots hold the opponents seen (`seen_opponents`), they are the
  robot detector's robots of the other alliance in a fresh camera result; none otherwise.
- Frame stacking follows the training's control rate (`decision_hz`, normally the policy's): the
  stack takes a frame every control period (on the Brain's clock), and in between the newest slot
  holds the current frame, so each State is answered from fresh data while the history keeps the
  spacing the policy learned.
- A new drive phase after a stop (enable, or a re-enable restarting the phase clock) starts a new
  stack, like a training episode's reset, and forgets the memories, except driver control after
  autonomous (VEX AI's interaction period after its isolation period), with or without the
  field's disable between them: the same match goes on, with its stack and memories.
- The pose is the Brain's (the GPS fused with wheel odometry and the IMU): the policy drives
  while the State has one (pose_fix gps or odometry), so a GPS dropout (the strip hidden by
  robots, goals or the platform) is driven through on odometry. At full speed while its
  pose_std is at most `pose_max_std_m`; beyond that, slower (`pose_speed_scale`: the speeds
  times pose_max_std_m / pose_std, never below half), so a worn pose is driven on carefully
  rather than stopped on (a stopped robot beside what hides the strip would wait for ever);
  only the Brain's pose_fix lost (its trust run out) is a stop.
- Anything that goes wrong (perception that raised on the newest frame, an observation that
  cannot be built, a policy that raises or returns NaN, no pose (pose_fix lost), an unknown
  alliance) gives a stop with the reason named. A camera that stops delivering is
  not an error: its last result ages into "no rings".
"""

from __future__ import annotations

from collections import deque
from dataclasses import dataclass, field
from itertools import pairwise
from typing import Any

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.camera import MemoryCamera
from jetson.autonomy.geometry import AllianceName, angle_diff_deg, robot_to_field, wrap_heading
from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES
from jetson.autonomy.goal_memory import GoalMemory
from jetson.autonomy.observation import FrameStack, RobotView, build_frame
from jetson.autonomy.policy import Policy
from jetson.autonomy.ring_memory import RingMemory
from jetson.autonomy.skills import SkillDriver
from jetson.camera_feed import NO_GOALS, NO_ROBOTS, no_goals, no_robots
from jetson.errors import SettingsError
from jetson.partner import NOTHING, Claim, PartnerInput
from jetson.settings import DecisionConfig
from protocol.messages import (
    Alliance,
    ClampAction,
    GpsStatus,
    LiftAction,
    MatchPhase,
    PoseFix,
    State,
    TargetKind,
)

DEFAULT_DECISION_HZ = 12.0  # sim.config.WorldConfig.control_hz: what policies are trained at
RINGS_UNKNOWN = 255  # State.rings_held when the Brain has no ring counter
# Decision.reason when the decision-maker drives: the policy, or the scripted alliance
# (jetson/scripted.py); any other reason is a stop.
DRIVING_REASONS = frozenset({"policy", "scripted"})
# The slowest a worn pose (pose_std beyond pose_max_std_m) makes the robot drive, as a fraction.
UNCERTAIN_SPEED_MIN = 0.5
CLAMP_HOLDS = 1  # State.goal_clamped: 1 holds a goal, 0 open, 255 no clamp sensor fitted
_NO_RINGS = np.zeros((0, 2))
# Our alliance's code among the robot detector's (jetson.perception.robots.ROBOT_ALLIANCE_CODES:
# the colour codes of jetson.autonomy.goal_colours).
_ALLIANCE_CODES = {Alliance.RED: GOAL_COLOUR_CODES["red"], Alliance.BLUE: GOAL_COLOUR_CODES["blue"]}
# A skill's target as the partner report names it (SkillDriver.target's kinds).
_CLAIMS = {"ring": TargetKind.RING, "goal": TargetKind.GOAL, "platform": TargetKind.PLATFORM}


@dataclass(frozen=True, slots=True)
class PerceptionInput:
    id: int
    age_s: float
    rings_robot_xy: NDArray[np.float64]
    error: str | None = None  # perception raised on the newest frame
    # The goals the camera saw, (N, 3) x, y robot frame and colour code; none without a goal
    # detector (jetson.camera_feed.Perceived.goals_robot).
    goals_robot: NDArray[np.float64] = field(default_factory=no_goals)
    # The robots the camera saw, (N, 3) x, y robot frame and alliance code; none without a robot
    # detector (jetson.camera_feed.Perceived.robots_robot).
    robots_robot: NDArray[np.float64] = field(default_factory=no_robots)

    @classmethod
    def of(cls, perceived: Any, age_s: float) -> PerceptionInput:
        """The decision's view of a camera result (jetson.camera_feed.Perceived), `age_s` old;
        a result from a feed that reports no robots has none."""
        return cls(
            perceived.id,
            age_s,
            perceived.rings_robot_xy,
            perceived.error,
            perceived.goals_robot,
            getattr(perceived, "robots_robot", NO_ROBOTS),
        )


@dataclass(frozen=True, slots=True)
class Decision:
    linear: float  # m/s
    angular: float  # rad/s, clockwise
    intake: bool
    reason: str  # "policy", or why it is a stop
    perception: str = "-"  # fresh | stale | none | - (not looked at)
    rings: int = 0  # rings in the observation
    error: str | None = None  # the exception, when one made this a stop
    clamp: ClampAction = ClampAction.LEAVE  # the goal clamp: hold, release or leave as it is
    lift: LiftAction = LiftAction.LEAVE  # the high-branch lift: up, down or leave as it is

    @property
    def drove(self) -> bool:
        return self.reason in DRIVING_REASONS


class PoseHistory:
    """The GPS poses of the last States, to answer "where was the robot at time t"."""

    def __init__(self, span_ms: float = 1000.0) -> None:
        self.span_ms = span_ms
        self._poses: deque[tuple[float, float, float, float]] = deque()

    def clear(self) -> None:
        self._poses.clear()

    def push(self, time_ms: float, x: float, y: float, heading_deg: float) -> None:
        if self._poses and time_ms < self._poses[-1][0]:
            self._poses.clear()  # the Brain's clock went back: a reboot
        self._poses.append((time_ms, x, y, heading_deg))
        while self._poses[-1][0] - self._poses[0][0] > self.span_ms:
            self._poses.popleft()

    def at(self, time_ms: float) -> tuple[float, float, float] | None:
        """The pose at time_ms, interpolated between the States around it (heading the short
        way round); None when the history does not reach back that far or is empty."""
        poses = self._poses
        if not poses or time_ms < poses[0][0]:
            return None
        if time_ms >= poses[-1][0]:
            return poses[-1][1:]
        for (t0, x0, y0, h0), (t1, x1, y1, h1) in pairwise(poses):
            if t0 <= time_ms <= t1:
                f = 0.0 if t1 == t0 else (time_ms - t0) / (t1 - t0)
                heading = float(wrap_heading(h0 + f * angle_diff_deg(h1, h0)))
                return x0 + f * (x1 - x0), y0 + f * (y1 - y0), heading
        return poses[-1][1:]


def stop(reason: str, error: str | None = None) -> Decision:
    return Decision(0.0, 0.0, False, reason, error=error)


@dataclass(frozen=True, slots=True)
class PhaseStep:
    """What one State means for the match: may the robot drive, does a new match start (forget
    the history), and is this the disable between VEX AI's periods (keep it)."""

    drive: bool
    entering: bool
    pause: bool


class PhaseTracker:
    """Follows the Brain's phase from State to State (every decision-maker's first gate)."""

    def __init__(self, drive_phases: tuple[str, ...]) -> None:
        self._drive_phases = {MatchPhase[p.upper()] for p in drive_phases}
        self.reset()

    def reset(self) -> None:
        self._phase: MatchPhase | None = None
        self._phase_ms = 0
        self._enabled_phase: MatchPhase | None = None  # the last drive phase decided in

    def step(self, state: State) -> PhaseStep:
        phase = state.phase
        restarted = phase != self._phase or state.phase_ms < self._phase_ms
        # Autonomous -> driver is the same match going on (VEX AI's isolation -> interaction),
        # with or without the field's disable between them: keep the history.
        entering = restarted and not (
            self._enabled_phase == MatchPhase.AUTONOMOUS and phase == MatchPhase.DRIVER
        )
        self._phase, self._phase_ms = phase, state.phase_ms
        if phase not in self._drive_phases:
            # The disable between isolation and interaction keeps the history as well.
            pause = phase == MatchPhase.DISABLED and self._enabled_phase == MatchPhase.AUTONOMOUS
            return PhaseStep(False, False, pause)
        self._enabled_phase = phase
        return PhaseStep(True, entering, False)


def why_not_drive(state: State) -> str | None:
    """The stop reason a State in a drive phase still gives (an unknown alliance; no pose), or
    None: the pose is the Brain's, the GPS fused with odometry and the IMU, driven on while it
    rests on the GPS or, through a dropout, on odometry (pose_speed_scale says how fast)."""
    if state.alliance == Alliance.UNKNOWN:
        # The Brain finds it at run time: its screen's pick, or the GPS start pose.
        return "alliance unknown: pick it on the Brain's screen"
    gps = state.gps_status.name.lower()
    if state.pose_fix == PoseFix.LOST:
        return "pose lost" if state.gps_status == GpsStatus.OK else f"gps {gps}"
    return None


def pose_speed_scale(state: State, config: DecisionConfig) -> float:
    """What the decision's speeds are multiplied by for the pose's trust: 1 while the Brain's
    pose_std is within pose_max_std_m; beyond it pose_max_std_m / pose_std, never below
    UNCERTAIN_SPEED_MIN (a robot on a worn pose drives on, carefully, until the strip is seen
    again and the GPS corrects it)."""
    limit = config.pose_max_std_m
    if state.pose_std <= limit:  # NaN never reaches here (the codec refuses it)
        return 1.0
    return max(UNCERTAIN_SPEED_MIN, limit / state.pose_std)


def alliance_name(alliance: Alliance) -> AllianceName:
    """The State's alliance as the autonomy code names it; callers have stopped on UNKNOWN
    (why_not_drive) before they ask."""
    return "red" if alliance == Alliance.RED else "blue"


def perceived_rings(
    perception: PerceptionInput | None, config: DecisionConfig
) -> tuple[NDArray[np.float64], str]:
    """The camera's rings (robot frame) and how they stand: fresh, stale (older than
    perception_max_age_s: no rings) or none."""
    if perception is None:
        return _NO_RINGS, "none"
    if not perception.age_s <= config.perception_max_age_s:
        return _NO_RINGS, "stale"
    return perception.rings_robot_xy, "fresh"


def perceived_goals(
    perception: PerceptionInput | None, config: DecisionConfig
) -> NDArray[np.float64]:
    """The camera's goals (robot frame, colour code), by perceived_rings' rule: a stale result,
    or none, has no goals."""
    if perception is None or perceived_rings(perception, config)[1] != "fresh":
        return NO_GOALS
    return perception.goals_robot


def perceived_opponents(
    perception: PerceptionInput | None, config: DecisionConfig, alliance: Alliance
) -> NDArray[np.float64]:
    """The opponents the camera saw (robot frame, (N, 2)) by perceived_rings' rule: the robot
    detector's robots (jetson/perception/robots.py) of the other alliance; none from a stale
    result, from none, or with our alliance unknown."""
    if perception is None or perceived_rings(perception, config)[1] != "fresh":
        return _NO_RINGS
    robots = np.asarray(perception.robots_robot, dtype=np.float64)
    ours = _ALLIANCE_CODES.get(alliance)
    if ours is None or robots.size == 0:
        return _NO_RINGS
    robots = robots.reshape(-1, 3)
    return robots[robots[:, 2] != ours, :2]


def rings_held(state: State, config: DecisionConfig) -> int:
    """The Brain's ring counter when it has one (255 means none is fitted), else the configured
    stand-in."""
    return config.rings_held if state.rings_held == RINGS_UNKNOWN else state.rings_held


class Decider:
    def __init__(
        self,
        policy: Policy,
        config: DecisionConfig | None = None,
        camera: MemoryCamera | None = None,
    ) -> None:
        # `camera`: the robot's camera, for a policy whose ring memory looks through it
        # (memory_view "camera"); the daemon builds it from [camera]'s config.
        self.policy = policy
        self.config = config or DecisionConfig()
        self.camera = camera
        hz = self.config.decision_hz or getattr(policy, "control_hz", None) or DEFAULT_DECISION_HZ
        self.decision_hz = float(hz)
        self.period_ms = 1000.0 / self.decision_hz
        self.spec = policy.spec
        names = tuple(policy.action_names)
        self._skills = getattr(policy, "skills", None)
        if self._skills is None and names[:2] != ("linear", "angular"):
            raise SettingsError(f"the policy's actions must start with linear, angular: {names}")
        self._scale = np.asarray(policy.action_scale[:2], dtype=np.float64)
        self._intake_index = names.index("intake") if "intake" in names else None
        self._phases = PhaseTracker(self.config.drive_phases)
        # The last observation and policy output (None after a stop without one): what the
        # dashboard shows of the decision (jetson/dashboard/snapshot.py).
        self.last_obs: NDArray[np.float32] | None = None
        self.last_action: NDArray[np.float64] | None = None
        self.reset()

    @property
    def ring_memory(self) -> RingMemory:
        return self._memory

    @property
    def goal_memory(self) -> GoalMemory:
        return self._goals

    @property
    def skill_driver(self) -> SkillDriver | None:
        return self._driver

    def reset(self) -> None:
        """Forget the history: a new connection or a new match."""
        self._stack: FrameStack | None = None
        self._memory = RingMemory(self.spec, self.camera)
        self._goals = GoalMemory(self.spec)
        self._driver = None if self._skills is None else SkillDriver(self._skills, self.spec)
        self._poses = PoseHistory()
        self._drove = False
        self._next_push_ms = 0.0
        self._phases.reset()

    def claim(self, state: State) -> Claim:
        """The target this robot claims for its partner (jetson.partner): a skill policy's is
        the target of the skill it drove last (a ring, a goal or the platform), in the field
        frame; nothing while it does not drive, and nothing for a policy that drives the
        wheels itself."""
        target = None if self._driver is None or not self._drove else self._driver.target
        if target is None:
            return NOTHING
        kind, local = target
        xy = robot_to_field(np.asarray(local), (state.x, state.y), state.heading)
        return Claim(_CLAIMS[kind], (float(xy[0]), float(xy[1])))

    def decide(
        self,
        state: State,
        perception: PerceptionInput | None,
        partner: PartnerInput | None = None,
    ) -> Decision:
        """The answer to one State, from the newest perception and (for a spec with the
        partner block) the partner's newest report."""
        self._drove = False  # until this State's answer drives
        decision = self._decide(state, perception, partner)
        self._drove = decision.drove
        return decision

    def _decide(
        self, state: State, perception: PerceptionInput | None, partner: PartnerInput | None
    ) -> Decision:
        self.last_obs = self.last_action = None
        step = self._phases.step(state)
        if not step.drive:
            # The disable between isolation and interaction keeps the frame stack as well.
            if not step.pause:
                self._stack = None
            return stop(f"phase {state.phase.name.lower()}")
        if step.entering:
            self._stack = None
            self._poses.clear()
            self._memory.reset()
            self._goals.reset()
            if self._driver is not None:
                self._driver.reset()
        why = why_not_drive(state)
        if why is not None:
            return stop(why)
        self._poses.push(float(state.time_ms), state.x, state.y, state.heading)
        rings, seen = perceived_rings(perception, self.config)
        if seen == "fresh" and perception is not None and perception.error is not None:
            return Decision(0.0, 0.0, False, "perception error", seen, 0, perception.error)
        seen_from = None
        if seen == "fresh" and perception is not None and self.config.frame_pose:
            seen_from = self._poses.at(state.time_ms - 1000.0 * max(perception.age_s, 0.0))
        try:
            opponents = (
                perceived_opponents(perception, self.config, state.alliance)
                if self.spec.seen_opponents
                else _NO_RINGS
            )
            goals = perceived_goals(perception, self.config) if self.spec.goal_sight else None
            obs = self._observation(
                state, rings, fresh=seen == "fresh", seen_from=seen_from, partner=partner,
                opponents=opponents, goals=goals,
            )  # fmt: skip
            action = np.asarray(self.policy(obs), dtype=np.float64).reshape(-1)
        except Exception as exc:
            return Decision(
                0.0, 0.0, False, "error", seen, len(rings), f"{type(exc).__name__}: {exc}"
            )
        if action.size < 2 or not np.all(np.isfinite(action)):
            return Decision(0.0, 0.0, False, "policy output not finite", seen, len(rings))
        self.last_obs, self.last_action = obs, action
        if self._driver is not None:
            # A skill policy: its highest-scored skill, driven from the same observation.
            try:
                linear, angular = self._driver.command(obs, action)
            except Exception as exc:
                return Decision(
                    0.0, 0.0, False, "error", seen, len(rings), f"{type(exc).__name__}: {exc}"
                )
            k = pose_speed_scale(state, self.config)
            # The controller lets go of a goal in a tug of war it loses (release_dragged_s).
            clamp = ClampAction.RELEASE if self._driver.release else ClampAction.LEAVE
            return Decision(k * linear, k * angular, True, "policy", seen, len(rings), clamp=clamp)
        action = np.clip(action, -1.0, 1.0)
        linear, angular = (action[:2] * self._scale * pose_speed_scale(state, self.config)).tolist()
        i = self._intake_index
        # Policies trained without an intake action had the intake always on.
        intake = True if i is None else bool(action[i] > 0)
        return Decision(linear, angular, intake, "policy", seen, len(rings))

    def _observation(
        self,
        state: State,
        rings: NDArray[np.float64],
        fresh: bool = True,
        seen_from: tuple[float, float, float] | None = None,
        partner: PartnerInput | None = None,
        opponents: NDArray[np.float64] = _NO_RINGS,
        goals: NDArray[np.float64] | None = None,
    ) -> NDArray[np.float32]:
        t = state.phase_ms / 1000.0
        if state.phase == MatchPhase.DRIVER:
            t += self.config.driver_time_offset_s
        view = RobotView(
            x=state.x,
            y=state.y,
            heading_deg=state.heading,
            alliance=alliance_name(state.alliance),
            time_s=t,
            rings_robot_xy=rings,
            rings_held=rings_held(state, self.config),
            # Without a clamp sensor the policy is told the clamp is open, and the goal memory
            # never sees a goal taken.
            goal_clamped=state.goal_clamped == CLAMP_HOLDS,
            intake_fills=self.config.intake_fills,
            tall=self.config.role == "24in",
            others_robot_xy=opponents,
        )
        # A report older than partner_max_age_s is none: the robot plays alone.
        if self.spec.partner and partner and partner.age_s <= self.config.partner_max_age_s:
            view.partner = partner.view(state.x, state.y, state.heading)
        # Only a fresh camera frame may tell the memory that a ring is gone.
        view = self._memory.observe(view, seen_from) if fresh else self._memory.recall(view)
        if fresh and goals is not None:  # a fresh camera result's goals correct the memory
            view.goals_seen_robot = goals
        view = self._goals.observe(view, seen_from)
        frame = build_frame(self.spec, view)
        now_ms = float(state.time_ms)
        if self._stack is None:
            self._stack = FrameStack(self.spec)
            self._next_push_ms = now_ms + self.period_ms
            return self._stack.reset(frame)
        if now_ms >= self._next_push_ms:
            self._next_push_ms += self.period_ms
            if now_ms >= self._next_push_ms:  # fell behind (a gap in States): start the beat again
                self._next_push_ms = now_ms + self.period_ms
            return self._stack.push(frame)
        committed = self._stack.observation()
        return np.concatenate((frame, committed[self.spec.frame_size :]))
