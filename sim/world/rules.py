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

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.geometry import AllianceName
from sim.field import FieldSpec, PlatformSpec
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
    board) and the platform is Balanced."""
    return _robot_elevated(world, r, _Judged(world))


def _robot_elevated(world: WorldState, r: RobotState, judged: _Judged) -> bool:
    try:
        plat = world.field.platform(r.alliance)
    except ValueError:
        return False
    if whole_game(world):
        return (
            r.on_platform == r.alliance
            and footprint_on_board(plat, r, world.field.seesaw.overhang)
            and judged.balanced(r.alliance)
        )
    return plat.contains_point(r.x, r.y)


class _Judged:
    """What a score asks of one state again and again (is this robot elevated, is that platform
    Balanced), each worked out once: the answers hold until the state changes, so a _Judged
    lives for one question about the world (a score, a goal's owner)."""

    def __init__(self, world: WorldState) -> None:
        self.world = world
        self._balanced: dict[AllianceName, bool] = {}
        self._elevated: dict[int, bool] = {}

    def balanced(self, alliance: AllianceName) -> bool:
        b = self._balanced.get(alliance)
        if b is None:
            b = self._balanced[alliance] = platform_balanced(self.world, alliance)
        return b

    def elevated(self, r: RobotState) -> bool:
        e = self._elevated.get(r.index)
        if e is None:
            e = self._elevated[r.index] = _robot_elevated(self.world, r, self)
        return e


def goal_owner(world: WorldState, g: GoalState) -> tuple[AllianceName | None, bool]:
    """Which alliance a goal scores for right now, and whether it is elevated."""
    if whole_game(world):
        return _goal_owner_game(world, g, _Judged(world))
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
        return _score_game(world)
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


# --- the whole game ---------------------------------------------------------------------------


def robot_corners(r: RobotState) -> list[tuple[float, float]]:
    """The four corners of a robot's footprint, field frame."""
    h = math.radians(r.heading)
    fx, fy = math.sin(h), math.cos(h)  # forward
    rx, ry = fy, -fx  # right
    hw, hl = r.config.width_m / 2, r.config.length_m / 2
    return [
        (r.x + a * hl * fx + b * hw * rx, r.y + a * hl * fy + b * hw * ry)
        for a, b in ((1, 1), (1, -1), (-1, -1), (-1, 1))
    ]


def footprint_on_board(plat: PlatformSpec, r: RobotState, overhang: float = 0.0) -> bool:
    """The robot touches no tile: its footprint is over the board but for `overhang` (the field
    file's [seesaw] overhang: a frame hanging over the edge, its wheels on the board)."""
    hx, hy = plat.size[0] / 2 + overhang, plat.size[1] / 2 + overhang
    cx, cy = plat.center
    return all(abs(x - cx) <= hx and abs(y - cy) <= hy for x, y in robot_corners(r))


def goal_on_board(plat: PlatformSpec, g: GoalState) -> bool:
    """A free goal rests on the board: its centre is over it."""
    return g.carried_by is None and plat.contains_point(g.x, g.y)


def goal_fully_on_board(plat: PlatformSpec, g: GoalState) -> bool:
    rad = g.spec.base_radius
    return (
        abs(g.x - plat.center[0]) <= plat.size[0] / 2 - rad
        and abs(g.y - plat.center[1]) <= plat.size[1] / 2 - rad
    )


def platform_balanced(world: WorldState, alliance: AllianceName) -> bool:
    """Balanced [D]: the board roughly parallel to the field (|tilt| within the field file's
    balanced_tilt_deg, the hinge's flats on its base) and nothing on it also touching the tiles
    (a robot on it with part of its footprint off the board, a goal resting across its edge)."""
    plat = world.field.platform(alliance)
    state = world.platforms.get(alliance)
    if state is None or abs(state.tilt) > math.radians(world.field.seesaw.balanced_tilt_deg):
        return False
    overhang = world.field.seesaw.overhang
    for r in world.robots:
        if r.on_platform == alliance and not footprint_on_board(plat, r, overhang):
            return False
    return all(not goal_on_board(plat, g) or goal_fully_on_board(plat, g) for g in world.goals)


def goal_lifted(world: WorldState, g: GoalState) -> bool:
    """A goal held off the tiles by a clamp that lifts (RobotConfig.clamp_lifts)."""
    return any(world.robots[i].config.clamp_lifts for i in g.holders)


def _goal_owner_game(
    world: WorldState, g: GoalState, judged: _Judged
) -> tuple[AllianceName | None, bool]:
    """Elevated on an alliance's Balanced platform (resting on the board, or in Possession of an
    Elevated robot of it), else Scored in the home zone its base touches; an alliance goal only
    ever scores for its own alliance."""
    for i in g.holders:
        carrier = world.robots[i]
        if judged.elevated(carrier) and g.spec.alliance in (None, carrier.alliance):
            return carrier.alliance, True
    if g.carried_by is None:
        for alliance in ALLIANCES:
            try:
                plat = world.field.platform(alliance)
            except ValueError:
                continue
            if (
                goal_on_board(plat, g)
                and goal_fully_on_board(plat, g)
                and g.spec.alliance in (None, alliance)
                and judged.balanced(alliance)
            ):
                return alliance, True
    if goal_lifted(world, g):
        return None, False
    for alliance, zone in world.field.home_zones.items():
        inside = zone.contains_point(g.x, g.y, margin=g.spec.base_radius)
        if inside and g.spec.alliance in (None, alliance):
            return alliance, False  # type: ignore[return-value]
    return None, False


def ring_points(world: WorldState, g: GoalState) -> int:
    """What the rings on a goal are worth to the alliance they count for."""
    sc = world.field.scoring
    return (
        sc.ring_high_branch * g.rings_high
        + sc.ring_branch * g.rings_low
        + sc.ring_base * (g.rings_base)
    )


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


def _score_game(world: WorldState) -> dict[str, AllianceScore]:
    sc = world.field.scoring
    rules = world.field.rules
    judged = _Judged(world)
    elevated_robots = {a: 0 for a in ALLIANCES}
    robots = {a: 0 for a in ALLIANCES}
    for r in world.robots:
        robots[r.alliance] += 1
        if judged.elevated(r):
            elevated_robots[r.alliance] += 1
    owners = [_goal_owner_game(world, g, judged) for g in world.goals]
    fouls = {a: 0 for a in ALLIANCES}
    platform_fouls = {a: 0 for a in ALLIANCES}
    for f in world.fouls:
        fouls[f.alliance] += 1
        if f.kind == "platform_protection":
            platform_fouls[f.alliance] += 1
    out = {}
    for alliance in ALLIANCES:
        rings = high = base = points = in_zone = goals_up = 0
        for g, (owner, elevated) in zip(world.goals, owners, strict=True):
            if g.spec.alliance == alliance or (g.spec.alliance is None and owner == alliance):
                rings += g.rings
                high += g.rings_high
                base += g.rings_base
                points += ring_points(world, g)
            if owner == alliance:
                if elevated:
                    goals_up += 1
                else:
                    in_zone += 1
        credit = platform_credit(
            rules.platform_foul_credit * platform_fouls[other(alliance)],
            elevated_robots[alliance],
            robots[alliance],
            rules.elevated_robots_max,
        )
        auto = world.autonomous[alliance] if world.autonomous else None
        bonus = auto.bonus if auto else 0
        total = (
            points
            + in_zone * sc.goal_in_home_zone
            + goals_up * sc.goal_elevated
            + (elevated_robots[alliance] + credit) * sc.robot_elevated
            + bonus
        )
        out[alliance] = AllianceScore(
            rings,
            in_zone,
            goals_up,
            elevated_robots[alliance],
            total,
            rings_high=high,
            rings_base=base,
            autonomous_bonus=bonus,
            autonomous_win_point=bool(auto and auto.win_point),
            fouls=fouls[alliance],
            foul_credit=credit,
            balanced=alliance in world.platforms and judged.balanced(alliance),
        )
    return out


def _segment_distance(x: float, y: float, seg: tuple[float, float, float, float]) -> float:
    x0, y0, x1, y1 = seg
    dx, dy = x1 - x0, y1 - y0
    n = dx * dx + dy * dy
    t = 0.0 if n == 0 else min(1.0, max(0.0, ((x - x0) * dx + (y - y0) * dy) / n))
    return math.hypot(x - (x0 + t * dx), y - (y0 + t * dy))


def awp_line_cleared(world: WorldState, alliance: AllianceName) -> bool:
    """Cleared [G]: the alliance goal that started on the AWP line touches neither the line nor
    the Neutral Zone (between the two home zones), lifted or not (the line's projection is
    infinite upward, as the Q&A rules)."""
    f = world.field
    if alliance not in f.awp_lines:
        return False
    g = world.goals[f.awp_goals[alliance]]
    rad = g.spec.base_radius
    if _segment_distance(g.x, g.y, f.awp_lines[alliance]) <= rad:
        return False
    lo, hi = f.home_zones["red"].x1, f.home_zones["blue"].x0
    return not (g.x + rad > lo and g.x - rad < hi)


def autonomous_results(world: WorldState) -> dict[str, AutonomousResult]:
    """The isolation period's outcome, judged when it ends: the Autonomous Bonus to the alliance
    with more points (a tie, 0-0 included, splits it), the Win Point to an alliance that Cleared
    its AWP line with at least one ring on each of its alliance goals. An alliance whose robots
    committed a forfeiting foul in the period (rules.isolation_foul_forfeits) gives both to the
    opponent; when both did, neither gets the bonus."""
    sc = world.field.scoring
    now = _score_game(world)
    points = {a: now[a].total for a in ALLIANCES}
    forfeit = {a: False for a in ALLIANCES}
    if world.field.rules.isolation_foul_forfeits:
        for f in world.fouls:
            if f.kind in ("isolation_contact", "isolation_home_zone"):
                forfeit[f.alliance] = True
    out = {}
    for a in ALLIANCES:
        b = other(a)
        if forfeit[a] or forfeit[b]:
            bonus = sc.autonomous_bonus if forfeit[b] and not forfeit[a] else 0
        elif points[a] == points[b]:
            bonus = sc.autonomous_bonus_tie
        else:
            bonus = sc.autonomous_bonus if points[a] > points[b] else 0
        own_goals = [g for g in world.goals if g.spec.alliance == a]
        earned = (
            awp_line_cleared(world, a)
            and bool(own_goals)
            and all(g.rings > 0 for g in own_goals)
            and not forfeit[a]
        )
        out[a] = AutonomousResult(points[a], bonus, earned or (forfeit[b] and not forfeit[a]))
    return out


def _touches_platform(world: WorldState, r: RobotState, plat: PlatformSpec, margin: float) -> bool:
    """Whether a robot's footprint (its bounding box, grown by margin) meets a platform's board."""
    corners = robot_corners(r)
    xs = [c[0] for c in corners]
    ys = [c[1] for c in corners]
    hx, hy = plat.size[0] / 2 + margin, plat.size[1] / 2 + margin
    return (
        max(xs) >= plat.center[0] - hx
        and min(xs) <= plat.center[0] + hx
        and max(ys) >= plat.center[1] - hy
        and min(ys) <= plat.center[1] + hy
    )


def update_fouls(
    world: WorldState,
    touching: Callable[[RobotState, RobotState], bool],
    events: StepEvents,
) -> None:
    """One step of the fouls the twin can see (the whole game). Each is called once when it
    starts (a contact that goes on is one foul), charged to the robot that broke the rule:

    isolation_contact: in the isolation period, a robot touching one of the other alliance's,
        charged to each robot that was driving toward the other (VEX AI: no contact);
    isolation_home_zone: in the isolation period, a robot's centre in the opponent's home zone
        (<SG4>; off by default for VEX AI);
    platform_protection: in the last endgame_s seconds, a robot touching the opposing alliance's
        platform, or touching an opposing robot that stands on its own platform (contact is
        transitive, <SG3>)."""
    rules = world.field.rules
    isolation = world.time_s <= world.isolation_s + 1e-9 and world.isolation_s > 0
    endgame = world.time_s >= world.match_length_s - rules.endgame_s - 1e-9
    now: set[tuple[int, int, str]] = set()
    margin = world.config.pin_contact_m
    for a in world.robots:
        for b in world.robots:
            if a.alliance == b.alliance or a.index == b.index:
                continue
            if isolation and rules.isolation_contact_foul and touching(a, b):
                dx, dy = b.x - a.x, b.y - a.y
                h = math.radians(a.heading)
                toward = a.v * (math.sin(h) * dx + math.cos(h) * dy)
                if toward > 1e-3:
                    now.add((a.index, b.index, "isolation_contact"))
            if endgame and b.on_platform == b.alliance and touching(a, b):
                now.add((a.index, b.index, "platform_protection"))
        if isolation and rules.isolation_home_zone_foul:
            zone = world.field.home_zones[other(a.alliance)]
            if zone.contains_point(a.x, a.y):
                now.add((a.index, -1, "isolation_home_zone"))
        if endgame:
            try:
                plat = world.field.platform(other(a.alliance))
            except ValueError:
                continue
            if _touches_platform(world, a, plat, margin):
                now.add((a.index, -1, "platform_protection"))
    started = sorted(now - world.foul_contacts)
    world.foul_contacts.clear()
    world.foul_contacts.update(now)
    called: set[tuple[int, str]] = set()
    for robot, _, kind in started:
        if (robot, kind) in called:
            continue
        if kind == "platform_protection" and any(
            c[0] == robot and c[2] == kind and c not in started for c in now
        ):
            continue  # already fouling that platform through another contact
        called.add((robot, kind))
        foul = Foul(world.time_s, robot, world.robots[robot].alliance, kind)  # type: ignore[arg-type]
        world.fouls.append(foul)
        events.fouls.append(foul)
