"""Field descriptions: a season's field as data (one TOML file per field), loaded into metres.

    spec = load_field("tipping_point")        # a file shipped in sim/field/
    spec = load_field("path/to/my_field.toml")

Everything returned is in the GPS field frame (jetson/autonomy/geometry.py), in metres and
degrees. Bad files raise FieldError naming the file and the key at fault. Only numpy and the
standard library here.
"""

from __future__ import annotations

import math
import tomllib
from dataclasses import dataclass, field
from functools import cached_property
from pathlib import Path
from typing import Any

import numpy as np

from jetson.autonomy.geometry import INCH, AllianceName
from sim.errors import FieldError

FIELD_DIR = Path(__file__).resolve().parent
DEFAULT_FIELD = "tipping_point"

_UNITS = {"m": 1.0, "in": INCH, "mm": 0.001, "cm": 0.01}
_GOAL_KINDS = ("alliance", "neutral", "neutral_tall")


RGB = tuple[int, int, int]


@dataclass(frozen=True)
class RingSpec:
    outer_diameter: float
    inner_diameter: float
    thickness: float
    mass_kg: float
    rgb: RGB
    total: int
    preloads_per_robot: int
    match_loads_per_alliance: int

    @property
    def radius(self) -> float:
        return self.outer_diameter / 2.0


@dataclass(frozen=True)
class GoalSpec:
    name: str
    kind: str  # "alliance", "neutral" or "neutral_tall"
    alliance: AllianceName | None
    position: tuple[float, float]
    base_radius: float
    base_height: float
    height: float
    mass_kg: float
    rgb: RGB
    branch_capacity: int = 1 << 30  # rings its low branches hold (then the base takes them)
    high_branch_capacity: int = 0  # rings its high branch holds (0: it has none)

    @property
    def has_high_branch(self) -> bool:
        return self.high_branch_capacity > 0


@dataclass(frozen=True)
class PlatformSpec:
    alliance: AllianceName
    center: tuple[float, float]
    size: tuple[float, float]  # (extent along x, extent along y)
    height: float
    rgb: RGB

    def contains(self, xy: np.ndarray) -> np.ndarray:
        p = np.asarray(xy, dtype=np.float64)
        return (np.abs(p[..., 0] - self.center[0]) <= self.size[0] / 2) & (
            np.abs(p[..., 1] - self.center[1]) <= self.size[1] / 2
        )

    def contains_point(self, x: float, y: float) -> bool:
        return (
            abs(x - self.center[0]) <= self.size[0] / 2
            and abs(y - self.center[1]) <= self.size[1] / 2
        )

    @property
    def field_side(self) -> float:
        """+1 or -1: the direction along x from the platform toward the field's centre (the
        board's hinge runs along y, parallel to the alliance wall)."""
        return 1.0 if self.center[0] < 0 else -1.0

    @property
    def max_tilt_rad(self) -> float:
        """The board's tilt when an edge rests on the floor."""
        return math.asin(min(1.0, self.height / (self.size[0] / 2)))

    def edge_height(self, tilt_rad: float) -> float:
        """Height of the field-side edge above the floor at a tilt (positive: that edge down)."""
        return max(0.0, self.height - self.size[0] / 2 * math.sin(tilt_rad))

    def along(self, x: float) -> float:
        """A point's distance from the hinge toward the field (the lever arm of a load)."""
        return (x - self.center[0]) * self.field_side


@dataclass(frozen=True)
class SeesawSpec:
    """The platform as a see-saw (the field file's [seesaw]; the whole game only)."""

    board_mass_kg: float = 4.0
    hinge_flat: float = 0.0508  # m: half the width of the hinge's flat surfaces
    balanced_tilt_deg: float = 3.0
    tilt_rate_deg_s: float = 45.0
    climb_edge: float = 0.0254  # m
    start_down: str = "field"  # "field", "wall" or "level"
    overhang: float = 0.0762  # m a robot's frame may hang over the board's edge


@dataclass(frozen=True)
class Zone:
    x0: float
    y0: float
    x1: float
    y1: float

    def contains(self, xy: np.ndarray, margin: float = 0.0) -> np.ndarray:
        """Points within the zone grown by `margin` (a disc of that radius touching it counts)."""
        p = np.asarray(xy, dtype=np.float64)
        return (
            (p[..., 0] >= self.x0 - margin)
            & (p[..., 0] <= self.x1 + margin)
            & (p[..., 1] >= self.y0 - margin)
            & (p[..., 1] <= self.y1 + margin)
        )

    def contains_point(self, x: float, y: float, margin: float = 0.0) -> bool:
        return (
            self.x0 - margin <= x <= self.x1 + margin and self.y0 - margin <= y <= self.y1 + margin
        )


