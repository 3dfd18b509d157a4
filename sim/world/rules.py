"""The game's rules: what scores, which alliance a goal counts for, when a robot is elevated, when
a platform is balanced, when a pin or a foul is called, the autonomous bonus and win point.
Tipping Point (VEX 2021-22), as the manual counts it (the sources and the choices made where it is
silent are in sim/field/tipping_point.toml, which holds every number).

Two games (WorldConfig.game):

ring_race
    The original team's simplification: every ring on a goal counts as on a branch, a robot is
    elevated while it stands on its platform, no fouls, no autonomous bonus.
tipping_point
    The whole game: rings on a neutral goal's high branch 10, on any other branch 3, in a base 1;
    rings on an alliance goal count for its alliance wherever it is, on a neutral goal only for
    the alliance whose home zone it is Scored in (or on whose platform it is Elevated); each goal
    Scored in the alliance's home zone 20 (its base on the zone's tiles: not Elevated, not lifted
    by a clamp); each robot Elevated 30 and each goal Elevated 40 on the alliance's Balanced
    platform; the Autonomous Bonus and Win Point; fouls (the isolation period's contact rule,
    <SG3>'s platform protection) and what they cost.

Functions over the world's state (sim.world.state.WorldState); the physics (sim.world.physics)
calls them and knows nothing of points. A different game changes this file.
"""

from __future__ import annotations

import math
from collections.abc import Callable

import numba as nb
import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.geometry import AllianceName
from sim.field import FieldSpec, PlatformSpec
from sim.world.batch import (
    ALLIANCE_CODES,
    FOUL_KINDS,
    SCORE_FIELDS,
    GameBatch,
    GameConsts,
)
from sim.world.seesaw import robot_extents
from sim.world.state import (
    AllianceScore,
    AutonomousResult,
    Foul,
    GoalState,
    RobotState,
    StepEvents,
    WorldState,
)

ALLIANCES: tuple[AllianceName, AllianceName] = ("red", "blue")


def other(alliance: AllianceName) -> AllianceName:
    return "blue" if alliance == "red" else "red"


def whole_game(world: WorldState) -> bool:
    return world.config.game == "tipping_point"


def robot_elevated(world: WorldState, r: RobotState) -> bool:
    """Ring race: a robot is elevated while it stands on its alliance's platform. The whole game:
    it drove onto its alliance's platform, touches nothing else (its whole footprint is on the
    board but for the field file's overhang) and the platform is Balanced."""
    if whole_game(world):
        return bool(game_judged(world.game_consts, pack(world))[1][0, r.index])
    try:
        plat = world.field.platform(r.alliance)
    except ValueError:
        return False
    return plat.contains_point(r.x, r.y)


def goal_owner(world: WorldState, g: GoalState) -> tuple[AllianceName | None, bool]:
    """Which alliance a goal scores for right now, and whether it is elevated."""
    if whole_game(world):
        owner, up = game_owners(world.game_consts, pack(world))
        code = int(owner[0, g.index])
        return (None if code < 0 else ALLIANCES[code]), bool(up[0, g.index])
    owner, up, _ = ring_race_owners(world.field, *_ring_race_arrays(world))
    code = int(owner[0, g.index])
    return (None if code == 0 else ALLIANCES[code - 1]), bool(up[0, g.index])


def _ring_race_arrays(
    world: WorldState,
) -> tuple[tuple[AllianceName, ...], NDArray[np.float64], NDArray[np.float64], NDArray[np.int64]]:
    """One world as a batch of one: the robots' alliances and positions, the goals' positions
    and carriers (ring_race_owners' arguments)."""
    robots = np.array([(r.x, r.y) for r in world.robots], dtype=np.float64).reshape(1, -1, 2)
    goals = np.array([(g.x, g.y) for g in world.goals], dtype=np.float64).reshape(1, -1, 2)
    carrier = [-1 if g.carried_by is None else g.carried_by for g in world.goals]
    return (
        tuple(r.alliance for r in world.robots),
        robots,
        goals,
        np.array(carrier, dtype=np.int64).reshape(1, -1),
    )


def score(world: WorldState) -> dict[str, AllianceScore]:
    """The match score for the current state (as if the match ended now)."""
    if whole_game(world):
        return game_state_score(world)
    return _score_ring_race(world)


