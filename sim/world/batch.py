"""The whole game as arrays over a batch of matches: the constants its compiled rules read, and a
World's state packed as a batch of one.

The whole game's rules (sim.world.rules: the score, the fouls, the autonomous period), the see-saw
(sim.world.seesaw) and the mechanisms (sim.world.mechanisms: tugs of war, where a ring goes) are
compiled loops over a batch of B matches. The twin's World calls them on itself packed as B = 1
(sim.world.rules.pack); the batched backend (sim.fast) keeps its matches in these arrays and
calls them on all of them at once: one definition of each rule for both.

Alliances are codes (0 red, 1 blue, -1 none); a robot's index is World's (red first); goals are
in the field file's order. `GameConsts` holds what does not change in a match: the field's
platforms, zones, AWP lines and points, the rules' numbers, each robot's and goal's size and mass.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.geometry import AllianceName
from sim.config import RobotConfig, WorldConfig
from sim.field import FieldSpec

F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
Bool = NDArray[np.bool_]

ALLIANCE_CODES: dict[str, int] = {"red": 0, "blue": 1}

# The foul kinds' codes (sim.world.state.FoulKind), the third axis of a batch's foul counts.
FOUL_KINDS: tuple[str, str, str] = (
    "isolation_contact",
    "isolation_home_zone",
    "platform_protection",
)

# The fields of a score row (rules.game_score's last axis), AllianceScore's order.
SCORE_FIELDS: tuple[str, ...] = (
    "rings",
    "goals_in_zone",
    "goals_elevated",
    "robots_elevated",
    "total",
    "rings_high",
    "rings_base",
    "autonomous_bonus",
    "autonomous_win_point",
    "fouls",
    "foul_credit",
    "balanced",
)


class GameConsts(NamedTuple):
    """What the whole game's compiled functions read that a match does not change. Per robot
    (R,): team, half_w, half_l, mass, lifts (its clamp lifts a goal off the tiles), pull (its
    drive's force, N), clamp_sign (+1 front clamp, -1 back), max_v. Per goal (G,): goal_team (-1
    neutral), goal_radius, goal_mass. Per alliance code (2,): plat_has, plat (centre x, centre y,
    half x, half y, height), max_tilt (rad, an edge on the floor), field_side (+1: the field is
    toward +x), awp_has, awp_line (x0, y0, x1, y1), awp_goal. Home zones in the field file's
    order: zone_team (Z,) and zone (Z, 4: x0, y0, x1, y1); the neutral zone is between
    neutral_lo and neutral_hi along x; plat_order: the platforms' codes in the field file's
    order (the order World meets them in)."""

    team: I64
    half_w: F64
    half_l: F64
    mass: F64
    lifts: Bool
    pull: F64
    clamp_sign: F64
    max_v: F64
    goal_team: I64
    goal_radius: F64
    goal_mass: F64
    plat_has: Bool
    plat_order: I64
    plat: F64
    max_tilt: F64
    field_side: F64
    awp_has: Bool
    awp_line: F64
    awp_goal: I64
    zone_team: I64
    zone: F64
    neutral_lo: float
    neutral_hi: float
    # points (the field file's [scoring])
    ring_high_branch: int
    ring_branch: int
    ring_base: int
    goal_in_home_zone: int
    robot_elevated: int
    goal_elevated: int
    autonomous_bonus: int
    autonomous_bonus_tie: int
    # rules (its [rules] and the world's settings)
    endgame_s: float
    platform_foul_credit: int
    elevated_robots_max: int
    isolation_contact_foul: bool
    isolation_foul_forfeits: bool
    isolation_home_zone_foul: bool
    isolation_s: float
    match_length_s: float
    pin_contact_m: float
    # the see-saw (its [seesaw])
    overhang: float
    balanced_tilt: float  # rad
    board_mass: float
    hinge_flat: float
    tilt_rate: float  # rad/s
    climb_edge: float


def game_consts(
    field: FieldSpec, config: WorldConfig, robots: Sequence[tuple[AllianceName, RobotConfig]]
) -> GameConsts:
    """The constants of the whole game on `field` with `robots` ((alliance, config) in World's
    order) under `config` (its isolation period, match length and contact margin)."""
    rules, sc, ss = field.rules, field.scoring, field.seesaw
    plat_has = np.zeros(2, dtype=bool)
    plat = np.zeros((2, 5))
    max_tilt = np.zeros(2)
    side = np.ones(2)
    for p in field.platforms:
        a = ALLIANCE_CODES[p.alliance]
        plat_has[a] = True
        plat[a] = (p.center[0], p.center[1], p.size[0] / 2, p.size[1] / 2, p.height)
        max_tilt[a] = p.max_tilt_rad
        side[a] = p.field_side
    awp_has = np.zeros(2, dtype=bool)
    awp_line = np.zeros((2, 4))
    awp_goal = np.zeros(2, dtype=np.int64)
    for name, line in field.awp_lines.items():
        a = ALLIANCE_CODES[name]
        if name in field.awp_goals:
            awp_has[a] = True
            awp_line[a] = line
            awp_goal[a] = field.awp_goals[name]
    zones = list(field.home_zones.items())
    zone = np.array([(z.x0, z.y0, z.x1, z.y1) for _, z in zones], dtype=np.float64).reshape(-1, 4)
    lo = field.home_zones["red"].x1 if "red" in field.home_zones else 0.0
    hi = field.home_zones["blue"].x0 if "blue" in field.home_zones else 0.0
    interaction = config.interaction_s or rules.interaction_s
    rcs = [rc for _, rc in robots]
    return GameConsts(
        team=np.array([ALLIANCE_CODES[a] for a, _ in robots], dtype=np.int64),
        half_w=np.array([rc.width_m / 2 for rc in rcs], dtype=np.float64),
        half_l=np.array([rc.length_m / 2 for rc in rcs], dtype=np.float64),
        mass=np.array([rc.mass_kg for rc in rcs], dtype=np.float64),
        lifts=np.array([rc.clamp_lifts for rc in rcs], dtype=bool),
        pull=np.array([rc.pull_n for rc in rcs], dtype=np.float64),
        clamp_sign=np.array([rc.clamp_sign for rc in rcs], dtype=np.float64),
        max_v=np.array([rc.max_linear_mps for rc in rcs], dtype=np.float64),
        goal_team=np.array(
            [-1 if g.alliance is None else ALLIANCE_CODES[g.alliance] for g in field.goals],
            dtype=np.int64,
        ),
        goal_radius=np.array(field.goal_base_radii, dtype=np.float64),
        goal_mass=np.array([g.mass_kg for g in field.goals], dtype=np.float64),
        plat_has=plat_has,
        plat_order=np.array([ALLIANCE_CODES[p.alliance] for p in field.platforms], dtype=np.int64),
        plat=plat,
        max_tilt=max_tilt,
        field_side=side,
        awp_has=awp_has,
        awp_line=awp_line,
        awp_goal=awp_goal,
        zone_team=np.array([ALLIANCE_CODES[a] for a, _ in zones], dtype=np.int64),
        zone=zone,
        neutral_lo=float(lo),
        neutral_hi=float(hi),
        ring_high_branch=sc.ring_high_branch,
        ring_branch=sc.ring_branch,
        ring_base=sc.ring_base,
        goal_in_home_zone=sc.goal_in_home_zone,
        robot_elevated=sc.robot_elevated,
        goal_elevated=sc.goal_elevated,
        autonomous_bonus=sc.autonomous_bonus,
        autonomous_bonus_tie=sc.autonomous_bonus_tie,
        endgame_s=float(rules.endgame_s),
        platform_foul_credit=int(rules.platform_foul_credit),
        elevated_robots_max=int(rules.elevated_robots_max),
        isolation_contact_foul=bool(rules.isolation_contact_foul),
        isolation_foul_forfeits=bool(rules.isolation_foul_forfeits),
        isolation_home_zone_foul=bool(rules.isolation_home_zone_foul),
        isolation_s=float(config.isolation_s),
        match_length_s=float(config.isolation_s + interaction),
        pin_contact_m=float(config.pin_contact_m),
        overhang=float(ss.overhang),
        balanced_tilt=math.radians(ss.balanced_tilt_deg),
        board_mass=float(ss.board_mass_kg),
        hinge_flat=float(ss.hinge_flat),
        tilt_rate=math.radians(ss.tilt_rate_deg_s),
        climb_edge=float(ss.climb_edge),
    )


class GameBatch(NamedTuple):
    """A batch's state as the whole game's rules read it (each array's first axis the match):
    robots' pose x, y, heading (deg) and commanded speed v (B, R), on_platform (B, R: the
    alliance code of the board it drove onto, -1 none); goals' x, y, carrier and contester (B, G:
    a robot index, -1 none), rings on each and how many of them are on its high branch and in its
    base (B, G); each alliance's board tilt (B, 2, rad, + field-side edge down); the fouls so far
    by alliance and kind (B, 2, 3: FOUL_KINDS); the autonomous period's bonus and win point by
    alliance (B, 2; zero until it is judged)."""

    x: F64
    y: F64
    heading: F64
    v: F64
    on_platform: I64
    gx: F64
    gy: F64
    carrier: I64
    contester: I64
    rings: I64
    rings_high: I64
    rings_base: I64
    tilt: F64
    fouls: I64
    auto_bonus: I64
    auto_win_point: I64