@dataclass(frozen=True)
class StartSpec:
    alliance: AllianceName
    robot: str
    position: tuple[float, float]
    heading: float


@dataclass(frozen=True)
class RulesSpec:
    autonomous_s: float
    interaction_s: float
    pin_time_s: float
    endgame_s: float = 30.0  # <SG3>: the platforms are protected in the match's last seconds
    platform_foul_credit: int = 1  # Elevated robots credited to the opponent per <SG3> violation
    # <SG3>: the most Elevated robots (real and credited) an alliance scores; 0: no bound
    elevated_robots_max: int = 2
    isolation_contact_foul: bool = True  # robots of both alliances touching in isolation
    isolation_foul_forfeits: bool = True  # ... gives the opponent the bonus and the win point
    isolation_home_zone_foul: bool = False  # a robot in the opponent's home zone in isolation


@dataclass(frozen=True)
class ScoringSpec:
    ring_high_branch: int
    ring_branch: int
    ring_base: int
    goal_in_home_zone: int
    robot_elevated: int
    goal_elevated: int
    autonomous_bonus: int
    autonomous_bonus_tie: int = 10  # to each alliance when the autonomous period is a tie


@dataclass(frozen=True)
class FieldSpec:
    name: str
    season: str
    source: str
    size: float
    tile: float
    wall_height: float
    wall_thickness: float
    tile_rgb: RGB
    line_rgb: RGB
    wall_rgb: RGB
    lines: tuple[tuple[float, float, float, float], ...]
    ring: RingSpec
    ring_positions: np.ndarray  # (N, 2) rings on the field at the start
    match_load_spots: np.ndarray  # (M, 2) red's spots; blue's are their point mirror
    goals: tuple[GoalSpec, ...]
    platforms: tuple[PlatformSpec, ...]
    home_zones: dict[str, Zone]
    starts: tuple[StartSpec, ...]
    rules: RulesSpec
    scoring: ScoringSpec
    seesaw: SeesawSpec = SeesawSpec()
    # The AWP line of each alliance ([x0, y0, x1, y1]) and the goal that starts on it (its index).
    awp_lines: dict[str, tuple[float, float, float, float]] = field(default_factory=dict)
    awp_goals: dict[str, int] = field(default_factory=dict)

    @property
    def half(self) -> float:
        """Half the field width: the observation's length unit."""
        return self.size / 2.0

    @cached_property
    def goal_may_score(self) -> np.ndarray:
        """(G, 2) bool: whether each goal may score for red (column 0) and for blue (1): a
        neutral goal for both, an alliance goal for its own alliance only."""
        rows = [(g.alliance in (None, "red"), g.alliance in (None, "blue")) for g in self.goals]
        out = np.array(rows, dtype=bool).reshape(-1, 2)
        out.setflags(write=False)  # one array for every caller: nobody may change it
        return out

    @cached_property
    def goal_base_radii(self) -> np.ndarray:
        """(G,): each goal's base radius, metres."""
        out = np.array([g.base_radius for g in self.goals], dtype=np.float64)
        out.setflags(write=False)
        return out

    def platform(self, alliance: AllianceName) -> PlatformSpec:
        for p in self.platforms:
            if p.alliance == alliance:
                return p
        raise FieldError(f"field {self.name!r} has no {alliance} platform")

    def start(self, alliance: AllianceName, robot: str) -> StartSpec:
        for s in self.starts:
            if s.alliance == alliance and s.robot == robot:
                return s
        known = ", ".join(f"{s.alliance}/{s.robot}" for s in self.starts)
        raise FieldError(f"field {self.name!r} has no start for {alliance}/{robot} (has {known})")


def resolve_field_path(name_or_path: str | Path) -> Path:
    candidate = Path(name_or_path)
    if candidate.suffix == ".toml" or candidate.exists():
        if not candidate.is_file():
            raise FieldError(f"field file {candidate} does not exist")
        return candidate
    shipped = FIELD_DIR / f"{name_or_path}.toml"
    if not shipped.is_file():
        known = ", ".join(sorted(p.stem for p in FIELD_DIR.glob("*.toml")))
        raise FieldError(f"no field named {name_or_path!r} (shipped fields: {known})")
    return shipped


