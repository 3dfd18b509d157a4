"""Deterministic evaluation: seeded matches between two players, with honest statistics.

    pete-sim eval --policy jetson/models/policy/ --opponent planner --matches 100 --seed 0

Players (`load_player`): a path to our policy.onnx (with policy.json beside it), a training
checkpoint (.pt) or run folder, `original:PATH` (the original team's ONNX through
sim.baselines.original; a bare path to it works too), `planner` (= planner-route),
`planner-nearest`, `planner-collector` (the route planner without its endgame: it collects to the
bell instead of parking, the stronger planner where only rings pay), `scripted`, `random`,
`idle`, and, as an opponent only, `none` (alone on the field).

Matches come in pairs on one seed, sides swapped (A red then A blue), so neither player gets the
better start more often. Scenarios:

    capped    the report's task: 5 points per ring for the first 10
    uncapped  every ring counts and the intake never fills: as many as the field holds

Every match records, per side, rings collected, the time the 10th ring came in (fill time),
match score, pins; the summary gives means with 95 % t-intervals, win rate (by match score)
with a Wilson interval, and the median fill time.

Worlds (`world`, sim.config.WORLD_PRESETS): the ring race (the default), or the whole game,
`tipping_point_1v1` / `tipping_point_2v2`. A side is one player for each of its alliance's robots,
or one player that drives every robot of it (each robot gets its own instance); a side's rings,
pins and fill time are its robots' together. In the whole game each match also records both
alliances' score by element (rings on high branches, low branches and bases, goals in the home
zone and elevated, robots elevated, the autonomous bonus and win point, Balanced) and their
fouls by kind, and the summary reports their means.
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable, Iterable, Sequence
from dataclasses import dataclass, field, replace
from functools import partial
from pathlib import Path
from typing import Any

import numpy as np

from jetson.autonomy.geometry import AllianceName, other_alliance
from jetson.autonomy.spec import ObservationSpec
from sim.baselines.planner import Planner, PlannerConfig
from sim.config import WORLD_PRESETS
from sim.errors import CheckpointError, ConfigError, EvalError
from sim.match import EnvConfig, MatchCore, make_config
from sim.players import IdlePlayer, Player, PolicyPlayer, RandomPlayer, ScriptedPlayer
from sim.world import rules
from sim.world.physics import World

# Start and ring jitter make seeds differ; training configs use the same values.
EVAL_WORLD: dict[str, Any] = {
    "start_jitter_m": 0.1,
    "start_jitter_deg": 10.0,
    "ring_jitter_m": 0.03,
}
SCENARIOS: dict[str, dict[str, Any]] = {
    "capped": {},
    # Every ring counts and the intake never fills: ring collection alone, as many as the field
    # holds (with a 10-ring intake, going past 10 is a question of handling mobile goals).
    "uncapped": {
        "world": {"robots": {"15in": {"ring_capacity": None}, "24in": {"ring_capacity": None}}},
        "reward": {"ring_cap": None},
    },
}
BUILTIN = (
    "planner",
    "planner-route",
    "planner-nearest",
    "planner-collector",
    "scripted",
    "random",
    "idle",
)
FILL_TARGET = 10
# A whole-game alliance's score by element (sim.world.state.AllianceScore), in the order the
# summaries print them; win point and balanced are yes/no, the rest counts.
ELEMENTS: tuple[tuple[str, str], ...] = (
    ("rings_high", "rings high branch"),
    ("rings_low", "rings low branches"),
    ("rings_base", "rings in bases"),
    ("goals_in_zone", "goals in home zone"),
    ("goals_elevated", "goals elevated"),
    ("robots_elevated", "robots elevated"),
    ("foul_credit", "robots credited"),
    ("autonomous_bonus", "autonomous bonus"),
    ("autonomous_win_point", "autonomous win pt"),
    ("balanced", "platform balanced"),
    ("fouls", "fouls"),
)
YES_NO = ("autonomous_win_point", "balanced")


@dataclass
class PlayerSpec:
    """How to make a player, and the observation spec it needs (learned policies only)."""

    label: str
    make: Callable[[], Player]
    spec: ObservationSpec | None = None


def registered_players() -> dict[str, Callable[[], Player]]:
    """The player classes sim.players exports under a class-level `name` that take no
    constructor arguments (idle, random, scripted, and whatever player is added there): each is
    a command-line player by that name."""
    import inspect

    import sim.players

    out: dict[str, Callable[[], Player]] = {}
    for obj in vars(sim.players).values():
        name = getattr(obj, "name", None) if inspect.isclass(obj) else None
        if not isinstance(name, str) or not callable(getattr(obj, "act", None)):
            continue
        try:
            needed = [
                q
                for q in inspect.signature(obj).parameters.values()
                if q.default is q.empty and q.kind not in (q.VAR_POSITIONAL, q.VAR_KEYWORD)
            ]
        except (TypeError, ValueError):
            continue
        if not needed:
            out.setdefault(name, obj)
    return out


def load_player(text: str) -> PlayerSpec:
    """A PlayerSpec from a command-line word (see the module docstring), or the name of a player
    class sim.players exports (registered_players)."""
    from sim.baselines.original import OriginalPlayer, looks_like_original

    word = text.strip()
    if word in ("planner", "planner-route"):
        return PlayerSpec("planner", lambda: Planner(PlannerConfig(strategy="route")))
    if word == "planner-nearest":
        return PlayerSpec("planner-nearest", lambda: Planner(PlannerConfig(strategy="nearest")))
    if word == "planner-collector":
        return PlayerSpec("planner-collector", lambda: Planner(PlannerConfig(endgame=False)))
    if word == "scripted":
        return PlayerSpec("scripted", ScriptedPlayer)
    if word == "random":
        return PlayerSpec("random", RandomPlayer)
    if word == "idle":
        return PlayerSpec("idle", IdlePlayer)
    if word.startswith("original:"):
        path = word.removeprefix("original:")
        OriginalPlayer(path)  # fail now, with the reason, not in the first match
        found = str(Path(path).resolve())  # the same file from another working directory
        return PlayerSpec("original", lambda: OriginalPlayer(found))
    registered = registered_players()
    if word in registered:
        return PlayerSpec(word, registered[word])
    path = Path(word)
    if path.is_dir():
        for candidate in (path / "policy.onnx", path / "policy" / "policy.onnx"):
            if candidate.is_file():
                path = candidate
                break
        else:
            raise EvalError(f"{path}: no policy.onnx in this folder")
    if not path.exists():
        names = list(BUILTIN) + sorted(set(registered) - set(BUILTIN))
        raise EvalError(
            f"unknown player {word!r}: not a file, nor one of {', '.join(names)}, original:PATH"
        )
    if path.suffix == ".onnx":
        if looks_like_original(path):
            found = path.resolve()
            return PlayerSpec("original", lambda: OriginalPlayer(found))
        from jetson.autonomy.policy import OnnxPolicy
        from jetson.errors import PolicyError

        try:
            policy = OnnxPolicy(path)
        except PolicyError as e:
            raise EvalError(str(e)) from e
        # The maker loads the file again (by its absolute path), so a PlayerSpec can travel to
        # another process (sim.training.ray_backend), which an onnxruntime session cannot.
        label = path.parent.name or path.stem
        if label in BUILTIN or label in registered:  # jetson/models/alliance/: not the script
            label = f"policy:{label}"
        return PlayerSpec(label, partial(onnx_player, path.resolve()), policy.spec)
    if path.suffix == ".pt":
        from sim.training.checkpoint import load_policy_fn

        try:
            fn, spec, skills = load_policy_fn(path)
        except CheckpointError as e:
            raise EvalError(str(e)) from e
        return PlayerSpec(path.stem, lambda: PolicyPlayer(fn, "ours", skills), spec)
    raise EvalError(f"{path}: expected a .onnx policy or a .pt checkpoint")


def onnx_player(path: Path) -> Player:
    """Our policy.onnx (policy.json beside it) as a player."""
    from jetson.autonomy.policy import OnnxPolicy

    policy = OnnxPolicy(path)
    return PolicyPlayer(policy, "ours", policy.skills)


def load_side(text: str) -> tuple[PlayerSpec, ...]:
    """A side's players from a command-line word: one player name (`load_player`) for every robot
    of the alliance, or one per robot in the world's order, comma-separated ("planner,scripted":
    the 24" robot the planner, the 15" one the scripted chaser in tipping_point_2v2)."""
    words = [w.strip() for w in text.split(",")]
    if not all(words):
        raise EvalError(f"empty player name in {text!r}: give NAME or NAME,NAME")
    return tuple(load_player(w) for w in words)


def side_label(side: PlayerSpec | Sequence[PlayerSpec]) -> str:
    """How a side reads in summaries: its player's label, or its robots' joined by '+'."""
    specs = (side,) if isinstance(side, PlayerSpec) else tuple(side)
    labels = [s.label for s in specs]
    return labels[0] if len(set(labels)) == 1 else "+".join(labels)


def world_env(world: str | None) -> dict[str, Any]:
    """The evaluation's env table for a WORLD_PRESETS name (None: the ring race), with the
    evaluation's jitter. In the whole game a pin is counted but does not end the match (the ring
    race's evaluation ends it, as the original team's environment did)."""
    if world is None:
        return {"world": EVAL_WORLD}
    if world not in WORLD_PRESETS:
        raise EvalError(f"world must be one of {', '.join(WORLD_PRESETS)}, got {world!r}")
    preset = WORLD_PRESETS[world]
    table: dict[str, Any] = {"world": {**EVAL_WORLD, **preset}}
    if preset.get("game", "ring_race") != "ring_race":
        table["end_on_pin"] = False
    return table


def element_breakdown(world: World) -> dict[str, dict[str, Any]]:
    """Each alliance's whole-game score by element (ELEMENTS, plus the total and its fouls by
    kind) as it stands."""
    score = world.score()
    out: dict[str, dict[str, Any]] = {}
    for alliance in rules.ALLIANCES:
        s = score[alliance]
        row: dict[str, Any] = {"total": s.total}
        for key, _ in ELEMENTS:
            row[key] = getattr(s, key)
        kinds: dict[str, int] = {}
        for f in world.fouls:
            if f.alliance == alliance:
                kinds[f.kind] = kinds.get(f.kind, 0) + 1
        row["fouls_by_kind"] = kinds
        out[alliance] = row
    return out


# --- one match -----------------------------------------------------------------------------------


@dataclass
class MatchRecord:
    seed: int
    a_alliance: str
    rings: tuple[int, int]  # (A, B)
    fill_time_s: tuple[float | None, float | None]
    score: tuple[float, float]
    pins: tuple[int, int]
    ended_by_pin: bool
    length_s: float
    # The whole game: (A's alliance, B's) score by element (element_breakdown); None in the race.
    breakdown: tuple[dict[str, Any], dict[str, Any]] | None = None
    # (A's, B's) collisions between the two robots of one alliance: each time partners that
    # were apart come into contact (World.touching); 0 for an alliance of one robot.
    partner_collisions: tuple[int, int] = (0, 0)

    @property
    def result(self) -> float:
        """A's result by match score: 1 win, 0.5 draw, 0 loss."""
        a, b = self.score
        return 1.0 if a > b else 0.5 if a == b else 0.0