def _score_ring_race(world: WorldState) -> dict[str, AllianceScore]:
    """Rings on an alliance goal count for its alliance wherever it is; rings on a neutral goal
    count only while it is in a home zone (or elevated). Every ring counts as on a branch.
    (ring_race_score over a batch of one world.)"""
    alliances, robots, goals, carrier = _ring_race_arrays(world)
    rings = np.array([[g.rings for g in world.goals]], dtype=np.int64).reshape(1, -1)
    counts = ring_race_score(world.field, alliances, robots, goals, rings, carrier)
    return {a: AllianceScore(*(int(v[0]) for v in counts[a])) for a in ALLIANCES}


def ring_race_owners(
    field: FieldSpec,
    alliances: tuple[AllianceName, ...],
    robot_xy: NDArray[np.float64],
    goal_xy: NDArray[np.float64],
    goal_carrier: NDArray[np.int64],
) -> tuple[NDArray[np.int64], NDArray[np.bool_], NDArray[np.bool_]]:
    """The ring race, for a batch of B worlds: each goal's owner (B, G: 0 none, 1 red, 2 blue),
    whether it is elevated (B, G), and whether each robot is (B, R). A robot is elevated while
    its centre is on its alliance's platform; a goal carried by an elevated robot it may score
    for is elevated with it; otherwise a goal belongs to the first home zone (the field file's
    order) its base touches, if it may score there. Arguments as ring_race_score's."""
    team = np.array([a == "red" for a in alliances], dtype=bool)
    elevated = np.zeros(robot_xy.shape[:2], dtype=bool)
    for alliance in ALLIANCES:
        mine = team if alliance == "red" else ~team
        try:
            plat = field.platform(alliance)
        except ValueError:
            continue
        elevated |= plat.contains(robot_xy) & mine[None]
    owner = np.zeros(goal_xy.shape[:2], dtype=np.int64)
    goal_up = np.zeros(goal_xy.shape[:2], dtype=bool)
    if len(alliances):
        carried = goal_carrier >= 0
        carrier = np.where(carried, goal_carrier, 0)
        carrier_red = team[carrier]
        carrier_up = np.take_along_axis(elevated, carrier, axis=1) & carried
        allowed = field.goal_may_score
        may = np.where(carrier_red, allowed[None, :, 0], allowed[None, :, 1])
        goal_up = carrier_up & may
        owner = np.where(goal_up, np.where(carrier_red, 1, 2), 0)
    margin = field.goal_base_radii[None]
    for alliance, zone in field.home_zones.items():
        code = 1 if alliance == "red" else 2
        inside = zone.contains(goal_xy, margin=margin)  # type: ignore[arg-type]
        ok = field.goal_may_score[:, code - 1]
        owner = np.where((owner == 0) & inside & ok[None], code, owner)
    return owner, goal_up, elevated


def ring_race_score(
    field: FieldSpec,
    alliances: tuple[AllianceName, ...],
    robot_xy: NDArray[np.float64],
    goal_xy: NDArray[np.float64],
    goal_rings: NDArray[np.int64],
    goal_carrier: NDArray[np.int64],
) -> dict[str, tuple[NDArray[np.int64], ...]]:
    """The ring race's score of a batch of B worlds at once, by alliance: (rings, goals in the
    home zone, goals elevated, robots elevated, total), each (B,). robot_xy (B, R, 2) with the
    robots' alliances; goal_xy (B, G, 2), goal_rings (B, G) and goal_carrier (B, G: the robot
    index, -1 when free), the goals in the field file's order. The twin's World scores through
    it with B = 1; the batched backend (sim.fast) with every match together."""
    sc = field.scoring
    n = goal_xy.shape[0]
    team = np.array([a == "red" for a in alliances], dtype=bool)  # (R,) red robots
    owner, goal_up, elevated = ring_race_owners(field, alliances, robot_xy, goal_xy, goal_carrier)
    out = {}
    for alliance in ALLIANCES:
        code = 1 if alliance == "red" else 2
        may = field.goal_may_score
        neutral = may[:, 0] & may[:, 1]
        own = may[:, code - 1] & ~neutral
        counts = own[None] | (neutral[None] & (owner == code))
        rings = (goal_rings * counts).sum(axis=1)
        in_zone = ((owner == code) & ~goal_up).sum(axis=1)
        up_goals = ((owner == code) & goal_up).sum(axis=1)
        mine = team if alliance == "red" else ~team
        robots_up = (elevated & mine[None]).sum(axis=1) if len(alliances) else np.zeros(n, int)
        total = (
            rings * sc.ring_branch
            + in_zone * sc.goal_in_home_zone
            + up_goals * sc.goal_elevated
            + robots_up * sc.robot_elevated
        )
        out[alliance] = (rings, in_zone, up_goals, robots_up, total)
    return out


