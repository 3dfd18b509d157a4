"""The scripted alliance: a hand-written strategy for the whole Tipping Point match, one robot of
a VEX AI alliance (a 24" and a 15") per instance.

It reads only what the robot has: its pose (the GPS, field frame), the rings its camera sees
(robot frame), the rings its intake holds, the clamp's and the lift's state, the match clock, the
goals its goal detector reports (robot frame and base colour, optional: jetson/perception/goals.py)
and the field's layout known before the match (jetson/autonomy/field_layout.py). Its memories are
its own: a RingMemory (jetson/autonomy/ring_memory.py) started from the layout's rings, and a
named memory of the goals (the layout's places, moved where it released them or saw them, the
ones it found missing or saw carried). Everything is planned in the alliance frame, so a blue
robot plays the same script mirrored.

The two robots share the work by a fixed plan (no radio between them): each role has its own
goals, its own half of the field for rings, and its own time line.

  24" (the high-branch lift)                  15"
  isolation: stand still (its start leaves    isolation: back onto the alliance goal beside
  no room to turn; standing still it cannot   its start (the preloads thread on), climb the
  touch the other alliance);                  platform and wait at the hinge: the board level
  interaction: take a neutral goal (south,    under it and its goal, so nobody drives onto it;
  tall, north, then its AWP goal), the        22 s before the end: move to the field side
  preloads on the high branch, collect its    (the ramp down);
  half's rings;
  32 s before the end: line up in front of    14 s before the end: move to its balance spot.
  the platform, climb from 20.5 s, hold the
  ramp down; 9 s before the end: move to the
  balance point.

A goal it cannot find (the clamp does not close where the goal should be, or the robot stands
where it was), one seen carried, one where a goal of the other alliance's colour is seen, one
the camera does not show where it is believed when the robot looks before backing onto it, or
one chased 15 s without the clamp closing, is marked missing (or left for a while) and the next
one on its list is tried. A goal beside a platform is backed onto from where the robot's whole
footprint stays off both platforms. A neutral goal pushed up the board into the 24"'s lane
(a goal blocks it in about one match in five against the ring race, mostly pushed there in
isolation) is taken off it once the sentry unlocks the board: the 24" backs up its lane onto
it, pulls it straight out and climbs with it.
The steal (`steal_s`, measured in docs/notes/2026-11-27-the-steal.md): the 24" gives up its
climb, leaves its goal in the home zone and takes neutral goals from outside it instead, the
one it last saw moving (another robot carries it: the other alliance's loaded goal, whose rings
then count for this alliance) first; that one it drags home and holds there to the end, a free
one it leaves there and takes the next. The 15" then stays at its lock spot, balanced alone.
With `steal_climb` (docs/notes/2026-11-27-steal-then-climb.md) both climb after all: the 24"
tows the goal another robot holds to its stage (always pulling ahead: a tug of war goes to the
harder pull), waits there and climbs with it, and the 15" plays the climbing endgame.
Options off by default (measured, docs/notes/2026-11-27-raid-and-lane.md): the deposit and the
raid (the 24" leaves its goal in the home zone and fetches the free goals of either colour from
outside it, the other alliance's zone first). The endgame's
positions come from the see-saw's torque balance (the layout's board mass and hinge flats, both
robots' masses, the carried goals'): the 24" holds the board tipped toward the field at
`hold_along_m`, the 15" moves to `partner_along_m`, then the 24" moves to where the torques
cancel.

Its settings and messages (RobotRole, AllianceConfig, AllianceInputs, AllianceAction) live in
jetson/autonomy/alliance_config.py, its own state types (the pose, a step's command, a goal
belief) in jetson/autonomy/alliance_state.py, and the steal's phases (the steal, the haul, the
tow) in jetson/autonomy/alliance_steal.py, a mixin of AllianceStrategy.

Interface (what the daemon's decide.py calls):

    strategy = AllianceStrategy(RobotRole.from_dict(...), load_layout())
    strategy.reset()                                   # a new match
    linear, angular, clamp, lift, intake = strategy.step(AllianceInputs(...))

linear m/s, angular rad/s clockwise (the protocol's Command), clamp True hold / False release /
None leave, lift True up / False down, intake on or off.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass, field

import numpy as np

from jetson.autonomy.alliance_config import (
    AllianceAction,
    AllianceConfig,
    AllianceInputs,
    RobotRole,
)
from jetson.autonomy.alliance_state import GoalBelief, Move, Pose, Vec
from jetson.autonomy.alliance_steal import StealPhases
from jetson.autonomy.carried_goal import CarriedGoalTracker
from jetson.autonomy.field_layout import FieldLayout, GoalLayout
from jetson.autonomy.geometry import (
    AllianceName,
    angle_diff_deg,
    field_to_robot,
    heading_of,
    robot_to_field,
    to_alliance_frame,
)
from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES
from jetson.autonomy.observation import RobotView
from jetson.autonomy.ring_memory import RingMemory
from jetson.autonomy.skills import Trail, arc_through, back_onto, pursuit_point, turn_first
from jetson.autonomy.spec import SPEC_VERSION, ObservationSpec


@dataclass(frozen=True)
class _IsoTask:
    """One isolation-period job: back onto `goal`, leave `rings` preloads on it (None: all),
    drag it so the robot stands at `drag_to`, then let go (or keep it with `keep`)."""

    goal: str
    rings: int | None = None
    drag_to: tuple[float, float] | None = None
    keep: bool = False
    wait: bool = True  # wait for the rings to thread on before the next job (else: keep going)


@dataclass
class _Plan:
    """One role's fixed plan: its isolation jobs in order, the interaction's goal list."""

    iso: list[_IsoTask] = field(default_factory=list)
    neutral: list[str] = field(default_factory=list)  # interaction goals, in order
    sentry: bool = False  # after its isolation jobs, wait on the platform (see _phase_sentry)


def default_plan(role: str, layout: FieldLayout) -> _Plan:
    """The 15" backs onto the alliance goal beside its start, threads its three preloads onto it
    and keeps it all match; the 24" stands still through the isolation period (its start leaves
    no room to turn without sweeping the alliance goal on the AWP line away, and a robot
    standing still cannot touch the other alliance) and keeps its preloads for a neutral goal's
    high branch, taking the nearest neutral goal as interaction starts."""
    own = [g for g in layout.goals if g.owner == "own"]
    other_own = next(g.name for g in own if g.name != layout.awp_goal)
    neutrals = sorted((g for g in layout.goals if g.owner is None), key=lambda g: g.xy[1])
    south, north = neutrals[0].name, neutrals[-1].name
    middle = [g.name for g in neutrals[1:-1]]
    if role == "24in":
        return _Plan([], [south, *middle, north, layout.awp_goal])
    return _Plan(
        [_IsoTask(other_own, None, None, keep=True, wait=False)], [north, other_own], sentry=True
    )


# The phases in which a robot is on its way onto the platform or on it (claim()).
_PLATFORM_PHASES = frozenset({"climb", "haul_climb", "balance", "sentry"})


def _segment_distance(point: Vec, a: Vec, b: Vec) -> float:
    ab = b - a
    n = float(ab @ ab)
    t = 0.0 if n < 1e-12 else min(1.0, max(0.0, float((point - a) @ ab) / n))
    return float(np.hypot(*(point - (a + t * ab))))


class AllianceStrategy(StealPhases):
    """One robot of the scripted alliance: reset() at a match's start, step() every control
    step (see the module docstring)."""

    def __init__(
        self, role: RobotRole, layout: FieldLayout, config: AllianceConfig | None = None
    ) -> None:
        self.role = role
        self.layout = layout
        self.config = config or AllianceConfig()
        self.name = f"alliance-{role.role}"
        self.spec = ObservationSpec(
            version=SPEC_VERSION,
            ring_memory=True,
            prior_rings=layout.rings,
            memory_forget_intake=True,
            memory_intake_zone=role.intake_zone,
            match_length_s=layout.match_length_s,
        )
        self.memory = RingMemory(self.spec)
        # The goal with the widest base: the clamp's reach for a goal not known by name.
        self._widest = max(layout.goals, key=lambda g: g.base_radius_m)
        self._trail = Trail(self.config.stuck_window_s, self.config.stuck_distance_m)
        self.reset()

    # --- the interface ---------------------------------------------------------------------

    def reset(self) -> None:
        self.memory.reset()
        self._trail.clear()
        self.plan = default_plan(self.role.role, self.layout)
        if self.role.role == "24in":
            neutral = [n for n in self.plan.neutral if self.layout.goal(n).owner is None]
            keep = neutral[: max(0, self.config.neutral_goals_24)]
            self.plan.neutral = [n for n in self.plan.neutral if n in keep or n not in neutral]
        self._iso_index = 0
        self._held_at_clamp = 0
        self.goals = {
            g.name: GoalBelief(g, np.array(g.xy, dtype=np.float64)) for g in self.layout.goals
        }
        self.phase = "iso_goal"
        self.phase_since = 0.0
        self.holding: str | None = None  # the goal it believes it holds
        self.target_goal: str | None = None
        self._ring_target: Vec | None = None
        self._ring_since = 0.0
        self._ignored: list[tuple[Vec, float]] = []
        self._backoff_until = -1.0
        self._backoff_turn = 1.0
        self._backoff_dir = -1.0
        self._was_clamped = False
        self._staged = False
        self._climbing = False
        self._climb_track: list[tuple[float, float]] = []
        self._climb_retried = False
        self._guarding = False
        self._sentry_set = False
        self._tug_until = -1.0
        self._tugs = 0
        # t, x, y, heading, commanded v
        self._moves: list[Move] = []
        self._stage_goal: str | None = None
        self._stage_since = 0.0
        self._last_t = 0.0
        self._now = 0.0
        self._goal_seen: dict[str, tuple[float, Vec]] = {}  # name -> (time, where) last seen
        self._busy: dict[str, float] = {}  # name -> carried by another robot until
        self._chased: dict[str, float] = {}  # name -> chased too long: not stolen until
        self._opponent_goals: list[tuple[float, Vec]] = []  # (time, where) of the other colour
        self._given_up: set[str] = set()  # goals let go in a tug of war
        self._detector = False  # a goal detector reports (AllianceInputs.goals_robot)
        self._confirmed: str | None = None  # the goal seen just before backing onto it
        self._look_since: float | None = None
        self._no_ring_since: float | None = None
        self._deposited: list[str] = []  # goals left in the home zone, oldest first
        self._clamped_at = 0.0  # when the clamp last closed
        self._sightings: list[tuple[float, Vec]] = []  # (time, where) of every goal seen lately
        self._lane_goal_xy: Vec | None = None  # a goal on the board in the 24"'s lane
        self._clear_since: float | None = None
        self._clear_backing = False
        # The neutral goal another robot carries (the steal's first target).
        self._tracker = CarriedGoalTracker(self.config.carried_mps, self.config.carried_s)
        self._dragged_checked = False  # a whole drag window was read since the clamp closed
        self._test_to: Vec | None = None  # where the steal tests the goal it clamped
        self._lined = False  # climbing with a held goal: in its lane, heading for the wall
        self._towing = True  # towing a held goal to its stage (else lining up there)
        self._contested = False  # the goal hauled is another robot's too: held to the end
        self._stage_xy: Vec | None = None  # the stage it drives to now
        self._bad_stages: list[Vec] = []  # stages it was blocked on, stealing this goal
        self._reset_steal()
        self.intent = "start"  # what the last step was doing, for logs and tests

    def claim(self) -> tuple[str, Vec | None]:
        """What this robot is going for, for its partner (alliance frame): ("platform", its
        centre) while it climbs, balances or waits on it; ("zone", the home zone's centre)
        while it parks there; ("goal", where the goal is believed to be) while it goes for one
        and holds none; ("ring", the ring) while it drives to one; else ("nothing", None)."""
        if self.phase in _PLATFORM_PHASES:
            return "platform", np.asarray(self.layout.platform.center, dtype=np.float64)
        if self.phase == "park":
            x0, y0, x1, y1 = self.layout.home_zone
            return "zone", np.array([(x0 + x1) / 2, (y0 + y1) / 2])
        if self.target_goal is not None and self.holding is None:
            belief = self.goals.get(self.target_goal)
            if belief is not None and belief.xy is not None:
                return "goal", np.array(belief.xy, dtype=np.float64)
        if self._ring_target is not None:
            return "ring", np.array(self._ring_target, dtype=np.float64)
        return "nothing", None

    def field_claim(self, alliance: AllianceName) -> tuple[str, tuple[float, float]] | None:
        """claim() in the field frame for a robot of `alliance` (what its partner report and the
        twin's partner block carry); None when it claims nothing."""
        kind, xy = self.claim()
        if kind == "nothing" or xy is None:
            return None
        fx, fy = to_alliance_frame(np.asarray(xy, dtype=np.float64), None, alliance)[0]
        return kind, (float(fx), float(fy))

    def step(self, inputs: AllianceInputs) -> AllianceAction:
        xy, heading = to_alliance_frame((inputs.x, inputs.y), inputs.heading_deg, inputs.alliance)
        assert heading is not None
        pose = Pose(np.asarray(xy, dtype=np.float64), float(heading), float(inputs.time_s))
        dt = max(0.0, pose.t - self._last_t)
        self._last_t = pose.t
        view = RobotView(
            x=inputs.x,
            y=inputs.y,
            heading_deg=inputs.heading_deg,
            alliance=inputs.alliance,  # type: ignore[arg-type]
            time_s=inputs.time_s,
            rings_robot_xy=np.asarray(inputs.rings_robot_xy, dtype=np.float64).reshape(-1, 2),
            rings_held=inputs.rings_held,
            goal_clamped=inputs.goal_clamped,
        )
        self.memory.observe(view)
        self._now = pose.t
        self._track_clamp(pose, inputs.goal_clamped)
        self._detector = inputs.goals_robot is not None
        if inputs.goals_robot is not None:
            self._see_goals(pose, inputs.alliance, inputs.goals_robot)
        self._forget_goals(pose)
        self._trail.push(pose.t, float(pose.xy[0]), float(pose.xy[1]))
        v, w, clamp = self._decide(pose, inputs, dt)
        v, w, let_go = self._tug(pose, inputs, v, w)
        self._check_dragging(pose, inputs)
        if let_go:
            clamp = False
        intake = self.phase not in (
            "climb", "stage", "balance", "drop", "sentry", "park", "steal", "haul", "haul_climb"
        )  # fmt: skip
        lift = bool(self.role.reaches_high_branch and inputs.goal_clamped and intake)
        return AllianceAction(float(v), float(w), clamp, lift, intake)

    def _tug(
        self, pose: Pose, inputs: AllianceInputs, v: float, w: float
    ) -> tuple[float, float, bool]:
        """A robot of the other alliance clamped the goal this one holds and drags it (the
        robot drives forward yet moves backward): pull away at full speed, straight, for a
        while (a tug of war goes to the stronger pull); the `tug_release`-th time with one goal,
        let it go instead (the third value: release the clamp)."""
        c = self.config
        endgame = self.phase in ("climb", "balance", "stage", "steal", "haul", "haul_climb")
        self._moves.append(Move(pose.t, float(pose.xy[0]), float(pose.xy[1]), pose.heading, v))
        while self._moves and self._moves[0].t < pose.t - c.tug_window_s:
            self._moves.pop(0)
        if not inputs.goal_clamped:
            self._tugs = 0
        if not inputs.goal_clamped or endgame:
            self._tug_until = -1.0
            return v, w, False
        if pose.t < self._tug_until:
            self.intent = "tug"
            return self.role.max_linear_mps, 0.0, False
        window = self._moved_ahead(pose, least_v=0.1)
        if window is not None and window[0] < -c.tug_distance_m:
            self._moves.clear()
            self._tugs += 1
            if c.tug_release and self._tugs >= c.tug_release:
                self._let_go(pose)
                return 0.0, 0.0, True
            self._tug_until = pose.t + c.tug_s
            self.intent = "tug"
            return self.role.max_linear_mps, 0.0, False
        return v, w, False

    def _check_dragging(self, pose: Pose, inputs: AllianceInputs) -> None:
        """The goal in the clamp comes slower than the robot drives (over the last
        `tug_window_s` of driving forward at half speed or more, less than half the way): another
        robot holds it too (`_contested`, until the clamp opens)."""
        if not inputs.goal_clamped:
            self._contested = False
            self._dragged_checked = False
            self._test_to = None
            return
        fast = 0.5 * self.role.max_linear_mps
        window = self._moved_ahead(pose, least_v=fast) if pose.t - self._clamped_at > 1.0 else None
        if window is not None:
            self._dragged_checked = True
            if window[0] < 0.5 * fast * window[1]:
                self._contested = True

    def _moved_ahead(self, pose: Pose, least_v: float) -> tuple[float, float] | None:
        """Over the last `tug_window_s` of commands (at least 90 % of it recorded), all of them
        forward at `least_v` or more: how far the robot moved along its heading (each step along
        the heading it had then: a robot that turned on the way ends behind where it began along
        its newest heading, yet moved ahead), and in how long. None: no such window."""
        m = self._moves
        if len(m) < 3 or m[-1].t - m[0].t < self.config.tug_window_s * 0.9:
            return None
        if not all(k.v >= least_v for k in m[:-1]):
            return None
        moved = 0.0
        for a, b in itertools.pairwise(m):
            h = math.radians(a.heading)
            moved += (b.x - a.x) * math.sin(h) + (b.y - a.y) * math.cos(h)
        return moved, m[-1].t - m[0].t

    def _let_go(self, pose: Pose) -> None:
        """Give up the goal held in a tug of war: it is not where this robot can score it (the
        other robot keeps it), so it is marked missing, and the next goal on the list is next."""
        if self.holding is not None:
            self.goals[self.holding].xy = None
            self._given_up.add(self.holding)
        self.holding = None
        self._tugs = 0
        self.intent = "let_go"
        if self.phase not in ("climb", "stage", "balance", "park"):
            self._set_phase("release", pose.t)

    # --- memories ----------------------------------------------------------------------------

    def _clamp_point(self, pose: Pose, goal: GoalLayout) -> Vec:
        h = math.radians(pose.heading)
        return pose.xy - self.role.clamp_offset(goal) * np.array([math.sin(h), math.cos(h)])

    def _track_clamp(self, pose: Pose, clamped: bool) -> None:
        if clamped and not self._was_clamped:
            self._clamped_at = pose.t
            # The goal now held: the one it was backing onto, else the believed one nearest
            # the clamp point.
            name = self.target_goal
            if name is None:
                best = math.inf
                for b in self.goals.values():
                    if b.xy is None:
                        continue
                    d = float(np.hypot(*(b.xy - self._clamp_point(pose, b.goal))))
                    if d < best:
                        name, best = b.goal.name, d
            self.holding = name
            if name is not None:
                self.goals[name].xy = None
        elif self._was_clamped and not clamped and self.holding is not None:
            belief = self.goals[self.holding]
            belief.xy = self._clamp_point(pose, belief.goal)
            self.holding = None
        self._was_clamped = clamped

    def _see_goals(self, pose: Pose, alliance: str, goals_robot: Vec) -> None:
        """Take the goal detector's sightings into the goal beliefs (see AllianceConfig)."""
        c = self.config
        seen = np.asarray(goals_robot, dtype=np.float64).reshape(-1, 3)
        now = pose.t
        self._opponent_goals = [(t, p) for t, p in self._opponent_goals if t > now - c.conflict_s]
        self._sightings = [(t, p) for t, p in self._sightings if t > now - 1.0]
        if not len(seen):
            return
        where = robot_to_field(seen[:, :2], pose.xy, pose.heading)  # the alliance frame
        self._sightings.extend((now, p.copy()) for p in where)
        own = GOAL_COLOUR_CODES[alliance]
        yellow = [
            p
            for p, k in zip(where, seen[:, 2].astype(int), strict=True)
            if k == GOAL_COLOUR_CODES["yellow"]
        ]
        self._tracker.observe(now, pose.heading, yellow)
        for xy, code in zip(where, seen[:, 2].astype(int), strict=True):
            if code == GOAL_COLOUR_CODES["yellow"]:
                owner: str | None = None
            elif code == own:
                owner = "own"
            else:
                self._opponent_goals.append((now, xy.copy()))
                owner = "opponent"
            best, best_d = None, c.sight_match_m
            revive = None
            for b in self.goals.values():
                name = b.goal.name
                if b.goal.owner != owner or name == self.holding or name in self._given_up:
                    continue
                if b.xy is None:
                    revive = revive or b
                    continue
                d = float(np.hypot(*(b.xy - xy)))
                if d < best_d:
                    best, best_d = b, d
            if best is None and revive is not None and revive.tries < c.goal_try_s:
                best = revive
            if best is None:
                continue
            name = best.goal.name
            last = self._goal_seen.get(name)
            if (
                last is not None
                and 0.3 <= now - last[0] <= 1.5
                and float(np.hypot(*(last[1] - xy))) / (now - last[0]) > c.carried_mps
            ):
                self._busy[name] = now + c.busy_s
            if last is None or now - last[0] >= 0.3:
                self._goal_seen[name] = (now, xy.copy())
            best.xy = xy.copy()

    def _forget_goals(self, pose: Pose) -> None:
        """A goal whose spot the robot's body now covers is not there (pushed away)."""
        half = min(self.role.length_m, self.role.width_m) / 2
        for b in self.goals.values():
            if b.xy is not None and float(np.hypot(*(b.xy - pose.xy))) < half:
                b.xy = None

    # --- the state machine -------------------------------------------------------------------

    def _time_left(self, pose: Pose) -> float:
        return self.layout.match_length_s - pose.t

    def _set_phase(self, phase: str, t: float) -> None:
        if phase != self.phase:
            self.phase = phase
            self.phase_since = t
            self._trail.clear()
            self._climbing = False
            if phase == "haul_climb":  # a held goal to its stage, then lined up there
                self._lined = False
                self._towing = True

    def _decide(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        c = self.config
        left = self._time_left(pose)
        big = self.role.role == "24in"
        # The endgame takes over from whatever the robot is doing.
        stealing = c.steal_s is not None
        climbing = not stealing or c.steal_climb
        if (
            big
            and stealing
            and c.steal_climb
            and left <= c.climb_24_s
            and self.phase in ("steal", "haul")
        ):
            held = inputs.goal_clamped and self._contested
            self._set_phase("haul_climb" if held else "climb", pose.t)
        elif big and stealing and left <= c.steal_s and self.phase not in (
            "steal", "haul", "haul_climb", "climb", "balance", "park"
        ):  # fmt: skip
            self._set_phase("steal", pose.t)
            self._given_up.clear()  # a goal let go in a tug of war is what the steal is for
            for b in self.goals.values():
                b.tries = 0.0
        elif (
            big
            and climbing
            and left <= c.climb_24_s
            and self.phase not in ("climb", "balance", "park", "haul_climb")
        ):
            self._set_phase("climb", pose.t)
        if not big:
            if not climbing and self.phase == "sentry":
                pass  # the 24" steals: the sentry keeps the board balanced where it is
            elif self.phase == "sentry" and self._climbing and left <= c.climb_15_s:
                self._set_phase("climb", pose.t)
                self._climbing = True  # already on the board, in its lane
                self._climb_track = []
            elif left <= c.stage_15_s and self.phase not in (
                "stage",
                "climb",
                "balance",
                "park",
                "sentry",
            ):
                self._set_phase("stage", pose.t)
            elif (
                not c.carry_goal_15
                and left <= c.drop_15_s
                and self.phase not in ("drop", "stage", "climb", "balance", "park")
            ):
                self._set_phase("drop", pose.t)
        if pose.t < self._backoff_until:
            self.intent = "backoff"
            return (
                self._backoff_dir * 0.5 * self.role.max_linear_mps,
                self._backoff_turn * 0.5 * self.role.max_angular_rad_s,
                bool(inputs.goal_clamped),
            )
        handler = getattr(self, "_phase_" + self.phase)
        return handler(pose, inputs, dt)

    # isolation: the alliance goal and the preloads ------------------------------------------

    def _phase_iso_goal(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        """Back onto the current isolation job's goal."""
        if self._iso_index >= len(self.plan.iso) or pose.t >= self.layout.isolation_s:
            self._next_goal(pose)
            return 0.0, 0.0, bool(inputs.goal_clamped)
        task = self.plan.iso[self._iso_index]
        if inputs.goal_clamped:
            self._held_at_clamp = inputs.rings_held
            self._set_phase("iso_score", pose.t)
            return self._phase_iso_score(pose, inputs, dt)
        self.target_goal = task.goal
        if not self._goal_available(task.goal):
            self._iso_index += 1
            return 0.0, 0.0, False
        self.intent = f"iso_goal:{task.goal}"
        return self._get_goal(task.goal, pose, inputs, dt, wait_until=None)

    def _phase_iso_score(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        """Thread the job's preloads onto the goal (dragging it where the job says), then let
        go of it or keep it."""
        c = self.config
        task = self.plan.iso[self._iso_index]
        self.intent = "iso_score"
        if not inputs.goal_clamped:
            self._iso_index += 1
            self._set_phase("iso_goal", pose.t)
            return 0.0, 0.0, False
        arrived = True
        v = w = 0.0
        if task.drag_to is not None:
            target = np.array(task.drag_to)
            if float(np.hypot(*(target - pose.xy))) > 0.1:
                arrived = False
                v, w = self._drive_to(pose, target, None, speed=0.5)
        want = 0 if task.rings is None else max(0, self._held_at_clamp - task.rings)
        done = arrived and (inputs.rings_held <= want or (task.keep and not task.wait))
        if done or pose.t - self.phase_since > c.preload_wait_s + 3.0:
            self._iso_index += 1
            if task.keep:
                self._next_goal(pose)
                return 0.0, 0.0, True
            self._set_phase("release", pose.t)
            return 0.0, 0.0, False
        return v, w, True

    def _phase_release(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        """Open the clamp and drive forward, away from the goal just let go."""
        self.intent = "release"
        if pose.t - self.phase_since < 0.6:
            return 0.4 * self.role.max_linear_mps, 0.0, False
        if pose.t < self.layout.isolation_s and self._iso_index < len(self.plan.iso):
            self._set_phase("iso_goal", pose.t)
        else:
            self._next_goal(pose)
        return 0.0, 0.0, False

    def _phase_sentry(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        """Wait on the platform's field side with the goal it holds: the board stays tipped
        toward the field (the ramp down) whatever the other robots push onto it, so the
        alliance can still climb it at the end."""
        c = self.config
        plat = self.layout.platform
        clamp = bool(inputs.goal_clamped)
        y = c.board_y_15_m
        if self._climbing and self._off_lane(pose, y):
            self._climbing = self._sentry_set = False  # pushed out of its lane: line up again
        if not self._climbing:
            stage = np.array([self._board_x(c.sentry_stage_along_m), y])
            heading_err = angle_diff_deg(plat.wall_heading_deg, pose.heading)
            if float(np.hypot(*(stage - pose.xy))) > 0.07:
                self.intent = "to_sentry"
                return (*self._arrive(pose, stage, plat.wall_heading_deg), clamp)
            if abs(heading_err) > 5:
                self.intent = "line_up"
                return 0.0, self._turn_to(pose, plat.wall_heading_deg), clamp
            self._climbing = True
        self.intent = "sentry"
        along = plat.along(float(pose.xy[0]))
        want = c.sentry_along_m
        if c.lock_along_m is not None and (
            self._time_left(pose) > c.unlock_s or (c.steal_s is not None and not c.steal_climb)
        ):
            want = c.lock_along_m
            self.intent = "lock"
        if abs(along - want) < 0.03:
            self._sentry_set = True
        if self._sentry_set and pose.t < self.layout.isolation_s:
            return 0.0, 0.0, clamp  # in place: never drive while the other alliance may be near
        return (*self._on_board(pose, y, want), clamp)

    def _next_goal(self, pose: Pose) -> None:
        if (
            self.config.iso_rings
            and pose.t < self.layout.isolation_s - self.config.iso_rings_until_s
        ):
            self._set_phase("iso_rings", pose.t)
            return
        if pose.t < self.layout.isolation_s and not self.plan.sentry:
            self._set_phase("iso_wait", pose.t)
            return
        self._next_goal_interaction(pose)

    def _phase_iso_rings(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        """The rest of the isolation period: rings on its own side, deep enough that the
        other alliance's robots are unlikely there; they go onto the neutral goal later."""
        c = self.config
        full = self.role.ring_capacity is not None and inputs.rings_held >= self.role.ring_capacity
        if full or pose.t >= self.layout.isolation_s - c.iso_rings_until_s:
            self._ring_target = None
            self._next_goal_interaction(pose)
            return 0.0, 0.0, False
        target = self._choose_ring(pose, x_max=c.iso_ring_x_max_m, only_mine=True)
        if target is None:
            self._next_goal_interaction(pose)
            return 0.0, 0.0, False
        self.intent = "iso_ring"
        v, w = self._drive_to(pose, target, None, speed=c.speed, ring=True)
        return v, w, False

    def _phase_iso_wait(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        """The rest of the isolation period: stand in front of the platform, in its climbing
        lane, facing the wall (a goal pushed toward the board meets the robot instead, and a
        robot standing still cannot make contact with another)."""
        c = self.config
        clamp = bool(inputs.goal_clamped)
        if pose.t >= self.layout.isolation_s:
            self._next_goal_interaction(pose)
            return 0.0, 0.0, clamp
        plat = self.layout.platform
        big = self.role.role == "24in"
        along = plat.size[0] / 2 + self.role.length_m / 2 + c.guard_gap_m
        guard = np.array([plat.x_at(along), c.board_y_24_m if big else c.board_y_15_m + 0.05])
        if c.guard and not self._guarding and float(np.hypot(*(guard - pose.xy))) > 0.08:
            self.intent = "to_guard"
            return (*self._drive_to(pose, guard, None, speed=0.6), clamp)
        self._guarding = True
        self.intent = "iso_wait"
        if not c.guard:
            return 0.0, 0.0, clamp
        return 0.0, self._turn_to(pose, plat.wall_heading_deg), clamp

    def _goal_available(self, name: str, raid: bool = False) -> bool:
        """A goal worth going for: believed somewhere, not tried too long, not seen carried,
        not deep in the other alliance's half (unless `raid`), and not on or by either platform
        (backing onto it there would climb the board)."""
        b = self.goals[name]
        if b.xy is None or b.tries >= self.config.goal_try_s:
            return False
        if self._busy.get(name, -1.0) > self._now:
            return False
        if not raid and float(b.xy[0]) > self.config.goal_x_max_m:
            return False
        if b.goal.owner != "opponent":
            for _, p in self._opponent_goals:
                if float(np.hypot(*(p - b.xy))) < self.config.conflict_m:
                    b.xy = None  # a goal of the other alliance stands there
                    return False
        half_diag = math.hypot(self.role.length_m, self.role.width_m) / 2
        x, y = float(b.xy[0]), float(b.xy[1])
        plat = self.layout.platform
        # The other alliance's platform is this one's half-turn mirror; the raid takes goals
        # beside it too (not on it): its stage keeps the robot off the board (_stage_for).
        far = b.goal.base_radius_m + 0.05 if raid else half_diag
        return not plat.either_contains((x, y), half_diag, far)

    def _raiding(self, pose: Pose) -> bool:
        """The raid is on (see AllianceConfig.raid): the 24", a goal detector, its first goal
        left in the home zone, more than `deposit_until_s` left."""
        c = self.config
        return bool(
            c.raid
            and self._detector
            and self.role.role == "24in"
            and self._deposited
            and self._time_left(pose) > c.deposit_until_s
        )

    def _raid_goal(self, pose: Pose) -> str | None:
        """The raid's next goal (see AllianceConfig.raid): a free goal outside the home zone,
        the nearest, one in the other alliance's home zone first within `raid_prefer_m`. Only
        the 24" raids, only with a goal detector (it finds the goals the others moved), and
        only while more than `deposit_until_s` are left (_raiding)."""
        c = self.config
        if not self._raiding(pose):
            return None
        line = self.layout.home_zone[2]  # the home zone's edge toward the field
        best, best_cost = None, math.inf
        for name, b in self.goals.items():
            if name == self.holding or name in self._given_up:
                continue
            if not self._goal_available(name, raid=True):
                continue
            assert b.xy is not None
            x = float(b.xy[0])
            r = b.goal.base_radius_m
            if x < line + r - 0.03:
                continue  # scored in the home zone already
            theirs = x > -line - r + 0.03  # scored in the other alliance's home zone
            cost = float(np.hypot(*(b.xy - pose.xy))) - (c.raid_prefer_m if theirs else 0.0)
            if cost < best_cost:
                best, best_cost = name, cost
        return best

    def _interaction_goal(self, pose: Pose) -> str | None:
        """The next goal to take: the first available on the list that it has not left in its
        home zone (after the first it left, the raid's: _raid_goal); with none, from
        `refetch_s` before the end, the nearest one it left there (to climb with)."""
        if self._deposited and self.config.raid and self._detector:
            raid = self._raid_goal(pose)
            if raid is not None or self._time_left(pose) > self.config.refetch_s:
                return raid
        else:
            for name in self.plan.neutral:
                if name not in self._deposited and self._goal_available(name):
                    return name
        if self._time_left(pose) <= self.config.refetch_s:
            left = [n for n in self._deposited if self._goal_available(n)]
            if left:
                return min(left, key=lambda n: float(np.hypot(*(self.goals[n].xy - pose.xy))))
        return None

    def _next_goal_interaction(self, pose: Pose) -> None:
        if self.plan.sentry:
            self._set_phase("sentry", pose.t)
            return
        if self._was_clamped:
            self.target_goal = None
            self._set_phase("collect", pose.t)
            return
        name = self._interaction_goal(pose)
        if name is not None:
            self.target_goal = name
            self._set_phase("get_goal", pose.t)
            return
        self.target_goal = None
        self._set_phase("collect", pose.t)

    # interaction: a goal to score on, rings onto it ---------------------------------------------

    def _phase_get_goal(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        if inputs.goal_clamped:
            self.target_goal = None
            self._set_phase("collect", pose.t)
            return self._phase_collect(pose, inputs, dt)
        name = self.target_goal
        if name is None or not self._goal_available(name, raid=self._raiding(pose)):
            self._next_goal(pose)
            return 0.0, 0.0, True
        self.intent = f"goal:{name}"
        wait = self.layout.isolation_s - self.config.isolation_margin_s
        return self._get_goal(name, pose, inputs, dt, wait_until=wait)

    def _stage_for(self, goal: Vec, pose: Pose) -> Vec:
        """Where to stand before backing onto a goal: on the own side of one near the centre
        line (never toward the other alliance), else the free spot around it (inside the walls,
        off the platform) nearest the robot, far enough to turn there without sweeping it."""
        c = self.config
        stealing = self.phase == "steal"
        if abs(float(goal[0])) < 0.6 and not stealing:
            return goal + np.array([-c.goal_stage_m, 0.0])
        half_diag = math.hypot(self.role.length_m, self.role.width_m) / 2
        limit = self.layout.half_m - half_diag - 0.03
        best, best_d = goal + np.array([-c.goal_stage_m, 0.0]), math.inf
        now = float(np.hypot(*(pose.xy - goal)))
        # The way there must not sweep the goal away (the robot turns in place first).
        need = min(half_diag + 0.17, now) - 0.03
        body = max(self.role.length_m, self.role.width_m) / 2 + 0.02
        for k in range(32):
            a = 2 * math.pi * (k % 16) / 16
            reach = c.goal_stage_m if k < 16 else half_diag + 0.22
            p = goal + reach * np.array([math.cos(a), math.sin(a)])
            if abs(float(p[0])) > limit or abs(float(p[1])) > limit:
                continue
            if self._near_a_platform(p, body) or self._clamped_touches_platform(goal, p):
                continue
            d = float(np.hypot(*(p - pose.xy)))
            if _segment_distance(goal, pose.xy, p) < need:
                d += 5.0
            if stealing and any(float(np.hypot(*(p - q))) < 0.35 for q in self._bad_stages):
                d += 10.0  # blocked there before (the robot that holds the goal stands there)
            if d < best_d:
                best, best_d = p, d
        return best

    def _near_a_platform(self, p: Vec, margin: float) -> bool:
        """A point within `margin` of either platform (the other is this one's mirror)."""
        return self.layout.platform.either_contains((float(p[0]), float(p[1])), margin)

    def _clamped_touches_platform(self, goal: Vec, stage: Vec, margin: float = 0.05) -> bool:
        """Backing from `stage` onto `goal` would end with the robot's body on (or within
        `margin` of) a platform: its footprint where the clamp closes, sampled along its
        edges."""
        d = stage - goal
        n = float(np.hypot(*d))
        if n < 1e-9:
            return False
        u = d / n  # from the goal toward the robot's centre (its back faces the goal)
        side = np.array([-u[1], u[0]])
        centre = goal + self.role.clamp_offset(self._widest) * u
        hl, hw = self.role.length_m / 2, self.role.width_m / 2
        for a in np.linspace(-1.0, 1.0, 5):
            for b in np.linspace(-1.0, 1.0, 5):
                if abs(a) < 1.0 and abs(b) < 1.0:
                    continue  # the edges only
                if self._near_a_platform(centre + a * hl * u + b * hw * side, margin):
                    return True
        return False

    def _get_goal(
        self,
        name: str,
        pose: Pose,
        inputs: AllianceInputs,
        dt: float,
        wait_until: float | None,
    ) -> tuple[float, float, bool | None]:
        """Drive to the stage in front of a goal, wait there until `wait_until` if the goal
        lies near the other alliance, then back onto it."""
        c = self.config
        belief = self.goals[name]
        assert belief.xy is not None
        goal = belief.xy
        dist = float(np.hypot(*(pose.xy - goal)))
        if self._stage_goal != name:
            self._stage_goal = name
            self._stage_since = pose.t
            self._staged = False
            self._confirmed = None
            self._look_since = None
        since = max(self._stage_since, self.layout.isolation_s)
        if pose.t - since > c.goal_chase_s:
            # This long after one goal in the interaction period (a corner, a crowd): leave it
            # for a while and take the next.
            self._busy[name] = pose.t + c.busy_s
            self._chased[name] = pose.t + c.busy_s
            self._stage_goal = None
            return 0.0, 0.0, False
        stage = self._stage_for(goal, pose)
        self._stage_xy = stage
        local = field_to_robot(goal[None, :], pose.xy, pose.heading)[0]
        behind = abs(math.atan2(-float(local[0]), -float(local[1]))) < math.radians(30)
        waiting = wait_until is not None and pose.t < wait_until
        aligned = behind and dist < c.goal_stage_m + 0.3
        if waiting or not (self._staged or aligned):
            if waiting and self._staged:
                # Waiting out the isolation period: turn in place only, never drive.
                self.intent = "wait"
                face = float(np.degrees(np.arctan2(-(goal - pose.xy)[0], -(goal - pose.xy)[1])))
                return 0.0, self._turn_to(pose, face), False
            if float(np.hypot(*(pose.xy - stage))) > 0.1:
                self.intent = "to_stage"
                v, w = self._drive_to(pose, stage, None, speed=c.speed)
                return v, w, False
            self._staged = True
        look = self._look(name, pose, goal)
        if look is not None:
            return look
        belief.tries += dt
        if belief.tries > c.goal_try_s:
            belief.xy = None  # not where it was believed to be
            self._staged = False
            return 0.0, 0.0, False
        self.intent = f"back_onto:{name}"
        v, w = self._back_onto(float(local[0]), float(local[1]), dist)
        if dist < c.goal_stage_m - 0.25 and not behind and abs(v) < 0.05:
            # Turned away from it up close (pushed, or the goal moved): stage again.
            self._staged = False
        if self._trail.stuck(pose.t, abs(v)):
            self._trail.clear()
            self._backoff_until = pose.t + c.backoff_s / 2
            self._backoff_turn = 0.0
            self._backoff_dir = 1.0  # forward, clear of whatever blocks the reverse
            self._staged = False
            return 0.5 * self.role.max_linear_mps, 0.0, True
        return v, w, True

    def _look(self, name: str, pose: Pose, goal: Vec) -> tuple[float, float, bool | None] | None:
        """Before backing onto a goal in the interaction period (with a goal detector): unless
        it was seen where it is believed in the last confirm_s, face it and look; a goal not
        seen within look_s is marked missing. None: go ahead (confirmed, or no check)."""
        c = self.config
        if (
            c.confirm_s is None
            or not self._detector
            or pose.t < self.layout.isolation_s
            or self._confirmed == name
        ):
            return None
        belief = self.goals[name]
        seen = self._goal_seen.get(name)
        if (
            seen is not None
            and pose.t - seen[0] <= c.confirm_s
            and float(np.hypot(*(seen[1] - goal))) < 0.3
        ):
            self._confirmed = name
            self._look_since = None
            return None
        if self._look_since is None:
            self._look_since = pose.t
            self._staged = True  # look from here, no new stage
        if pose.t - self._look_since > c.look_s:
            self._tracker.lost(goal)  # a carried goal followed there has gone too
            belief.xy = None  # not seen where it should stand
            self._staged = False
            self._look_since = None
            return 0.0, 0.0, False
        self.intent = f"look:{name}"
        d = goal - pose.xy
        face = float(heading_of(d))
        v = 0.0
        if float(np.hypot(*d)) < c.look_from_m and abs(angle_diff_deg(face, pose.heading)) < 30:
            v = -0.3 * self.role.max_linear_mps  # too near to see it: back away, facing it
        return v, self._turn_to(pose, face), False

    def _back_onto(self, gx: float, gy: float, dist: float) -> tuple[float, float]:
        """(v, w) that turns the back to a goal (robot frame) and reverses onto it: slowly and
        only while lined up in the last stretch, where the clamp needs the goal within its
        width (a goal met off-centre is pushed away instead)."""
        rc = self.role
        back = math.atan2(-gx, -gy)  # bearing seen from the back: positive turns clockwise
        w = float(
            np.clip(self.config.turn_gain * back, -rc.max_angular_rad_s, rc.max_angular_rad_s)
        )
        across = abs(gx)
        gap = dist - rc.length_m / 2
        if gap < 0.45:
            ok = max(0.0, 1.0 - across / 0.06) if abs(back) < math.radians(25) else 0.0
            return -0.35 * rc.max_linear_mps * ok, w
        _, w2 = back_onto(gx, gy, rc.max_linear_mps, rc.max_angular_rad_s, self.config.turn_gain)
        return -0.7 * rc.max_linear_mps * max(0.0, math.cos(back)) ** 6, w2

    def _phase_collect(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        c = self.config
        if not inputs.goal_clamped and pose.t - self.phase_since > 0.5:
            # Lost it (a tug of war) or never had one: look for the next.
            name = self._interaction_goal(pose)
            if name is not None:
                self.target_goal = name
                self._set_phase("get_goal", pose.t)
                return 0.0, 0.0, False
        target = self._choose_ring(pose)
        keep = bool(inputs.goal_clamped)
        if target is None:
            if self._no_ring_since is None:
                self._no_ring_since = pose.t
            if (
                c.deposit_after_s is not None
                and self.role.role == "24in"
                and keep
                and self.holding is not None
                and len(self._deposited) < len(c.deposit_spots)
                and pose.t - self._no_ring_since >= c.deposit_after_s
                and self._time_left(pose) > c.deposit_until_s
                and (inputs.rings_held == 0 or pose.t - self._clamped_at > c.preload_wait_s + 3)
            ):
                self._set_phase("deposit", pose.t)
                return self._phase_deposit(pose, inputs, dt)
            self.intent = "search"
            return (*self._search(pose), keep)
        self._no_ring_since = None
        self.intent = "ring"
        v, w = self._drive_to(pose, target, None, speed=c.speed, ring=True)
        return v, w, keep

    def _phase_deposit(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        """Leave the goal it holds deep in the home zone, beside the platform (its rings count
        there, and it scores 20), then drive off and take the next goal."""
        c = self.config
        plat = self.layout.platform
        along, y = c.deposit_spots[min(len(self._deposited), len(c.deposit_spots) - 1)]
        spot = np.array([plat.x_at(along), plat.center[1] + y])
        if inputs.goal_clamped:
            if float(np.hypot(*(spot - pose.xy))) > 0.12:
                self.intent = "to_deposit"
                return (*self._drive_to(pose, spot, None, speed=0.8), True)
            if self.holding is not None and self.holding not in self._deposited:
                self._deposited.append(self.holding)
            self.intent = "deposit"
            self.phase_since = pose.t
            return 0.0, 0.0, False
        self.intent = "deposit"
        if pose.t - self.phase_since < 0.6:
            return 0.4 * self.role.max_linear_mps, 0.0, False
        self._no_ring_since = None
        self._next_goal_interaction(pose)
        return 0.0, 0.0, False

    def _search(self, pose: Pose) -> tuple[float, float]:
        """No ring known in its half: sweep its half's waypoints so the camera finds some."""
        side = -1.0 if self.role.role == "24in" else 1.0
        points = [(-0.3, 0.45 * side), (0.1, 1.2 * side), (-0.8, 1.4 * side), (-0.45, 0.9 * side)]
        k = int(pose.t // 4.0) % len(points)
        return self._drive_to(pose, np.array(points[k]), None, speed=0.7)

    def _choose_ring(
        self, pose: Pose, x_max: float | None = None, only_mine: bool = False
    ) -> Vec | None:
        c = self.config
        known = self.memory.known
        if not len(known):
            return None
        now = pose.t
        self._ignored = [(p, u) for p, u in self._ignored if u > now]
        x_lim = c.ring_x_max_m if x_max is None else x_max
        if self._time_left(pose) < self.layout.endgame_s + 3.0:
            # The platforms are protected: stay well clear of the other alliance's.
            x_lim = min(x_lim, c.endgame_x_max_m)
        ok = known[:, 0] <= x_lim
        if self.role.role == "24in":
            mine = known[:, 1] < c.ring_half_split_m
        else:
            mine = known[:, 1] >= c.ring_half_split_m
        plat = self.layout.platform
        near_board = (
            np.abs(known[:, 0] - plat.center[0]) < plat.size[0] / 2 + c.platform_keepout_m
        ) & (np.abs(known[:, 1] - plat.center[1]) < plat.size[1] / 2 + c.platform_keepout_m)
        half = self.layout.half_m - 0.06
        inside = (np.abs(known[:, 0]) < half) & (np.abs(known[:, 1]) < half)
        ok &= ~near_board & inside
        for p, _ in self._ignored:
            ok &= np.hypot(*(known - p).T) > 0.1
        cand = known[ok & mine]
        if not len(cand) and not only_mine:
            cand = known[ok]
        if not len(cand):
            return None
        local = field_to_robot(cand, pose.xy, pose.heading)
        dist = np.hypot(local[:, 0], local[:, 1])
        turn = np.abs(np.arctan2(local[:, 0], local[:, 1]))
        cost = dist + c.turn_cost_m_per_rad * turn
        best = int(np.argmin(cost))
        if self._ring_target is not None:
            d = np.hypot(*(cand - self._ring_target).T)
            k = int(np.argmin(d))
            if d[k] < 0.12 and cost[k] <= cost[best] + c.switch_margin_m:
                best = k
        target = cand[best]
        if self._ring_target is None or float(np.hypot(*(target - self._ring_target))) > 0.12:
            self._ring_since = now
        self._ring_target = target.copy()
        if now - self._ring_since > c.give_up_ring_s:
            self._ignored.append((target.copy(), now + c.give_up_ring_s))
            self._ring_target = None
        return target

    # the endgame -------------------------------------------------------------------------------

    def _board_x(self, along: float) -> float:
        return self.layout.platform.x_at(along)

    def _phase_drop(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        """The 15": leave the goal it carries deep in the home zone, clear of the platform."""
        self.intent = "drop"
        if not inputs.goal_clamped:
            if pose.t - self.phase_since < 0.6 and self.holding is None:
                return 0.3 * self.role.max_linear_mps, 0.0, False
            return (*self._search_home(pose), False)
        plat = self.layout.platform
        target = np.array([plat.x_at(0.17), plat.center[1] + 1.45])
        if float(np.hypot(*(target - pose.xy))) > 0.15:
            v, w = self._drive_to(pose, target, None, speed=0.8)
            return v, w, True
        self.phase_since = pose.t
        return 0.0, 0.0, False

    def _search_home(self, pose: Pose) -> tuple[float, float]:
        """Until the stage time: rings near the home zone, on its own half."""
        target = self._choose_ring(pose)
        if target is None or target[0] > -0.1:
            return 0.0, 0.0
        return self._drive_to(pose, target, None, speed=0.7, ring=True)

    def _phase_stage(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        """The 15": wait in front of the board, facing the wall, until the 24" holds its edge
        down; then climb."""
        c = self.config
        self.intent = "stage"
        stage = np.array([self._board_x(c.stage_along_m), c.board_y_15_m])
        if self._time_left(pose) <= c.climb_15_s:
            self._set_phase("climb", pose.t)
            return self._phase_climb(pose, inputs, dt)
        clamp = bool(inputs.goal_clamped)
        return (*self._arrive(pose, stage, self.layout.platform.wall_heading_deg), clamp)

    def _phase_climb(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        c = self.config
        plat = self.layout.platform
        big = self.role.role == "24in"
        clamp: bool | None = bool(inputs.goal_clamped)
        y = c.board_y_24_m if big else c.board_y_15_m
        if (
            not big
            and self._climbing
            and self._off_lane(pose, y)
            and self._time_left(pose) > c.blocked_s + 4.0
        ):
            self._climbing = False  # pushed out of its lane: to the stage, line up again
        if (
            big
            and inputs.goal_clamped
            and not self._climbing
            and c.steal_s is not None
            and c.steal_climb
            and (self._contested or self._dragged_back(pose))
        ):
            # Another robot holds the goal too (the steal's test told only after the climb
            # began, or it drags the robot backward on its way to the stage): the slow approach
            # and turning in place hand the goal over, so the tow takes it to the stage.
            self._contested = True
            self._set_phase("haul_climb", pose.t)
            return self._phase_haul_climb(pose, inputs, dt)
        if big and not self._climbing and not inputs.goal_clamped:
            cleared = self._clear_lane(pose, y)
            if cleared is not None:
                return cleared
        if big and not self._climbing and inputs.goal_clamped and self._clear_backing:
            # The goal taken off the board: straight out toward the field first, far enough
            # to turn with it (it swings behind the robot) without meeting the board.
            field_heading = (plat.wall_heading_deg + 180.0) % 360.0
            if plat.along(float(pose.xy[0])) < c.stage_along_m + 0.3:
                self.intent = "pull_out"
                return 0.5 * self.role.max_linear_mps, self._turn_to(pose, field_heading), True
            self._clear_backing = False
        if not self._climbing:
            # Line up first: at the stage in its lane, facing the wall.
            stage = np.array([self._board_x(c.stage_along_m), y])
            heading_err = angle_diff_deg(plat.wall_heading_deg, pose.heading)
            at_stage = float(np.hypot(*(stage - pose.xy))) <= 0.07
            if not at_stage:
                self.intent = "to_stage"
                return (*self._arrive(pose, stage, plat.wall_heading_deg), clamp)
            if abs(heading_err) > 5:
                self.intent = "line_up"
                return 0.0, self._turn_to(pose, plat.wall_heading_deg), clamp
            if big and c.lock_along_m is not None and self._time_left(pose) > c.climb_after_s:
                self.intent = "wait_unlock"  # the sentry holds the board level until then
                return 0.0, 0.0, clamp
            self._climbing = True
            self._climb_track = []
        along_now = plat.along(float(pose.xy[0]))
        self._climb_track.append((pose.t, along_now))
        self._climb_track = [k for k in self._climb_track if k[0] >= pose.t - c.blocked_s]
        edge = plat.size[0] / 2 + self.role.length_m / 2
        first = self._climb_track[0]
        if (
            pose.t - first[0] >= c.blocked_s * 0.95
            and along_now > edge - 0.05
            and first[1] - along_now < 0.03
        ):
            # The board's field edge is up (something on the board tips it the other way), or
            # something stands in the way: line up again once, then give the climb up and keep
            # the goal in the home zone instead.
            if not self._climb_retried and self._time_left(pose) > c.settle_s + 4.0:
                self._climb_retried = True
                self._climbing = False
                self.intent = "retry"
                return -0.5 * c.board_speed_mps, 0.0, clamp
            self._set_phase("park", pose.t)
            return self._phase_park(pose, inputs, dt)
        self.intent = "climb"
        goal_along = c.hold_along_m if big else c.partner_along_m
        if big and self._time_left(pose) <= c.settle_s:
            goal_along = self._balance_along(inputs)
            self.phase = "balance"
        return (*self._on_board(pose, y, goal_along), clamp)

    def _lane_goal(self, y: float) -> Vec | None:
        """Where a goal seen in the last second stands on the board's wall half in the lane at
        `y` (the sentry's own goal trails it on the field half)."""
        plat = self.layout.platform
        r = self._widest.base_radius_m
        for _, xy in self._sightings:
            on_board = plat.contains((float(xy[0]), float(xy[1])), margin=0.05)
            wall_half = plat.along(float(xy[0])) < 0.05
            if on_board and wall_half and abs(float(xy[1]) - y) < self.role.width_m / 2 + r:
                return xy
        return None

    def _clear_lane(self, pose: Pose, y: float) -> tuple[float, float, bool | None] | None:
        """The 24" before its climb, its clamp empty: a goal on the board in its lane is taken
        (stand at the stage facing the field, back up the lane onto it) for at most
        `clear_lane_s`, and then carried up (see AllianceConfig.clear_lane_s). None: nothing
        to clear (or no time left for it)."""
        c = self.config
        seen = self._lane_goal(y)
        if seen is not None:
            self._lane_goal_xy = seen
        if self._lane_goal_xy is None or self._time_left(pose) < c.settle_s + 6:
            return None
        if self._clear_since is not None and pose.t - self._clear_since > c.clear_lane_s:
            return None
        plat = self.layout.platform
        stage = np.array([self._board_x(c.stage_along_m), y])
        field_heading = (plat.wall_heading_deg + 180.0) % 360.0
        if not self._clear_backing:
            if float(np.hypot(*(stage - pose.xy))) > 0.07:
                self.intent = "to_stage"
                return (*self._arrive(pose, stage, field_heading), False)
            if abs(angle_diff_deg(field_heading, pose.heading)) > 5:
                self.intent = "line_up"
                return 0.0, self._turn_to(pose, field_heading), False
            if c.lock_along_m is not None and self._time_left(pose) > c.unlock_s - 0.5:
                # The sentry holds the board level (its field edge too high to back onto)
                # until it unlocks.
                self.intent = "wait_unlock"
                return 0.0, 0.0, False
            self._clear_backing = True
            self._clear_since = pose.t
        self.intent = "clear_lane"
        goal = self._lane_goal_xy
        local = field_to_robot(goal[None, :], pose.xy, pose.heading)[0]
        dist = float(np.hypot(*(goal - pose.xy)))
        v, w = self._back_onto(float(local[0]), float(local[1]), dist)
        return v, w, True

    def _against_wall(self, along: float) -> bool:
        """At `along` from the hinge the robot's front is (within 3 cm) against the wall."""
        return along < self.role.length_m / 2 - self.layout.platform.size[0] / 2 + 0.03

    def _off_lane(self, pose: Pose, y: float) -> bool:
        """Pushed out of the lane at `y` (more than `off_lane_m` along the wall)."""
        return abs(float(pose.xy[1]) - y) > self.config.off_lane_m

    def _dragged_back(self, pose: Pose) -> bool:
        """Over the last `tug_window_s` of commands (none of them backward), the robot moved
        backward more than `tug_distance_m`: another robot drags the goal in its clamp."""
        window = self._moved_ahead(pose, least_v=0.0)
        return (
            window is not None
            and self._moves[-1].v >= 0.0
            and window[0] < -self.config.tug_distance_m
        )

    def _phase_park(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        """The climb is blocked: end the match with the goal it carries deep in the home zone,
        beside the platform (not in front of it)."""
        self.intent = "park"
        c = self.config
        plat = self.layout.platform
        big = self.role.role == "24in"
        side = -1.0 if big else 1.0
        target = np.array([plat.x_at(c.park_along_m), plat.center[1] + side * c.park_y_m])
        clamp = bool(inputs.goal_clamped)
        if float(np.hypot(*(target - pose.xy))) > 0.1:
            return (*self._drive_to(pose, target, None, speed=0.7), clamp)
        return 0.0, 0.0, clamp

    def _phase_hold(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        return self._phase_climb(pose, inputs, dt)

    def _phase_balance(
        self, pose: Pose, inputs: AllianceInputs, dt: float
    ) -> tuple[float, float, bool | None]:
        c = self.config
        self.intent = "balance"
        big = self.role.role == "24in"
        y = c.board_y_24_m if big else c.board_y_15_m
        along = self._balance_along(inputs) if big else c.partner_along_m
        clamp: bool | None = bool(inputs.goal_clamped)
        return (*self._on_board(pose, y, along), clamp)

    def _balance_along(self, inputs: AllianceInputs) -> float:
        """Where the 24" stands (from the hinge, toward the field) for the board's torques to
        cancel: its own, the goal it carries (behind it, toward the field, on the board's edge
        at most) and the 15"'s at partner_along_m."""
        c = self.config
        plat = self.layout.platform
        torque = self.role.partner_mass_kg * c.partner_along_m
        half = plat.size[0] / 2
        if inputs.goal_clamped and self.holding is not None:
            g = self.goals[self.holding].goal
            torque += g.mass_kg * min(self.role.clamp_offset(g), half)
        if c.carry_goal_15:
            # The goal the 15" plans to climb with, behind it toward the field.
            kept = [t.goal for t in default_plan("15in", self.layout).iso if t.keep]
            g = self.layout.goal(kept[-1] if kept else self.layout.awp_goal)
            torque += g.mass_kg * min(c.partner_along_m + 0.36, half)
        # Its whole footprint must stay over the board (with the overhang) to be Elevated.
        reach = max(0.0, half + plat.overhang_m - self.role.length_m / 2 - c.footprint_margin_m)
        return float(np.clip(-torque / self.role.mass_kg, -reach, reach))

    def _on_board(
        self, pose: Pose, y: float, along: float, speed: float | None = None
    ) -> tuple[float, float]:
        """Drive straight toward the wall (or back) to `along` from the hinge, heading held, at
        `speed` at most (None: the board's speed)."""
        c = self.config
        plat = self.layout.platform
        off_lane = (float(pose.xy[1]) - y) * plat.field_side
        err = plat.along(float(pose.xy[0])) - along  # > 0: still toward the field: forward
        top = c.board_speed_mps if speed is None else speed
        v = float(np.clip(2.0 * err, -top, top))
        if abs(err) < 0.015:
            v = 0.0
        # Hold the heading toward the wall, leaning a little toward the lane's y while moving
        # (> 0: the lane lies to the robot's left, a counter-clockwise turn when driving forward).
        lean = float(np.clip(60.0 * off_lane, -15.0, 15.0)) if v != 0.0 else 0.0
        want = plat.wall_heading_deg - lean * (1.0 if v >= 0 else -1.0)
        heading_err = angle_diff_deg(want, pose.heading)
        w = float(np.clip(3.0 * math.radians(heading_err), -1.5, 1.5))
        if v == 0.0 and abs(heading_err) < c.board_heading_tolerance_deg:
            w = 0.0  # turning in place on a tilted board slides the robot sideways
        return v, w

    # driving ----------------------------------------------------------------------------------

    def _turn_to(self, pose: Pose, heading: float) -> float:
        err = math.radians(angle_diff_deg(heading, pose.heading))
        if abs(err) < math.radians(2):
            return 0.0
        return float(
            np.clip(
                self.config.turn_gain * err,
                -self.role.max_angular_rad_s,
                self.role.max_angular_rad_s,
            )
        )

    def _arrive(self, pose: Pose, point: Vec, heading: float) -> tuple[float, float]:
        """Drive to a point, then turn to a heading there."""
        if float(np.hypot(*(point - pose.xy))) > 0.05:
            return self._drive_to(pose, point, None, speed=0.8)
        return 0.0, self._turn_to(pose, heading)

    def _drive_to(
        self,
        pose: Pose,
        target: Vec,
        after: Vec | None,
        speed: float,
        ring: bool = False,
    ) -> tuple[float, float]:
        c = self.config
        rc = self.role
        path = [target] if after is None else [target, after]
        local = field_to_robot(np.array(path), pose.xy, pose.heading)
        tx, ty = float(local[0, 0]), float(local[0, 1])
        dist = math.hypot(tx, ty)
        turn = turn_first(
            tx, ty, rc.max_linear_mps, rc.max_angular_rad_s, c.turn_gain, c.turn_in_place_rad,
            rc.length_m if ring else 0.0,
        )  # fmt: skip
        if turn is not None:
            return turn
        px, py = pursuit_point(local, c.lookahead_m)
        v_max = speed * rc.max_linear_mps
        if not ring:
            v_max = min(v_max, max(0.15, 1.5 * dist))  # slow down to stop at a point
        v, w = arc_through(px, py, v_max, rc.max_angular_rad_s)
        if self._trail.stuck(pose.t, v):
            if self.phase == "steal" and self._stage_xy is not None:
                self._bad_stages.append(self._stage_xy.copy())
            self._trail.clear()
            self._backoff_until = pose.t + c.backoff_s
            self._backoff_turn = -1.0 if tx > 0 else 1.0
            self._backoff_dir = -1.0
            if ring:
                self._ignored.append((target.copy(), pose.t + c.give_up_ring_s))
                self._ring_target = None
        return v, w