def eval_env(
    scenario: str = "capped",
    fidelity: str = "training",
    spec: ObservationSpec | None = None,
    base: dict[str, Any] | None = None,
    world: str | None = None,
) -> EnvConfig:
    """The evaluation's EnvConfig: `base` (default: the evaluation's jitter in the `world` preset,
    the ring race when None), the scenario, the fidelity and a policy's observation spec."""
    if scenario not in SCENARIOS:
        raise EvalError(f"scenario must be one of {sorted(SCENARIOS)}, got {scenario!r}")
    if fidelity not in ("training", "high"):
        raise EvalError(f"fidelity must be training or high, got {fidelity!r}")
    if base is not None and world is not None:
        base = make_config(make_config(base), **world_env(world))  # type: ignore[assignment]
    cfg = make_config(base or world_env(world))
    cfg = make_config(cfg, **SCENARIOS[scenario])
    cfg = make_config(cfg, world={"fidelity": fidelity})
    if spec is not None:
        cfg = replace(cfg, observation=spec)
    return cfg


def _seat(side: Player | Sequence[Player], robots: list[int], alliance: str) -> dict[int, Player]:
    """Robot index -> player: one player per robot of the alliance, in the world's order."""
    players = list(side) if isinstance(side, Sequence) else [side]
    if len(players) != len(robots):
        raise EvalError(
            f"{alliance} has {len(robots)} robot(s) but {len(players)} player(s): give one "
            "player per robot (one name on the command line plays every robot of an alliance)"
        )
    return dict(zip(robots, players, strict=True))