def update_pins(
    world: WorldState,
    touching: Callable[[RobotState, RobotState], bool],
    events: StepEvents,
    dt: float,
) -> None:
    """One step of the pin rule for one world (pin_step over its red-blue pairs)."""
    timers = world.pin_timers
    pairs = [
        (a, b)
        for a in world.robots
        if a.alliance == "red"
        for b in world.robots
        if b.alliance == "blue"
    ]
    if not pairs:
        return
    keys = [(a.index, b.index) for a, b in pairs]
    now = np.array([timers.get(k, 0.0) for k in keys])
    contact = np.array([touching(a, b) for a, b in pairs], dtype=bool)
    now, pinned = pin_step(now, contact, dt, world.pin_time_s)
    for k, t, pin in zip(keys, now, pinned, strict=True):
        timers[k] = float(t)
        if pin:
            events.pins.append(k)


def pin_step(
    timers: NDArray[np.float64], touching: NDArray[np.bool_], dt: float, pin_time_s: float
) -> tuple[NDArray[np.float64], NDArray[np.bool_]]:
    """The pin rule, one control step of any batch of red-blue pairs: a pair in contact for
    pin_time_s is a pin and its timer starts again; apart, its timer is zero. Returns the new
    timers and which pairs were pinned."""
    grown = np.where(touching, timers + dt, 0.0)
    pinned = touching & (grown >= pin_time_s - 1e-9)
    return np.where(pinned, 0.0, grown), pinned


def pin_timer(world: WorldState, red_index: int, blue_index: int) -> float:
    """How long the two robots have been in contact, s (0 when apart or just pinned)."""
    return world.pin_timers.get((red_index, blue_index), 0.0)


def _alliance_code(alliance: str | None) -> int:
    return -1 if alliance is None else ALLIANCE_CODES[alliance]


def pack(world: WorldState) -> GameBatch:
    """One World's state as a batch of one."""
    robots, goals = world.robots, world.goals
    tilt = np.zeros((1, 2))
    for name, state in world.platforms.items():
        tilt[0, ALLIANCE_CODES[name]] = state.tilt
    fouls = np.zeros((1, 2, 3), dtype=np.int64)
    for f in world.fouls:
        fouls[0, ALLIANCE_CODES[f.alliance], FOUL_KINDS.index(f.kind)] += 1
    bonus = np.zeros((1, 2), dtype=np.int64)
    win = np.zeros((1, 2), dtype=np.int64)
    if world.autonomous:
        for name, res in world.autonomous.items():
            bonus[0, ALLIANCE_CODES[name]] = res.bonus
            win[0, ALLIANCE_CODES[name]] = int(res.win_point)

    def row(values: list[float], dtype: type = np.float64) -> NDArray:
        return np.array(values, dtype=dtype).reshape(1, -1)

    return GameBatch(
        x=row([r.x for r in robots]),
        y=row([r.y for r in robots]),
        heading=row([r.heading for r in robots]),
        v=row([r.v for r in robots]),
        on_platform=row([_alliance_code(r.on_platform) for r in robots], np.int64),
        gx=row([g.x for g in goals]),
        gy=row([g.y for g in goals]),
        carrier=row([-1 if g.carried_by is None else g.carried_by for g in goals], np.int64),
        contester=row([-1 if g.contested_by is None else g.contested_by for g in goals], np.int64),
        rings=row([g.rings for g in goals], np.int64),
        rings_high=row([g.rings_high for g in goals], np.int64),
        rings_base=row([g.rings_base for g in goals], np.int64),
        tilt=tilt,
        fouls=fouls,
        auto_bonus=bonus,
        auto_win_point=win,
    )


