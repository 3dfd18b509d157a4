"""Field descriptions: a season's field as data (one TOML file per field), loaded into metres.

    spec = load_field("tipping_point")        # a file shipped in sim/field/
    spec = load_field("path/to/my_field.toml")

Everything returned is in the GPS field frame (jetson/autonomy/geometry.py), in metres and
degrees. Bad files raise FieldError naming the file and the key at fault. Only numpy and the
standard library here.
"""

from __future__ import annotations

import tomllib
from dataclasses import dataclass
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


@dataclass(frozen=True)
class ScoringSpec:
    ring_high_branch: int
    ring_branch: int
    ring_base: int
    goal_in_home_zone: int
    robot_elevated: int
    goal_elevated: int
    autonomous_bonus: int


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

    @property
    def half(self) -> float:
        """Half the field width: the observation's length unit."""
        return self.size / 2.0

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
    rules = RulesSpec(
        autonomous_s=r.number(rules_t, "autonomous_s", "rules"),
        interaction_s=r.positive(rules_t, "interaction_s", "rules"),
        pin_time_s=r.positive(rules_t, "pin_time_s", "rules"),
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
        }
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
    )