def play_match(
    cores: dict[str, MatchCore],
    a: Player | Sequence[Player],
    b: Player | Sequence[Player] | None,
    seed: int,
    a_alliance: str,
    stop_when_filled: bool = False,
    on_step: Callable[[MatchCore, list[Any]], None] | None = None,
) -> MatchRecord:
    """One seeded match: A on `a_alliance`, B (None: nobody) on the other side; a side is a player
    for its alliance's one robot, or a sequence of one player per robot.

    stop_when_filled ends the match once every side's robots have FILL_TARGET rings together
    (fill times are all that is wanted then)."""
    core = cores["solo-" + a_alliance] if b is None else cores["duel"]
    rng = np.random.default_rng(seed)
    obs = core.reset(rng)
    lineup = core.world.lineup
    mine = [i for i, (al, _) in enumerate(lineup) if al == a_alliance]
    theirs = [i for i, (al, _) in enumerate(lineup) if al != a_alliance]
    players = _seat(a, mine, a_alliance)
    sides = [mine]
    if b is not None and theirs:
        players.update(_seat(b, theirs, other_alliance(a_alliance)))  # type: ignore[arg-type]
        sides.append(theirs)
    # Each player draws from its own stream: A's noise never depends on B.
    for i, p in players.items():
        p.reset(core, i, np.random.default_rng((seed, i)))
    fill: list[float | None] = [None] * len(sides)
    partners = [[(i, j) for i in robots for j in robots if i < j] for robots in sides]
    in_contact: set[tuple[int, int]] = set()
    collisions = [0] * len(sides)
    while True:
        commands = [players[i].act(core, i, obs[i]) for i in range(len(lineup))]
        results, ended, _ = core.step(commands)
        obs = [r.observation for r in results]
        if on_step is not None:
            on_step(core, results)
        for k, pairs in enumerate(partners):
            for pair in pairs:
                if core.world.touching(*pair):
                    collisions[k] += pair not in in_contact
                    in_contact.add(pair)
                else:
                    in_contact.discard(pair)
        for k, robots in enumerate(sides):
            collected = sum(core.world.robots[i].collected for i in robots)
            if fill[k] is None and collected >= FILL_TARGET:
                fill[k] = core.world.time_s
        limit = core.config.max_steps
        if ended or (limit is not None and core.world.steps >= limit):
            break
        if stop_when_filled and all(v is not None for v in fill):
            break
    world = core.world
    score = world.score()
    opp: AllianceName = other_alliance(a_alliance)  # type: ignore[arg-type]
    sa = float(score[a_alliance].total)  # type: ignore[index]
    sb = float(score[opp].total)
    opponents = sides[1] if len(sides) > 1 else []
    breakdown = None
    if rules.whole_game(world):
        by_alliance = element_breakdown(world)
        breakdown = (by_alliance[a_alliance], by_alliance[opp])
    return MatchRecord(
        seed=seed,
        a_alliance=a_alliance,
        rings=(
            sum(world.robots[i].collected for i in mine),
            sum(world.robots[i].collected for i in opponents),
        ),
        fill_time_s=(fill[0], fill[1] if len(fill) > 1 else None),
        score=(sa, sb),
        pins=(sum(core.pins[i] for i in mine), sum(core.pins[i] for i in opponents)),
        ended_by_pin=core.ended_by_pin,
        length_s=world.time_s,
        breakdown=breakdown,
        partner_collisions=(collisions[0], collisions[1] if len(collisions) > 1 else 0),
    )