# --- the whole game ---------------------------------------------------------------------------
# Compiled loops over a batch of matches (sim.world.batch: GameConsts, GameBatch). World calls
# them on itself as a batch of one (pack); the batched backend (sim.fast) on all its matches.
# Alliance codes: 0 red, 1 blue, -1 none.


@nb.njit(cache=True)
def _on_board(c: GameConsts, a: int, x: float, y: float, grow: float) -> bool:
    """A point over alliance a's board, the board grown by `grow` on every side."""
    return abs(x - c.plat[a, 0]) <= c.plat[a, 2] + grow and abs(y - c.plat[a, 1]) <= (
        c.plat[a, 3] + grow
    )


@nb.njit(cache=True)
def _footprint_on_board(c: GameConsts, a: int, x: float, y: float, heading: float, i: int) -> bool:
    """Robot i touches no tile: its footprint's four corners are over a's board but for the
    field file's overhang (a frame hanging over the edge, its wheels on the board)."""
    h = math.radians(heading)
    fx, fy = math.sin(h), math.cos(h)
    rx, ry = fy, -fx
    hw, hl = c.half_w[i], c.half_l[i]
    for sa in (1.0, -1.0):
        for sb in (1.0, -1.0):
            px = x + sa * hl * fx + sb * hw * rx
            py = y + sa * hl * fy + sb * hw * ry
            if not _on_board(c, a, px, py, c.overhang):
                return False
    return True


@nb.njit(cache=True)
def _balanced(c: GameConsts, s: GameBatch, b: int, a: int) -> bool:
    """Balanced [D]: the board roughly parallel to the field (|tilt| within balanced_tilt, the
    hinge's flats on its base) and nothing on it also touching the tiles (a robot on it with part
    of its footprint off the board, a free goal whose centre is over the board resting across its
    edge)."""
    if not c.plat_has[a] or abs(s.tilt[b, a]) > c.balanced_tilt:
        return False
    for i in range(s.x.shape[1]):
        if s.on_platform[b, i] == a and not _footprint_on_board(
            c, a, s.x[b, i], s.y[b, i], s.heading[b, i], i
        ):
            return False
    for g in range(s.gx.shape[1]):
        x, y = s.gx[b, g], s.gy[b, g]
        free = s.carrier[b, g] < 0
        if free and _on_board(c, a, x, y, 0.0) and not _on_board(c, a, x, y, -c.goal_radius[g]):
            return False
    return True


@nb.njit(cache=True)
def _judge(
    c: GameConsts, s: GameBatch, b: int, balanced: NDArray[np.bool_], up: NDArray[np.bool_]
) -> None:
    """Match b's platforms Balanced (2,) and robots Elevated (R,), into the arrays given: a robot
    is Elevated when it drove onto its own alliance's board, its footprint is on it and the
    board is Balanced."""
    for a in range(2):
        balanced[a] = _balanced(c, s, b, a)
    for i in range(s.x.shape[1]):
        a = c.team[i]
        up[i] = (
            c.plat_has[a]
            and s.on_platform[b, i] == a
            and balanced[a]
            and _footprint_on_board(c, a, s.x[b, i], s.y[b, i], s.heading[b, i], i)
        )


@nb.njit(cache=True)
def _owner(
    c: GameConsts, s: GameBatch, b: int, g: int, balanced: NDArray[np.bool_], up: NDArray[np.bool_]
) -> tuple[int, bool]:
    """Goal g's owner (alliance code, -1 none) and whether it is Elevated: in the Possession of
    an Elevated robot it may score for; else resting wholly on a Balanced board of an alliance it
    may score for; else (not lifted by a clamp) Scored in the first home zone its base touches
    that it may score for. An alliance goal only ever scores for its own alliance."""
    mine = c.goal_team[g]
    lifted = False
    for k in range(2):
        i = s.carrier[b, g] if k == 0 else s.contester[b, g]
        if i < 0:
            continue
        lifted = lifted or c.lifts[i]
        if up[i] and (mine < 0 or mine == c.team[i]):
            return c.team[i], True
    x, y, rad = s.gx[b, g], s.gy[b, g], c.goal_radius[g]
    if s.carrier[b, g] < 0:
        for a in range(2):
            if (
                c.plat_has[a]
                and balanced[a]
                and (mine < 0 or mine == a)
                and _on_board(c, a, x, y, 0.0)
                and _on_board(c, a, x, y, -rad)
            ):
                return a, True
    if lifted:
        return -1, False
    for z in range(c.zone.shape[0]):
        a = c.zone_team[z]
        x0, y0, x1, y1 = c.zone[z, 0], c.zone[z, 1], c.zone[z, 2], c.zone[z, 3]
        if x0 - rad <= x <= x1 + rad and y0 - rad <= y <= y1 + rad and (mine < 0 or mine == a):
            return a, False
    return -1, False


