"""The scripted alliance as the daemon's decision-maker: `[decision] player = "alliance"`.

jetson/autonomy/alliance.py's strategy plays the whole Tipping Point match for one robot of a VEX
AI alliance (the 24" or the 15", `[decision] role`). Here it drives the real robot from what the
daemon has, the same inputs the twin hands it (sim/baselines/alliance.py): the Brain's pose, the
camera's rings and goals (the pipeline's goal detector, jetson/perception/goals.py, on by default
with this player: `[camera] goals`; those on a platform's footprint dropped, as only a pose can
tell them), the intake's count, the clamp and the lift, the match clock.
So a team can field the whole game before any learned alliance exists. A camera result older
than `perception_max_age_s` gives no rings and no goals, as for a policy.

ScriptedDecider has jetson.decide.Decider's interface (decide(State, PerceptionInput) ->
Decision, reset(), the memories the dashboard draws) and passes the same gates (jetson.decide's
PhaseTracker and why_not_drive): it drives only in the drive phases, with a known alliance and a
pose (slower on a worn one: pose_speed_scale), and keeps its history through the disable between
isolation and interaction. It steps the strategy at the rate the twin runs it (`decision_hz`,
12 Hz by default) and repeats the last action in between, as a policy's frame stack keeps its
training's spacing.
"""

from __future__ import annotations

import math

import numpy as np

from jetson.autonomy.alliance import AllianceStrategy
from jetson.autonomy.alliance_config import (
    AllianceAction,
    AllianceConfig,
    AllianceInputs,
    RobotRole,
)
from jetson.autonomy.field_layout import FieldLayout, load_layout
from jetson.autonomy.goal_memory import GoalMemory
from jetson.autonomy.goal_sightings import off_the_platforms
from jetson.autonomy.ring_memory import RingMemory
from jetson.decide import (
    CLAMP_HOLDS,
    DEFAULT_DECISION_HZ,
    Decision,
    PerceptionInput,
    PhaseTracker,
    alliance_name,
    perceived_goals,
    perceived_rings,
    pose_speed_scale,
    rings_held,
    stop,
    why_not_drive,
)
from jetson.partner import NOTHING, Claim
from jetson.settings import DecisionConfig
from protocol.messages import (
    Alliance,
    ClampAction,
    LiftAction,
    LiftState,
    MatchPeriod,
    MatchPhase,
    State,
    TargetKind,
)

# The standard robots of a VEX AI alliance, as the twin builds them (sim/config.py's ROBOTS and
# the intake each has; tests/jetson/test_scripted.py checks they agree).
ROBOTS: dict[str, RobotRole] = {
    "24in": RobotRole(
        role="24in", length_m=0.6096, width_m=0.6096, mass_kg=9.0, max_linear_mps=0.904,
        max_angular_rad_s=4.8, intake_zone=(-0.15, 0.15, 0.254, 0.4356),
        reaches_high_branch=True, partner_mass_kg=5.5, ring_capacity=10,
    ),
    "15in": RobotRole(
        role="15in", length_m=0.381, width_m=0.381, mass_kg=5.5, max_linear_mps=0.904,
        max_angular_rad_s=4.8, intake_zone=(-0.11, 0.11, 0.1397, 0.3213),
        reaches_high_branch=False, partner_mass_kg=9.0, ring_capacity=10,
    ),
}  # fmt: skip
DRIVING = "scripted"  # Decision.reason while the strategy drives