def make_cores(env: EnvConfig) -> dict[str, MatchCore]:
    """The worlds an evaluation needs: a 1v1 one and one per side with no opponent."""
    cores = {"duel": MatchCore(env)}
    for alliance in ("red", "blue"):
        wc = replace(env.world, **{other_alliance(alliance): ()})  # type: ignore[arg-type]
        cores["solo-" + alliance] = MatchCore(env, wc)
    return cores


# --- statistics ----------------------------------------------------------------------------------

# Two-sided 95 % Student t critical values by degrees of freedom; 1.96 beyond the table.
_T95 = {1: 12.706, 2: 4.303, 3: 3.182, 4: 2.776, 5: 2.571, 6: 2.447, 7: 2.365, 8: 2.306,
        9: 2.262, 10: 2.228, 12: 2.179, 15: 2.131, 20: 2.086, 25: 2.060, 30: 2.042, 40: 2.021,
        60: 2.000, 120: 1.980}  # fmt: skip


def t95(df: int) -> float:
    if df < 1:
        return math.nan
    keys = sorted(k for k in _T95 if k <= df)
    return _T95[keys[-1]] if df <= 120 else 1.96


@dataclass(frozen=True)
class Stat:
    mean: float
    half_width: float  # 95 % interval: mean +- half_width
    n: int

    def __str__(self) -> str:
        return f"{self.mean:.2f} +- {self.half_width:.2f}"