@nb.njit(cache=True)
def platform_credit(violations: int, elevated: int, robots: int, most: int) -> int:
    """The Elevated robots credited to an alliance for the opponent's <SG3> violations (v2.2):
    each violation that does not interfere with gameplay credits "one additional Elevated
    Robot", and "Alliances may still only receive points for a maximum of two Elevated Robots"
    (`most`, the field file's elevated_robots_max; 0: no bound). The credit fills only what the
    alliance's own Elevated robots leave of that bound, and (a choice, for the twin's 1v1
    configs: the manual's alliances always field two robots) of the robots it fields: a
    credited robot stands for one of its own that the violation kept off its platform."""
    if most <= 0:
        return violations
    return max(0, min(violations, min(most, robots) - elevated))


@nb.njit(cache=True)
def game_judged(c: GameConsts, s: GameBatch) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Every match's platforms Balanced (B, 2) and robots Elevated (B, R)."""
    n, r = s.x.shape
    balanced = np.zeros((n, 2), dtype=np.bool_)
    up = np.zeros((n, r), dtype=np.bool_)
    for b in range(n):
        _judge(c, s, b, balanced[b], up[b])
    return balanced, up


@nb.njit(cache=True)
def game_owners(c: GameConsts, s: GameBatch) -> tuple[NDArray[np.int64], NDArray[np.bool_]]:
    """Every goal's owner (B, G: alliance code, -1 none) and whether it is Elevated (B, G)."""
    n, r = s.x.shape
    n_goal = s.gx.shape[1]
    owner = np.full((n, n_goal), -1, dtype=np.int64)
    elevated = np.zeros((n, n_goal), dtype=np.bool_)
    for b in range(n):
        balanced = np.zeros(2, dtype=np.bool_)
        up = np.zeros(r, dtype=np.bool_)
        _judge(c, s, b, balanced, up)
        for g in range(n_goal):
            owner[b, g], elevated[b, g] = _owner(c, s, b, g, balanced, up)
    return owner, elevated


@nb.njit(cache=True)
def game_score(c: GameConsts, s: GameBatch) -> NDArray[np.int64]:
    """The whole game's score of every match as if it ended now, (B, 2, 12): by alliance, the
    fields of sim.world.batch.SCORE_FIELDS (AllianceScore's). Rings on a neutral goal's high
    branch, on any branch and in a base count for the alliance the goal counts for (an alliance
    goal's wherever it is, a neutral goal's owner's); each goal Scored in a home zone and each
    robot and goal Elevated; the Elevated robots credited for the opponent's platform fouls;
    the autonomous bonus once it is judged."""
    n, r = s.x.shape
    n_goal = s.gx.shape[1]
    out = np.zeros((n, 2, 12), dtype=np.int64)
    for b in range(n):
        balanced = np.zeros(2, dtype=np.bool_)
        up = np.zeros(r, dtype=np.bool_)
        _judge(c, s, b, balanced, up)
        owner = np.full(n_goal, -1, dtype=np.int64)
        goal_up = np.zeros(n_goal, dtype=np.bool_)
        for g in range(n_goal):
            owner[g], goal_up[g] = _owner(c, s, b, g, balanced, up)
        for a in range(2):
            rings = high = base = points = in_zone = goals_up = robots = elevated = 0
            for i in range(r):
                if c.team[i] == a:
                    robots += 1
                    elevated += up[i]
            for g in range(n_goal):
                mine = c.goal_team[g]
                if mine == a or (mine < 0 and owner[g] == a):
                    hi, ba = s.rings_high[b, g], s.rings_base[b, g]
                    rings += s.rings[b, g]
                    high += hi
                    base += ba
                    points += (
                        c.ring_high_branch * hi
                        + c.ring_branch * (s.rings[b, g] - hi - ba)
                        + c.ring_base * ba
                    )
                if owner[g] == a:
                    if goal_up[g]:
                        goals_up += 1
                    else:
                        in_zone += 1
            credit = platform_credit(
                c.platform_foul_credit * s.fouls[b, 1 - a, 2],
                elevated,
                robots,
                c.elevated_robots_max,
            )
            bonus = s.auto_bonus[b, a]
            row = out[b, a]
            row[0], row[1], row[2], row[3] = rings, in_zone, goals_up, elevated
            row[4] = (
                points
                + in_zone * c.goal_in_home_zone
                + goals_up * c.goal_elevated
                + (elevated + credit) * c.robot_elevated
                + bonus
            )
            row[5], row[6], row[7], row[8] = high, base, bonus, s.auto_win_point[b, a]
            row[9] = s.fouls[b, a, 0] + s.fouls[b, a, 1] + s.fouls[b, a, 2]
            row[10], row[11] = credit, c.plat_has[a] and balanced[a]
    return out