def load_field(name_or_path: str | Path = DEFAULT_FIELD) -> FieldSpec:
    path = resolve_field_path(name_or_path)
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise FieldError(f"{path}: not valid TOML: {e}") from e
    return parse_field(data, source=str(path))


class _Reader:
    """Typed access to the TOML tables with errors that name the file and the key."""

    def __init__(self, source: str, scale: float) -> None:
        self.source = source
        self.scale = scale

    def fail(self, key: str, problem: str) -> FieldError:
        return FieldError(f"{self.source}: {key}: {problem}")

    def table(self, data: dict[str, Any], key: str) -> dict[str, Any]:
        value = data.get(key)
        if not isinstance(value, dict):
            raise self.fail(key, "missing table")
        return value

    def number(self, data: dict[str, Any], key: str, where: str, *, length: bool = False) -> float:
        value = data.get(key)
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.fail(f"{where}.{key}", f"expected a number, got {value!r}")
        return float(value) * (self.scale if length else 1.0)

    def positive(
        self, data: dict[str, Any], key: str, where: str, *, length: bool = False
    ) -> float:
        value = self.number(data, key, where, length=length)
        if value <= 0:
            raise self.fail(f"{where}.{key}", f"must be positive, got {value}")
        return value

    def integer(self, data: dict[str, Any], key: str, where: str) -> int:
        value = data.get(key)
        if isinstance(value, bool) or not isinstance(value, int) or value < 0:
            raise self.fail(f"{where}.{key}", f"expected a non-negative integer, got {value!r}")
        return value

    def flag(self, data: dict[str, Any], key: str, where: str, default: bool) -> bool:
        value = data.get(key, default)
        if not isinstance(value, bool):
            raise self.fail(f"{where}.{key}", f"expected true or false, got {value!r}")
        return value

    def string(self, data: dict[str, Any], key: str, where: str) -> str:
        value = data.get(key)
        if not isinstance(value, str) or not value:
            raise self.fail(f"{where}.{key}", f"expected a non-empty string, got {value!r}")
        return value

    def alliance(self, data: dict[str, Any], key: str, where: str) -> AllianceName:
        value = data.get(key)
        if value not in ("red", "blue"):
            raise self.fail(f"{where}.{key}", f"expected 'red' or 'blue', got {value!r}")
        return value  # type: ignore[return-value]

    def rgb(self, data: dict[str, Any], key: str, where: str) -> RGB:
        value = data.get(key)
        if (
            not isinstance(value, list)
            or len(value) != 3
            or not all(
                isinstance(c, int) and not isinstance(c, bool) and 0 <= c <= 255 for c in value
            )
        ):
            raise self.fail(
                f"{where}.{key}", f"expected [r, g, b] with 0..255 integers, got {value!r}"
            )
        return (value[0], value[1], value[2])

    def points(self, value: Any, where: str, width: int = 2) -> np.ndarray:
        try:
            arr = np.asarray(value, dtype=np.float64)
        except (TypeError, ValueError) as e:
            raise self.fail(where, f"expected a list of [{width} numbers]: {e}") from e
        if arr.size == 0:
            return np.zeros((0, width))
        if arr.ndim != 2 or arr.shape[1] != width or not np.all(np.isfinite(arr)):
            raise self.fail(
                where, f"expected a list of {width}-number lists, got shape {arr.shape}"
            )
        return arr * self.scale

    def pair(self, data: dict[str, Any], key: str, where: str) -> tuple[float, float]:
        arr = self.points([data.get(key)], f"{where}.{key}")
        return (float(arr[0, 0]), float(arr[0, 1]))