def mean_ci(values: list[float]) -> Stat:
    n = len(values)
    if n == 0:
        return Stat(math.nan, math.nan, 0)
    m = statistics.fmean(values)
    if n == 1:
        return Stat(m, math.nan, 1)
    return Stat(m, t95(n - 1) * statistics.stdev(values) / math.sqrt(n), n)


def wilson(successes: float, n: int) -> tuple[float, float]:
    """95 % Wilson score interval of a proportion (draws count as half a success)."""
    if n == 0:
        return (math.nan, math.nan)
    z = 1.96
    p = successes / n
    centre = (p + z * z / (2 * n)) / (1 + z * z / n)
    half = z * math.sqrt(p * (1 - p) / n + z * z / (4 * n * n)) / (1 + z * z / n)
    return (max(0.0, centre - half), min(1.0, centre + half))


@dataclass
class Summary:
    a: str
    b: str
    scenario: str
    fidelity: str
    matches: list[MatchRecord] = field(default_factory=list)
    world: str = "ring_race"

    def side(self, k: int) -> dict[str, Any]:
        m = self.matches
        fills = [r.fill_time_s[k] for r in m]
        filled = [f for f in fills if f is not None]
        return {
            "rings": mean_ci([float(r.rings[k]) for r in m]),
            "score": mean_ci([r.score[k] for r in m]),
            "pins": mean_ci([float(r.pins[k]) for r in m]),
            "fill_rate": len(filled) / len(m) if m else math.nan,
            "fill_median_s": statistics.median(filled) if filled else math.nan,
            "partner_collisions": mean_ci([float(r.partner_collisions[k]) for r in m]),
        }

    @property
    def whole_game(self) -> bool:
        return any(r.breakdown is not None for r in self.matches)

    def elements(self, k: int) -> dict[str, Any]:
        """Side k's whole-game score by element over the matches: the mean (95 % interval) of
        each count, the share of matches with the win point and Balanced, fouls by kind per
        match."""
        rows = [r.breakdown[k] for r in self.matches if r.breakdown is not None]
        out: dict[str, Any] = {}
        for key, _ in ELEMENTS:
            values = [float(row[key]) for row in rows]
            out[key] = statistics.fmean(values) if key in YES_NO else mean_ci(values)
        kinds = sorted({kind for row in rows for kind in row["fouls_by_kind"]})
        out["fouls_by_kind"] = {
            kind: statistics.fmean(row["fouls_by_kind"].get(kind, 0) for row in rows)
            for kind in kinds
        }
        return out

    @property
    def wins(self) -> int:
        return sum(1 for r in self.matches if r.result == 1.0)

    @property
    def draws(self) -> int:
        return sum(1 for r in self.matches if r.result == 0.5)

    @property
    def win_rate(self) -> float:
        """A's wins / matches (a draw is not a win)."""
        return self.wins / len(self.matches) if self.matches else math.nan

    def as_dict(self) -> dict[str, Any]:
        def plain(d: dict[str, Any]) -> dict[str, Any]:
            out: dict[str, Any] = {}
            for k, v in d.items():
                if isinstance(v, Stat):
                    out[k] = {"mean": v.mean, "ci95": v.half_width}
                else:
                    out[k] = v
            return out

        lo, hi = wilson(self.wins, len(self.matches))
        out = {
            "a": self.a,
            "b": self.b,
            "scenario": self.scenario,
            "fidelity": self.fidelity,
            "matches": len(self.matches),
            "a_stats": plain(self.side(0)),
            "b_stats": plain(self.side(1)),
            "a_wins": self.wins,
            "draws": self.draws,
            "a_win_rate": self.win_rate,
            "a_win_rate_ci95": [lo, hi],
        }
        if self.whole_game:  # the ring race's summary stays as it was
            out["world"] = self.world
            out["a_elements"] = plain(self.elements(0))
            out["b_elements"] = plain(self.elements(1))
            out["per_match"] = [
                {
                    "seed": r.seed,
                    "a_alliance": r.a_alliance,
                    "score": list(r.score),
                    "a": r.breakdown[0],
                    "b": r.breakdown[1],
                }
                for r in self.matches
                if r.breakdown is not None
            ]
        return out

    def table(self) -> str:
        sa, sb = self.side(0), self.side(1)
        lo, hi = wilson(self.wins, len(self.matches))
        rows = [
            ("", self.a, self.b),
            ("rings", str(sa["rings"]), str(sb["rings"])),
            ("score", str(sa["score"]), str(sb["score"])),
            ("pins", str(sa["pins"]), str(sb["pins"])),
            (f"filled {FILL_TARGET}", f"{sa['fill_rate']:.0%}", f"{sb['fill_rate']:.0%}"),
            ("median fill s", f"{sa['fill_median_s']:.2f}", f"{sb['fill_median_s']:.2f}"),
        ]
        if self.whole_game:
            rows.append(
                ("partner collisions", str(sa["partner_collisions"]), str(sb["partner_collisions"]))
            )
            ea, eb = self.elements(0), self.elements(1)
            for key, name in ELEMENTS:
                if key in YES_NO:
                    rows.append((name, f"{ea[key]:.0%}", f"{eb[key]:.0%}"))
                else:
                    rows.append((name, str(ea[key]), str(eb[key])))
            for kind in sorted(set(ea["fouls_by_kind"]) | set(eb["fouls_by_kind"])):
                a_k = ea["fouls_by_kind"].get(kind, 0.0)
                b_k = eb["fouls_by_kind"].get(kind, 0.0)
                rows.append((f"  {kind}", f"{a_k:.2f}", f"{b_k:.2f}"))
        w0 = max(len(r[0]) for r in rows)
        w1 = max(len(r[1]) for r in rows)
        lines = [f"{r[0]:<{w0}}  {r[1]:>{w1}}  {r[2]}" for r in rows]
        n = len(self.matches)
        world = f"{self.world}, " if self.whole_game else ""
        lines.append(
            f"{self.a} wins {self.wins}/{n} ({self.win_rate:.0%}, 95 % CI {lo:.0%}-{hi:.0%}), "
            f"draws {self.draws}; {world}{self.scenario}, {self.fidelity} fidelity, "
            "means +- 95 % CI"
        )
        if self.whole_game:
            lines.append(
                "by element: counts at the end of a match (robots credited: for the opponent's "
                "platform fouls), points for the bonus; win point and balanced: share of "
                "matches; fouls: a match, by kind below"
            )
        return "\n".join(lines)