class ScriptedDecider:
    """The scripted alliance behind the daemon's decision interface (see the module doc)."""

    policy = None  # no policy file: the dashboard reads no skills from it
    camera = None
    skill_driver = None

    def __init__(
        self,
        config: DecisionConfig | None = None,
        role: RobotRole | None = None,
        layout: FieldLayout | None = None,
    ) -> None:
        self.config = config or DecisionConfig()
        self.role = role or ROBOTS[self.config.role]
        self.layout = layout or load_layout()
        steal = float(self.config.steal_s) or None  # 0: no steal
        self.strategy = AllianceStrategy(
            self.role,
            self.layout,
            AllianceConfig(steal_s=steal, steal_climb=bool(self.config.steal_climb)),
        )
        self.spec = self.strategy.spec
        self.decision_hz = float(self.config.decision_hz or DEFAULT_DECISION_HZ)
        self.period_ms = 1000.0 / self.decision_hz
        self.description = f"scripted alliance ({self.role.role})"
        self._phases = PhaseTracker(self.config.drive_phases)
        # The strategy keeps its own beliefs of the goals; the dashboard's goal memory is empty.
        self._goals = GoalMemory(self.spec)
        self.last_obs = None
        self.last_action = None
        self.reset()

    @property
    def ring_memory(self) -> RingMemory:
        return self.strategy.memory

    @property
    def goal_memory(self) -> GoalMemory:
        return self._goals

    def reset(self) -> None:
        """Forget the match: a new connection or a new match."""
        self.strategy.reset()
        self._goals.reset()
        self._phases.reset()
        self._action: AllianceAction | None = None
        self._next_ms = 0.0
        self._drives = False

    def match_time_s(self, state: State) -> float:
        """Seconds since the match started, isolation included: the Brain's VEX AI match clock,
        or outside a field-controlled match the phase's clock (driver control counted after the
        layout's isolation period)."""
        if state.period != MatchPeriod.BEFORE:
            return state.match_ms / 1000.0
        t = state.phase_ms / 1000.0
        return t + self.layout.isolation_s if state.phase == MatchPhase.DRIVER else t

    def claim(self, state: State) -> Claim:
        """The strategy's target for the partner report (jetson.partner), in the field frame:
        the goal it goes for, the ring it drives to or the platform; nothing outside the drive
        phases or with the alliance unknown."""
        if state.alliance == Alliance.UNKNOWN or not self._drives:
            return NOTHING
        got = self.strategy.field_claim(alliance_name(state.alliance))
        return NOTHING if got is None else Claim(_CLAIMS[got[0]], got[1])

    def decide(
        self, state: State, perception: PerceptionInput | None, partner: object = None
    ) -> Decision:
        """The strategy's answer; the partner's report (`partner`) is not read: the scripted
        alliance shares the work by role, not by what its partner says."""
        decision = self._decide(state, perception)
        self._drives = decision.drove  # claim() claims only while the strategy drives
        return decision

    def _decide(self, state: State, perception: PerceptionInput | None) -> Decision:
        step = self._phases.step(state)
        if not step.drive:
            return stop(f"phase {state.phase.name.lower()}")
        if step.entering:
            self.strategy.reset()
            self._action = None
        why = why_not_drive(state)
        if why is not None:
            return stop(why)
        rings, seen = perceived_rings(perception, self.config)
        if seen == "fresh" and perception is not None and perception.error is not None:
            return Decision(0.0, 0.0, False, "perception error", seen, 0, perception.error)
        now_ms = float(state.time_ms)
        if self._action is None or now_ms >= self._next_ms:
            self._next_ms = max(self._next_ms + self.period_ms, now_ms)
            inputs = AllianceInputs(
                x=state.x,
                y=state.y,
                heading_deg=state.heading,
                alliance=alliance_name(state.alliance),
                time_s=self.match_time_s(state),
                rings_robot_xy=np.asarray(rings, dtype=np.float64).reshape(-1, 2),
                rings_held=rings_held(state, self.config),
                goal_clamped=state.goal_clamped == CLAMP_HOLDS,
                lift_up=state.lift == LiftState.UP,
                # A daemon without a goal detector reports none: the strategy then plays as
                # without one (its goals dead-reckoned from the layout and the clamp). A sighting
                # on a platform's footprint is dropped (jetson/autonomy/goal_sightings.py).
                goals_robot=off_the_platforms(
                    perceived_goals(perception, self.config),
                    (state.x, state.y),
                    state.heading,
                    self.layout.platform,
                ),
            )
            try:
                self._action = self.strategy.step(inputs)
            except Exception as exc:
                self._action = None
                return Decision(
                    0.0, 0.0, False, "error", seen, len(rings), f"{type(exc).__name__}: {exc}"
                )
        a = self._action
        if not (math.isfinite(a.linear) and math.isfinite(a.angular)):
            return Decision(0.0, 0.0, False, "strategy output not finite", seen, len(rings))
        k = pose_speed_scale(state, self.config)  # slower on a worn pose (jetson.decide)
        return Decision(
            k * float(a.linear),
            k * float(a.angular),
            bool(a.intake),
            DRIVING,
            seen,
            len(rings),
            clamp=_clamp(a.clamp),
            lift=_lift(a.lift),
        )


_CLAIMS = {
    "goal": TargetKind.GOAL, "ring": TargetKind.RING, "platform": TargetKind.PLATFORM,
    "zone": TargetKind.ZONE,
}  # fmt: skip


def _clamp(hold: bool | None) -> ClampAction:
    return ClampAction.LEAVE if hold is None else ClampAction.HOLD if hold else ClampAction.RELEASE


def _lift(up: bool | None) -> LiftAction:
    return LiftAction.LEAVE if up is None else LiftAction.UP if up else LiftAction.DOWN