@nb.njit(cache=True)
def _segment_distance(x: float, y: float, x0: float, y0: float, x1: float, y1: float) -> float:
    dx, dy = x1 - x0, y1 - y0
    n = dx * dx + dy * dy
    t = 0.0 if n == 0 else min(1.0, max(0.0, ((x - x0) * dx + (y - y0) * dy) / n))
    return math.hypot(x - (x0 + t * dx), y - (y0 + t * dy))


@nb.njit(cache=True)
def _awp_cleared(c: GameConsts, s: GameBatch, b: int, a: int) -> bool:
    """Cleared [G]: the alliance goal that started on a's AWP line touches neither the line nor
    the Neutral Zone (between the two home zones), lifted or not (the line's projection is
    infinite upward, as the Q&A rules)."""
    if not c.awp_has[a]:
        return False
    g = c.awp_goal[a]
    x, y, rad = s.gx[b, g], s.gy[b, g], c.goal_radius[g]
    line = c.awp_line[a]
    if _segment_distance(x, y, line[0], line[1], line[2], line[3]) <= rad:
        return False
    return not (x + rad > c.neutral_lo and x - rad < c.neutral_hi)


@nb.njit(cache=True)
def game_autonomous(
    c: GameConsts, s: GameBatch, points: NDArray[np.int64]
) -> tuple[NDArray[np.int64], NDArray[np.bool_], NDArray[np.bool_]]:
    """The isolation period's outcome, judged when it ends, from each alliance's points then
    (B, 2): the Autonomous Bonus (B, 2) to the alliance with more points (a tie, 0-0 included,
    splits it), the Win Point (B, 2) to an alliance that Cleared its AWP line with at least one
    ring on each of its alliance goals, and whether each Cleared its line (B, 2). An alliance
    whose robots committed a forfeiting foul in the period (isolation_foul_forfeits) gives both
    to the opponent; when both did, neither gets the bonus."""
    n = s.x.shape[0]
    bonus = np.zeros((n, 2), dtype=np.int64)
    win = np.zeros((n, 2), dtype=np.bool_)
    cleared = np.zeros((n, 2), dtype=np.bool_)
    for b in range(n):
        forfeit = np.zeros(2, dtype=np.bool_)
        if c.isolation_foul_forfeits:
            for a in range(2):
                forfeit[a] = s.fouls[b, a, 0] + s.fouls[b, a, 1] > 0
        for a in range(2):
            o = 1 - a
            if forfeit[a] or forfeit[o]:
                bonus[b, a] = c.autonomous_bonus if forfeit[o] and not forfeit[a] else 0
            elif points[b, a] == points[b, o]:
                bonus[b, a] = c.autonomous_bonus_tie
            else:
                bonus[b, a] = c.autonomous_bonus if points[b, a] > points[b, o] else 0
            cleared[b, a] = _awp_cleared(c, s, b, a)
            own = every = 0
            for g in range(s.gx.shape[1]):
                if c.goal_team[g] == a:
                    own += 1
                    every += s.rings[b, g] > 0
            earned = cleared[b, a] and own > 0 and every == own and not forfeit[a]
            win[b, a] = earned or (forfeit[o] and not forfeit[a])
    return bonus, win, cleared