class _Side:
    """A side's players, made once per alliance size and reset every match: one instance for
    each robot of the alliance (its own spec each, or the one spec for all)."""

    def __init__(self, specs: tuple[PlayerSpec, ...]) -> None:
        self.specs = specs
        self._made: dict[int, list[Player]] = {}

    def players(self, robots: int) -> list[Player]:
        if robots not in self._made:
            if len(self.specs) == 1:
                self._made[robots] = [self.specs[0].make() for _ in range(robots)]
            elif len(self.specs) == robots:
                self._made[robots] = [s.make() for s in self.specs]
            else:
                names = ",".join(s.label for s in self.specs)
                raise EvalError(
                    f"{len(self.specs)} players ({names}) for an alliance of {robots} robot(s): "
                    "give one name for all its robots, or one per robot"
                )
        return self._made[robots]


def _specs(side: PlayerSpec | Sequence[PlayerSpec]) -> tuple[PlayerSpec, ...]:
    specs = (side,) if isinstance(side, PlayerSpec) else tuple(side)
    if not specs:
        raise EvalError("a side needs at least one player")
    return specs


@dataclass(frozen=True)
class Series:
    """The matches of one evaluation. Match k depends on nothing but these fields and k (A on red
    for even k, on blue for odd k, seed + k // 2), so any subset of them can be played in any
    process: here (`play_here`) or as Ray tasks (sim.training.ray_backend)."""

    a: tuple[PlayerSpec, ...]
    b: tuple[PlayerSpec, ...] | None  # None: A alone on the field
    env: EnvConfig
    seed: int
    stop_when_filled: bool = False

    def play(
        self, ks: Iterable[int], progress: Callable[[int], None] | None = None
    ) -> list[MatchRecord]:
        """Matches ks, in order; progress(n) after the n-th."""
        try:
            cores = make_cores(self.env)
        except (ConfigError, ValueError) as e:
            raise EvalError(str(e)) from e
        pa = _Side(self.a)
        pb = _Side(self.b) if self.b is not None else None
        lineup = cores["duel"].world.lineup
        counts = {al: sum(1 for x, _ in lineup if x == al) for al in ("red", "blue")}
        records: list[MatchRecord] = []
        try:
            for k in ks:
                alliance = "red" if k % 2 == 0 else "blue"
                other = other_alliance(alliance)  # type: ignore[arg-type]
                players_b = pb.players(counts[other]) if pb is not None else None
                records.append(
                    play_match(
                        cores,
                        pa.players(counts[alliance]),
                        players_b,
                        self.seed + k // 2,
                        alliance,
                        self.stop_when_filled,
                    )
                )
                if progress is not None:
                    progress(len(records))
        finally:
            for core in cores.values():
                core.close()
        return records