def parse_field(data: dict[str, Any], source: str = "<field>") -> FieldSpec:
    units = data.get("units", "m")
    if units not in _UNITS:
        raise FieldError(f"{source}: units: expected one of {sorted(_UNITS)}, got {units!r}")
    r = _Reader(source, _UNITS[units])

    f = r.table(data, "field")
    size = r.positive(f, "size", "field", length=True)
    half = size / 2.0
    lines = tuple(
        tuple(float(v) for v in row) for row in r.points(f.get("lines", []), "field.lines", 4)
    )

    ring_t = r.table(data, "ring")
    ring = RingSpec(
        outer_diameter=r.positive(ring_t, "outer_diameter", "ring", length=True),
        inner_diameter=r.positive(ring_t, "inner_diameter", "ring", length=True),
        thickness=r.positive(ring_t, "thickness", "ring", length=True),
        mass_kg=r.positive(ring_t, "mass_kg", "ring"),
        rgb=r.rgb(ring_t, "rgb", "ring"),
        total=r.integer(ring_t, "total", "ring"),
        preloads_per_robot=r.integer(ring_t, "preloads_per_robot", "ring"),
        match_loads_per_alliance=r.integer(ring_t, "match_loads_per_alliance", "ring"),
    )
    if ring.inner_diameter >= ring.outer_diameter:
        raise r.fail("ring.inner_diameter", "must be smaller than outer_diameter")
    ring_positions = r.points(ring_t.get("positions"), "ring.positions")
    spots = r.points(ring_t.get("match_load_spots", []), "ring.match_load_spots")
    for where, pts in (("ring.positions", ring_positions), ("ring.match_load_spots", spots)):
        if pts.size and np.any(np.abs(pts) > half):
            raise r.fail(where, "a position lies outside the field")
    if len(ring_positions) > ring.total:
        raise r.fail("ring.positions", f"{len(ring_positions)} rings but total is {ring.total}")

    kinds = r.table(data, "goal_kinds")
    goals = []
    goal_list = data.get("goals")
    if not isinstance(goal_list, list) or not goal_list:
        raise FieldError(f"{source}: goals: expected a non-empty array of tables")
    for i, g in enumerate(goal_list):
        where = f"goals[{i}]"
        kind = r.string(g, "kind", where)
        if kind not in _GOAL_KINDS or kind not in kinds:
            raise r.fail(
                f"{where}.kind", f"expected one of {_GOAL_KINDS} with a [goal_kinds] entry"
            )
        k = kinds[kind]
        kw = f"goal_kinds.{kind}"
        alliance = r.alliance(g, "alliance", where) if kind == "alliance" else None
        rgb = r.rgb(k, f"{alliance}_rgb", kw) if alliance else r.rgb(k, "rgb", kw)
        pos = r.pair(g, "position", where)
        if max(abs(pos[0]), abs(pos[1])) > half:
            raise r.fail(f"{where}.position", "outside the field")
        goals.append(
            GoalSpec(
                name=r.string(g, "name", where),
                kind=kind,
                alliance=alliance,
                position=pos,
                base_radius=r.positive(k, "base_diameter", kw, length=True) / 2.0,
                base_height=r.positive(k, "base_height", kw, length=True),
                height=r.positive(k, "height", kw, length=True),
                mass_kg=r.positive(k, "mass_kg", kw),
                rgb=rgb,
                branch_capacity=r.integer(k, "branch_capacity", kw)
                if "branch_capacity" in k
                else 1 << 30,
                high_branch_capacity=r.integer(k, "high_branch_capacity", kw)
                if "high_branch_capacity" in k
                else 0,
            )
        )

    platforms = []
    for i, p in enumerate(data.get("platforms", [])):
        where = f"platforms[{i}]"
        size_xy = r.pair(p, "size", where)
        if min(size_xy) <= 0:
            raise r.fail(f"{where}.size", "must be positive")
        platforms.append(
            PlatformSpec(
                alliance=r.alliance(p, "alliance", where),
                center=r.pair(p, "center", where),
                size=size_xy,
                height=r.positive(p, "height", where, length=True),
                rgb=r.rgb(p, "rgb", where),
            )
        )

    zones_t = r.table(data, "zones")
    home_zones = {}
    for alliance in ("red", "blue"):
        arr = r.points([zones_t.get(f"{alliance}_home")], f"zones.{alliance}_home", 4)[0]
        x0, y0, x1, y1 = (float(v) for v in arr)
        if x1 <= x0 or y1 <= y0:
            raise r.fail(
                f"zones.{alliance}_home", "expected [x0, y0, x1, y1] with x0 < x1, y0 < y1"
            )
        home_zones[alliance] = Zone(x0, y0, x1, y1)
    awp_lines: dict[str, tuple[float, float, float, float]] = {}
    awp_goals: dict[str, int] = {}
    names = [g.name for g in goals]
    for alliance in ("red", "blue"):
        if f"{alliance}_awp_line" not in zones_t:
            continue
        line = r.points([zones_t[f"{alliance}_awp_line"]], f"zones.{alliance}_awp_line", 4)[0]
        awp_lines[alliance] = (float(line[0]), float(line[1]), float(line[2]), float(line[3]))
        goal = r.string(zones_t, f"{alliance}_awp_goal", "zones")
        if goal not in names:
            raise r.fail(f"zones.{alliance}_awp_goal", f"no goal named {goal!r}")
        awp_goals[alliance] = names.index(goal)

    seesaw = SeesawSpec()
    if "seesaw" in data:
        st = r.table(data, "seesaw")
        start_down = st.get("start_down", "field")
        if start_down not in ("field", "wall", "level"):
            raise r.fail("seesaw.start_down", f"expected field, wall or level, got {start_down!r}")
        seesaw = SeesawSpec(
            board_mass_kg=r.positive(st, "board_mass_kg", "seesaw"),
            hinge_flat=r.number(st, "hinge_flat", "seesaw", length=True),
            balanced_tilt_deg=r.positive(st, "balanced_tilt_deg", "seesaw"),
            tilt_rate_deg_s=r.positive(st, "tilt_rate_deg_s", "seesaw"),
            climb_edge=r.number(st, "climb_edge", "seesaw", length=True),
            start_down=start_down,
            overhang=r.number(st, "overhang", "seesaw", length=True) if "overhang" in st else 0.0,
        )

    starts = []
    for i, s in enumerate(data.get("starts", [])):
        where = f"starts[{i}]"
        starts.append(
            StartSpec(
                alliance=r.alliance(s, "alliance", where),
                robot=r.string(s, "robot", where),
                position=r.pair(s, "position", where),
                heading=r.number(s, "heading", where),
            )
        )
    if not starts:
        raise FieldError(f"{source}: starts: at least one robot start pose is needed")

    rules_t = r.table(data, "rules")
    defaults = RulesSpec(0.0, 1.0, 1.0)
    rules = RulesSpec(
        autonomous_s=r.number(rules_t, "autonomous_s", "rules"),
        interaction_s=r.positive(rules_t, "interaction_s", "rules"),
        pin_time_s=r.positive(rules_t, "pin_time_s", "rules"),
        endgame_s=r.number(rules_t, "endgame_s", "rules")
        if "endgame_s" in rules_t
        else defaults.endgame_s,
        platform_foul_credit=r.integer(rules_t, "platform_foul_credit", "rules")
        if "platform_foul_credit" in rules_t
        else defaults.platform_foul_credit,
        elevated_robots_max=r.integer(rules_t, "elevated_robots_max", "rules")
        if "elevated_robots_max" in rules_t
        else defaults.elevated_robots_max,
        isolation_contact_foul=r.flag(rules_t, "isolation_contact_foul", "rules", True),
        isolation_foul_forfeits=r.flag(rules_t, "isolation_foul_forfeits", "rules", True),
        isolation_home_zone_foul=r.flag(rules_t, "isolation_home_zone_foul", "rules", False),
    )
    sc = r.table(data, "scoring")
    scoring = ScoringSpec(
        **{
            key: r.integer(sc, key, "scoring")
            for key in (
                "ring_high_branch",
                "ring_branch",
                "ring_base",
                "goal_in_home_zone",
                "robot_elevated",
                "goal_elevated",
                "autonomous_bonus",
            )
        },
        autonomous_bonus_tie=r.integer(sc, "autonomous_bonus_tie", "scoring")
        if "autonomous_bonus_tie" in sc
        else r.integer(sc, "autonomous_bonus", "scoring") // 2,
    )
    return FieldSpec(
        name=r.string(data, "name", "<top>"),
        season=str(data.get("season", "")),
        source=source,
        size=size,
        tile=r.positive(f, "tile", "field", length=True),
        wall_height=r.positive(f, "wall_height", "field", length=True),
        wall_thickness=r.positive(f, "wall_thickness", "field", length=True),
        tile_rgb=r.rgb(f, "tile_rgb", "field"),
        line_rgb=r.rgb(f, "line_rgb", "field"),
        wall_rgb=r.rgb(f, "wall_rgb", "field"),
        lines=lines,  # type: ignore[arg-type]
        ring=ring,
        ring_positions=ring_positions,
        match_load_spots=spots,
        goals=tuple(goals),
        platforms=tuple(platforms),
        home_zones=home_zones,
        starts=tuple(starts),
        rules=rules,
        scoring=scoring,
        seesaw=seesaw,
        awp_lines=awp_lines,
        awp_goals=awp_goals,
    )