@nb.njit(cache=True)
def _touches_platform(c: GameConsts, s: GameBatch, b: int, i: int, a: int, margin: float) -> bool:
    """Whether robot i's footprint (its bounding box, grown by margin) meets a's board."""
    ex, ey = robot_extents(c, i, s.heading[b, i])
    hx, hy = c.plat[a, 2] + margin, c.plat[a, 3] + margin
    x, y = s.x[b, i], s.y[b, i]
    return (
        x + ex >= c.plat[a, 0] - hx
        and x - ex <= c.plat[a, 0] + hx
        and y + ey >= c.plat[a, 1] - hy
        and y - ey <= c.plat[a, 1] + hy
    )


@nb.njit(cache=True)
def game_fouls(
    c: GameConsts,
    s: GameBatch,
    time_s: NDArray[np.float64],
    touching: NDArray[np.bool_],
    contacts: NDArray[np.bool_],
    live: NDArray[np.bool_],
) -> NDArray[np.bool_]:
    """One step of the fouls the twin can see, in every live match at its time_s (after the
    step). Each is called once when it starts (a contact that goes on is one foul), charged to
    the robot that broke the rule (the kinds are sim.world.batch.FOUL_KINDS):

    isolation_contact: in the isolation period, a robot touching one of the other alliance's
        (touching, (B, R, R)), charged to each robot that was driving toward the other (VEX
        AI: no contact);
    isolation_home_zone: in the isolation period, a robot's centre in the opponent's home zone
        (<SG4>; off by default for VEX AI);
    platform_protection: in the last endgame_s seconds, a robot touching the opposing
        alliance's platform (its bounding box within pin_contact_m), or touching an opposing
        robot that stands on its own platform (contact is transitive, <SG3>).

    contacts (B, R, R + 1, 3): which contacts (robot, other robot or R for none, kind) were going
    on, updated in place; the batch's foul counts (s.fouls) grow by the fouls called. Returns
    which robot was called for which kind this step, (B, R, 3)."""
    n, r = s.x.shape
    called = np.zeros((n, r, 3), dtype=np.bool_)
    fouls = s.fouls  # written in place
    for b in range(n):
        if not live[b]:
            continue
        t = time_s[b]
        isolation = c.isolation_s > 0 and t <= c.isolation_s + 1e-9
        endgame = t >= c.match_length_s - c.endgame_s - 1e-9
        now = np.zeros((r, r + 1, 3), dtype=np.bool_)
        for i in range(r):
            for j in range(r):
                if c.team[i] == c.team[j]:
                    continue
                if isolation and c.isolation_contact_foul and touching[b, i, j]:
                    h = math.radians(s.heading[b, i])
                    dx, dy = s.x[b, j] - s.x[b, i], s.y[b, j] - s.y[b, i]
                    if s.v[b, i] * (math.sin(h) * dx + math.cos(h) * dy) > 1e-3:
                        now[i, j, 0] = True
                if endgame and s.on_platform[b, j] == c.team[j] and touching[b, i, j]:
                    now[i, j, 2] = True
            o = 1 - c.team[i]
            if isolation and c.isolation_home_zone_foul:
                for z in range(c.zone.shape[0]):
                    if c.zone_team[z] == o:
                        x0, y0, x1, y1 = c.zone[z, 0], c.zone[z, 1], c.zone[z, 2], c.zone[z, 3]
                        if x0 <= s.x[b, i] <= x1 and y0 <= s.y[b, i] <= y1:
                            now[i, r, 1] = True
                        break
            if endgame and c.plat_has[o] and _touches_platform(c, s, b, i, o, c.pin_contact_m):
                now[i, r, 2] = True
        for i in range(r):
            for k in range(3):
                started = ongoing = False
                for j in range(r + 1):
                    if now[i, j, k]:
                        if contacts[b, i, j, k]:
                            ongoing = True
                        else:
                            started = True
                # One foul per robot and kind when a contact starts; a platform fouled through
                # another contact that goes on is not called again.
                if started and not (k == 2 and ongoing):
                    called[b, i, k] = True
                    fouls[b, c.team[i], k] += 1
        contacts[b] = now
    return called


def game_state_score(world: WorldState) -> dict[str, AllianceScore]:
    """The whole game's score of one World (game_score on it as a batch of one)."""
    rows = game_score(world.game_consts, pack(world))[0]
    return {a: _alliance_score(rows[code]) for code, a in enumerate(ALLIANCES)}


