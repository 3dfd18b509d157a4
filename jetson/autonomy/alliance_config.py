"""The scripted alliance's settings and messages (jetson/autonomy/alliance.py): the robot it
drives as its own settings know it (RobotRole), the script's numbers (AllianceConfig, each with
why it is what it is), what the robot knows at one control step (AllianceInputs) and what the
strategy commands (AllianceAction). numpy only."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.field_layout import GoalLayout

Vec = NDArray[np.float64]


@dataclass(frozen=True)
class RobotRole:
    """The robot this strategy drives, as its own settings know it (not the match's state)."""

    role: str  # "24in" (the high-branch lift) or "15in"
    length_m: float
    width_m: float
    mass_kg: float
    max_linear_mps: float
    max_angular_rad_s: float
    intake_zone: tuple[float, float, float, float]  # x0, x1, y0, y1 robot frame: what it takes
    reaches_high_branch: bool
    partner_mass_kg: float  # the alliance's other robot
    ring_capacity: int | None = 10  # rings the intake holds (None: no limit)

    def __post_init__(self) -> None:
        if self.role not in ("24in", "15in"):
            raise ValueError(f"role must be '24in' or '15in', got {self.role!r}")
        for name in ("length_m", "width_m", "mass_kg", "max_linear_mps", "max_angular_rad_s"):
            if not getattr(self, name) > 0:
                raise ValueError(f"robot role: {name} must be positive")

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> RobotRole:
        d = dict(data)
        d["intake_zone"] = tuple(float(v) for v in d["intake_zone"])
        return cls(**d)

    def clamp_offset(self, goal: GoalLayout) -> float:
        """Robot centre to a clamped goal's centre (as the Brain's clamp holds it)."""
        return self.length_m / 2 + goal.base_radius_m + 0.005


@dataclass(frozen=True)
class AllianceConfig:
    """The script's numbers. Times are seconds before the match's end unless named otherwise."""

    lookahead_m: float = 0.3
    turn_gain: float = 4.0
    turn_in_place_rad: float = 1.0
    speed: float = 1.0  # fraction of the top speed when driving to a point
    turn_cost_m_per_rad: float = 0.2  # when choosing the next ring
    switch_margin_m: float = 0.15
    give_up_ring_s: float = 5.0
    stuck_window_s: float = 1.0
    stuck_distance_m: float = 0.04
    backoff_s: float = 0.6
    goal_stage_m: float = 0.8  # wait this far from a goal's centre before backing onto it
    goal_try_s: float = 7.0  # backing onto one goal this long without the clamp closing: missing
    goal_chase_s: float = 15.0  # going for one goal this long (interaction): left for busy_s
    # Start backing onto a neutral goal this long before the isolation period ends (0: as it
    # ends; the step that reaches its end is still judged as isolation).
    isolation_margin_s: float = 0.0
    # After its isolation work a robot stands still where it is (a robot standing still cannot
    # make contact) until the period ends; with iso_rings it collects rings on its own side
    # (x below iso_ring_x_max_m) instead, until iso_rings_until_s before the end.
    iso_rings: bool = False
    iso_rings_until_s: float = 2.5
    iso_ring_x_max_m: float = -0.4  # rings this far from the centre line only, in isolation
    preload_wait_s: float = 3.5  # hold the AWP goal at most this long for the preloads
    ring_half_split_m: float = 0.0  # the 24" takes rings with y below this, the 15" above
    ring_x_max_m: float = 0.45  # no ring chasing deeper into the opponent's side (alliance frame)
    endgame_x_max_m: float = 0.1  # nor past this in the endgame (the protected platforms)
    platform_keepout_m: float = 0.35  # rings this close to the board are left alone
    # The endgame: the 24" heads for the platform `climb_24_s` before the end, holds the board's
    # field edge down at `hold_along_m` from the hinge until `settle_s`, then moves to the
    # balance point; the 15" drops its goal at `drop_15_s`, waits at its stage from `stage_15_s`
    # and climbs to `partner_along_m` at `climb_15_s`.
    climb_24_s: float = 32.0
    hold_along_m: float = 0.2
    settle_s: float = 9.0
    drop_15_s: float = 24.0
    carry_goal_15: bool = True  # the 15" climbs with its goal (elevated 40) instead of dropping it
    stage_15_s: float = 18.0
    climb_15_s: float = 14.0
    partner_along_m: float = -0.10
    stage_along_m: float = 0.95  # the stage in front of the board, from the hinge
    board_y_24_m: float = -0.25  # where on the board each robot stands (alliance frame)
    board_y_15_m: float = 0.31
    board_speed_mps: float = 0.35
    board_heading_tolerance_deg: float = 6.0  # standing on the board: heading left this far off
    footprint_margin_m: float = 0.035  # keep the footprint this far inside the board's reach
    # The 15"'s sentry: it mounts the board from `sentry_stage_along_m` and waits at
    # `sentry_along_m` from the hinge, on the field side (its weight keeps the ramp down).
    sentry_stage_along_m: float = 0.65
    sentry_along_m: float = 0.3
    # The lock: the sentry waits at `lock_along_m` instead, where the board is level under it
    # and its goal (nobody drives onto a level board), and moves to `sentry_along_m` (the ramp
    # down) `unlock_s` before the end for the 24" to climb; the 24" starts up the board no
    # earlier than `climb_after_s` before the end. None: no lock (the ramp down all match).
    lock_along_m: float | None = -0.07
    unlock_s: float = 22.0
    climb_after_s: float = 20.5
    # guard: after its isolation work a robot drives to stand in front of the platform in its
    # climbing lane (goals pushed at the board meet it instead); off: it stands where it is.
    # Off by default: the drive there met the other alliance's robots (isolation fouls).
    guard: bool = False
    guard_gap_m: float = 0.05  # the guard stands this far in front of the board
    blocked_s: float = 2.0  # no progress onto the board this long: the climb is blocked
    # The 15" on the board (its sentry spot, or climbing from it) this far from its lane was
    # pushed out of it (a chain of robots and a goal swung through it; off the board's end it
    # holds nothing level and climbs nowhere): it goes back to its stage and lines up again.
    off_lane_m: float = 0.15
    park_along_m: float = 0.3  # a blocked robot parks here (from the hinge) ...
    park_y_m: float = 1.15  # ... this far beside the platform's centre
    # A tug of war: driving forward yet moved `tug_distance_m` backward in `tug_window_s`.
    tug_window_s: float = 0.75
    tug_distance_m: float = 0.05
    tug_s: float = 1.5
    # The tug of war that many times while holding one goal: let that goal go and take the next
    # on the list (0: never). A goal another robot holds keeps that robot attached to this one,
    # which can then neither collect nor climb.
    tug_release: int = 1
    # Goal sightings: one of its own or a neutral goal seen within `sight_match_m` of where it is
    # believed to be moves the belief there; one seen moving faster than `carried_mps` is carried
    # by another robot (left alone for `busy_s`); a goal of the other alliance's colour seen
    # within `conflict_m` of a believed goal in the last `conflict_s` stands where that goal was
    # believed (the believed one is marked missing).
    sight_match_m: float = 0.7
    goal_x_max_m: float = 0.45  # no goal is fetched from deeper in the other alliance's half
    carried_mps: float = 0.25
    busy_s: float = 25.0
    conflict_m: float = 0.5
    conflict_s: float = 2.0
    # Look before backing onto a goal (interaction, with a goal detector): the goal must have
    # been seen where it is believed in the last `confirm_s`; else the robot turns to face it
    # (backing away to `look_from_m` when nearer: the camera sees no goal closer than about
    # 0.7 m) and looks for up to `look_s`, and a goal not seen then is marked missing (what
    # stands there may be another robot's goal: backing onto it starts a tug of war; None: no
    # look).
    confirm_s: float | None = 1.5
    look_s: float = 2.5
    look_from_m: float = 0.85
    # The 24" with a goal and no ring known for `deposit_after_s` (the floor cleared), its
    # preloads off its intake, leaves that goal deep in its home zone at the next of
    # `deposit_spots` (the robot's centre, from the hinge toward the field and beside the
    # platform's centre; the goal trails it) while more than `deposit_until_s` are left, and
    # takes the next goal; `refetch_s` before the end, with none in hand, it goes back for the
    # one it left nearest, to climb with (None: never deposits).
    deposit_after_s: float | None = None
    # How many neutral goals (south, tall, north) the 24" tries before its AWP goal: a goal
    # the other alliance holds and stands still with looks free (a tug of war when clamped),
    # and the AWP goal is never another robot's.
    neutral_goals_24: int = 3
    deposit_until_s: float = 46.0
    deposit_spots: tuple[tuple[float, float], ...] = (
        (0.05, -1.3),
        (0.05, 1.3),
        (0.3, -1.45),
        (0.3, 1.45),
    )
    # `refetch_s` before the end the 24" wants a goal to climb with: the deposits' (above) and
    # the steal's (a free goal it holds is kept, one it left home is a target again).
    refetch_s: float = 44.0
    # The raid: once it has left its first goal (the preloads on it), the 24" fetches every
    # goal it believes free outside its home zone, of either alliance's colour or neutral, and
    # leaves it in its home zone (20 points each; one taken from the other alliance's home
    # zone is also 20 fewer for them, and goes first when within `raid_prefer_m` of a nearer
    # one). A goal in the other alliance's half is fetched until `deposit_until_s`, never from
    # on or beside either platform.
    raid: bool = False
    raid_prefer_m: float = 0.8
    # A goal on the board in the 24"'s lane (pushed up the ramp to the wall, it leaves the 24"
    # no room and tips the board): the 24" with no goal in its clamp, in front of the board,
    # backs up its lane onto it once the sentry unlocks the board, for at most `clear_lane_s`,
    # and climbs with it (seen by the goal detector in the last second; the daemon drops red
    # and blue sightings on a platform, jetson/autonomy/goal_sightings.py, so only a neutral
    # goal there is seen and taken).
    clear_lane_s: float = 6.0
    # The steal: `steal_s` before the end (the default: from the interaction period's first
    # second) the 24" leaves the goal it holds in its home zone and takes neutral goals home:
    # one seen carried first (the other alliance's loaded goal: its rings then count for this
    # alliance), then one standing in its own home zone that it did not leave there itself (the
    # ring race's chaser parks its loaded goal there), then the nearest; it searches its own
    # home zone before the middle. A goal another robot holds too (it comes slower than the
    # robot drives) it keeps; a free one it leaves in the home zone and takes the next. The 15"
    # plays as without the steal. None: no steal, the 24" scores rings and both robots climb.
    steal_s: float | None = 104.0
    # With the steal: `climb_24_s` before the end the 24" climbs after all, with the goal it
    # holds; one another robot holds too it tows to its stage at once and climbs with it (the
    # tow, below); the 15" plays the climbing endgame. False: the 24" holds its goal home to
    # the end, and the 15" stays at its lock spot, where the board balances under it and its
    # goal.
    steal_climb: bool = True
    # A neutral goal seen in motion this long is carried (jetson/autonomy/carried_goal.py).
    carried_s: float = 1.5
    # A goal the steal clamped and did not see carried is tested for at most this long: driven
    # ahead, one another robot holds too comes slower than the robot drives.
    steal_test_s: float = 6.0
    # A goal the steal clamps within `steal_again_m` of where it left one it tested free is held
    # to the end as another robot's. A chaser standing still with its loaded goal does not pull,
    # so that goal tests free and is left home; it stays where it was left (its chaser stands
    # still), and the steal comes back for it under another goal's name. A free goal left home
    # is pushed away by the robots passing (docs/notes/2026-11-28-taken-again.md). None: never.
    steal_again_m: float | None = 0.6
    steal_haul_y_m: float = 1.15  # the haul spot: this far beside the platform's centre ...
    steal_haul_along_m: float = 0.1  # ... and this far from the hinge toward the field
    # The tow (steal_climb, a goal another robot holds too): the 24" drags it to its stage
    # always driving ahead at `tow_speed` of its top speed or more (a tug of war goes to the
    # harder pull: a 24" at this share outpulls a 15" at full speed; turning in place hands the
    # goal over), steering at a point `tow_lookahead_m` along its lane toward the stage; beside
    # the platform it first tows out to the lane `tow_approach_m` beyond the stage. Within
    # `tow_near_m` of the stage it lines up there and waits (until `tow_into_board_s`, below);
    # in the last `tow_press_s` it tows and climbs at full speed.
    tow_speed: float = 0.7
    tow_lookahead_m: float = 0.4
    tow_approach_m: float = 0.5
    tow_lane_m: float = 0.08
    tow_near_m: float = 0.25
    tow_press_s: float = 10.0
    # From `tow_into_board_s` before the end (None: never) the 24" tows a goal another robot
    # holds too straight along its lane into the board instead: never slower than `tow_speed`,
    # pressed against the board's edge until it tips down, then up it and against the wall.
    tow_into_board_s: float | None = 24.0
    # Towed into the board, at or on it the 24" steers at most this far (radians) off its heading
    # toward its lane: turning harder there swings the chain across the board behind it.
    tow_board_err_rad: float = 0.3


class AllianceInputs(NamedTuple):
    """What the robot knows at one control step, as the daemon has it."""

    x: float  # GPS, field frame, metres
    y: float
    heading_deg: float
    alliance: str  # "red" or "blue"
    time_s: float  # since the match started, isolation included
    rings_robot_xy: Vec  # the camera's rings now, robot frame (x right, y forward)
    rings_held: int  # rings in the intake, not yet on a goal
    goal_clamped: bool  # the clamp holds a goal
    lift_up: bool = False
    # The goal detector's goals now, (N, 3): x, y robot frame and GOAL_COLOUR_CODES (None: no
    # goal detector, the goals are dead-reckoned from the layout and the clamp only).
    goals_robot: Vec | None = None


class AllianceAction(NamedTuple):
    linear: float  # m/s forward
    angular: float  # rad/s clockwise
    clamp: bool | None  # True hold, False release, None leave
    lift: bool | None  # True up, False down, None leave
    intake: bool