# Plays matches 0 ... n - 1 of a Series and returns their records in order, calling
# progress(done, n) as they finish: where an evaluation's matches run.
SeriesRunner = Callable[[Series, int, Callable[[int, int], None] | None], list[MatchRecord]]


def play_here(
    series: Series, matches: int, progress: Callable[[int, int], None] | None = None
) -> list[MatchRecord]:
    """The matches one after another in this process (evaluate's default runner)."""
    done = None if progress is None else (lambda n: progress(n, matches))
    return series.play(range(matches), done)


def evaluate(
    a: PlayerSpec | Sequence[PlayerSpec],
    b: PlayerSpec | Sequence[PlayerSpec] | None,
    matches: int,
    seed: int,
    scenario: str = "capped",
    fidelity: str = "training",
    stop_when_filled: bool = False,
    base_env: dict[str, Any] | None = None,
    progress: Callable[[int, int], None] | None = None,
    world: str | None = None,
    runner: SeriesRunner | None = None,
) -> Summary:
    """`matches` seeded matches of A against B (None: A alone), sides alternating per seed, in
    the `world` preset (None: the ring race). A side is one PlayerSpec for all its alliance's
    robots, or one per robot. runner: where the matches are played (default: here, one after
    another; sim.training.ray_backend.RayBackend.play: as Ray tasks over a cluster); the
    records are the same either way."""
    if matches < 1:
        raise EvalError(f"matches must be at least 1, got {matches}")
    side_a = _specs(a)
    side_b = _specs(b) if b is not None else ()
    specs = [s.spec for s in side_a + side_b if s.spec is not None]
    if len({s.fingerprint() for s in specs}) > 1:
        raise EvalError("the two policies expect different observations; evaluate each alone")
    try:
        env = eval_env(scenario, fidelity, specs[0] if specs else None, base_env, world)
    except (ConfigError, ValueError) as e:
        raise EvalError(str(e)) from e
    series = Series(side_a, side_b if b is not None else None, env, seed, stop_when_filled)
    summary = Summary(
        side_label(side_a),
        "nobody" if b is None else side_label(side_b),
        scenario,
        fidelity,
        world=world or "ring_race",
    )
    summary.matches.extend((runner or play_here)(series, matches, progress))
    return summary