def _alliance_score(row: NDArray[np.int64]) -> AllianceScore:
    values = dict(zip(SCORE_FIELDS, (int(v) for v in row), strict=True))
    values["autonomous_win_point"] = bool(values["autonomous_win_point"])
    values["balanced"] = bool(values["balanced"])
    return AllianceScore(**values)  # type: ignore[arg-type]


def platform_balanced(world: WorldState, alliance: AllianceName) -> bool:
    """Whether an alliance's board is Balanced now (the whole game; _balanced)."""
    if alliance not in world.platforms:
        return False
    balanced, _ = game_judged(world.game_consts, pack(world))
    return bool(balanced[0, ALLIANCE_CODES[alliance]])


def goal_on_board(plat: PlatformSpec, g: GoalState) -> bool:
    """A free goal rests on the board: its centre is over it."""
    return g.carried_by is None and plat.contains_point(g.x, g.y)


def platform_contact_at_end(world: WorldState) -> dict[str, bool]:
    """By alliance: whether one of its robots touches the opposing alliance's platform (itself or
    through an opposing robot standing on it) in the step the match ends with. <SG3> (v2.2, its
    Note 2): a violation still going on at the end of the match interferes with gameplay, a
    Disqualification. The twin reports it and does not score it (the match's points stand)."""
    out = {a: False for a in ALLIANCES}
    if world.time_s < world.match_length_s - 1e-9:
        return out
    for robot, _, kind in world.foul_contacts:
        if kind == "platform_protection":
            out[world.robots[robot].alliance] = True
    return out


def awp_line_cleared(world: WorldState, alliance: AllianceName) -> bool:
    """Whether an alliance Cleared its AWP line now (_awp_cleared)."""
    state = pack(world)
    points = np.zeros((1, 2), dtype=np.int64)
    return bool(game_autonomous(world.game_consts, state, points)[2][0, ALLIANCE_CODES[alliance]])


def autonomous_results(world: WorldState) -> dict[str, AutonomousResult]:
    """The isolation period's outcome for one World, judged as it ends (game_autonomous)."""
    state = pack(world)
    consts = world.game_consts
    points = game_score(consts, state)[:, :, 4]
    bonus, win, _ = game_autonomous(consts, state, points)
    return {
        a: AutonomousResult(int(points[0, k]), int(bonus[0, k]), bool(win[0, k]))
        for k, a in enumerate(ALLIANCES)
    }


def update_fouls(
    world: WorldState,
    touching: Callable[[RobotState, RobotState], bool],
    events: StepEvents,
) -> None:
    """One step of the fouls for one World (game_fouls on it as a batch of one): the fouls called
    go to world.fouls and events.fouls, robot by robot in FOUL_KINDS' order, and the contacts
    going on to world.foul_contacts."""
    consts = world.game_consts
    robots = world.robots
    r = len(robots)
    state = pack(world)
    isolation = consts.isolation_s > 0 and world.time_s <= consts.isolation_s + 1e-9
    endgame = world.time_s >= consts.match_length_s - consts.endgame_s - 1e-9
    touch = np.zeros((1, r, r), dtype=bool)
    if isolation or endgame:  # contacts only matter then (each is a PyBullet query)
        for a in robots:
            for b in robots:
                if a.alliance != b.alliance and a.index < b.index:
                    touch[0, a.index, b.index] = touch[0, b.index, a.index] = touching(a, b)
    contacts = np.zeros((1, r, r + 1, 3), dtype=bool)
    for i, j, kind in world.foul_contacts:
        contacts[0, i, r if j < 0 else j, FOUL_KINDS.index(kind)] = True
    called = game_fouls(
        consts, state, np.array([world.time_s]), touch, contacts, np.ones(1, dtype=bool)
    )
    world.foul_contacts.clear()
    for i, j, k in zip(*np.nonzero(contacts[0]), strict=True):
        world.foul_contacts.add((int(i), -1 if j == r else int(j), FOUL_KINDS[k]))
    for i, k in zip(*np.nonzero(called[0]), strict=True):
        foul = Foul(world.time_s, int(i), robots[i].alliance, FOUL_KINDS[k])  # type: ignore[arg-type]
        world.fouls.append(foul)
        events.fouls.append(foul)
