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
"""

from __future__ import annotations

import math
import statistics
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from jetson.autonomy.geometry import other_alliance
from jetson.autonomy.spec import ObservationSpec
from sim.baselines.planner import Planner, PlannerConfig
from sim.errors import CheckpointError, ConfigError, EvalError
from sim.match import EnvConfig, MatchCore, make_config
from sim.players import IdlePlayer, Player, PolicyPlayer, RandomPlayer, ScriptedPlayer

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


@dataclass
class PlayerSpec:
    """How to make a player, and the observation spec it needs (learned policies only)."""

    label: str
    make: Callable[[], Player]
    spec: ObservationSpec | None = None


def load_player(text: str) -> PlayerSpec:
    """A PlayerSpec from a command-line word (see the module docstring)."""
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
        return PlayerSpec("original", lambda: OriginalPlayer(path))
    path = Path(word)
    if path.is_dir():
        for candidate in (path / "policy.onnx", path / "policy" / "policy.onnx"):
            if candidate.is_file():
                path = candidate
                break
        else:
            raise EvalError(f"{path}: no policy.onnx in this folder")
    if not path.exists():
        raise EvalError(
            f"unknown player {word!r}: not a file, nor one of {', '.join(BUILTIN)}, original:PATH"
        )
    if path.suffix == ".onnx":
        if looks_like_original(path):
            return PlayerSpec("original", lambda: OriginalPlayer(path))
        from jetson.autonomy.policy import OnnxPolicy
        from jetson.errors import PolicyError

        try:
            policy = OnnxPolicy(path)
        except PolicyError as e:
            raise EvalError(str(e)) from e
        skills = policy.skills
        return PlayerSpec(
            path.parent.name or path.stem,
            lambda: PolicyPlayer(policy, "ours", skills),
            policy.spec,
        )
    if path.suffix == ".pt":
        from sim.training.checkpoint import load_policy_fn

        try:
            fn, spec, skills = load_policy_fn(path)
        except CheckpointError as e:
            raise EvalError(str(e)) from e
        return PlayerSpec(path.stem, lambda: PolicyPlayer(fn, "ours", skills), spec)
    raise EvalError(f"{path}: expected a .onnx policy or a .pt checkpoint")


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
) -> EnvConfig:
    if scenario not in SCENARIOS:
        raise EvalError(f"scenario must be one of {sorted(SCENARIOS)}, got {scenario!r}")
    if fidelity not in ("training", "high"):
        raise EvalError(f"fidelity must be training or high, got {fidelity!r}")
    cfg = make_config(base or {"world": EVAL_WORLD})
    cfg = make_config(cfg, **SCENARIOS[scenario])
    cfg = make_config(cfg, world={"fidelity": fidelity})
    if spec is not None:
        cfg = replace(cfg, observation=spec)
    return cfg


def play_match(
    cores: dict[str, MatchCore],
    a: Player,
    b: Player | None,
    seed: int,
    a_alliance: str,
    stop_when_filled: bool = False,
    on_step: Callable[[MatchCore, list[Any]], None] | None = None,
) -> MatchRecord:
    """One seeded match: A on `a_alliance`, B (None: nobody) on the other side.

    stop_when_filled ends the match once every robot has FILL_TARGET rings (fill times are all
    that is wanted then)."""
    core = cores["solo-" + a_alliance] if b is None else cores["duel"]
    rng = np.random.default_rng(seed)
    obs = core.reset(rng)
    lineup = core.world.lineup
    ia = next(i for i, (al, _) in enumerate(lineup) if al == a_alliance)
    ib = next((i for i, (al, _) in enumerate(lineup) if al != a_alliance), None)
    players: dict[int, Player] = {ia: a}
    if b is not None and ib is not None:
        players[ib] = b
    # Each player draws from its own stream: A's noise never depends on B.
    for i, p in players.items():
        p.reset(core, i, np.random.default_rng((seed, i)))
    fill: dict[int, float | None] = dict.fromkeys(players)
    while True:
        commands = [players[i].act(core, i, obs[i]) for i in range(len(lineup))]
        results, ended, _ = core.step(commands)
        obs = [r.observation for r in results]
        if on_step is not None:
            on_step(core, results)
        for i in players:
            if fill[i] is None and core.world.robots[i].collected >= FILL_TARGET:
                fill[i] = core.world.time_s
        limit = core.config.max_steps
        if ended or (limit is not None and core.world.steps >= limit):
            break
        if stop_when_filled and all(v is not None for v in fill.values()):
            break
    world = core.world
    score = world.score()
    sa = float(score[a_alliance].total)  # type: ignore[index]
    sb = float(score[other_alliance(a_alliance)].total)  # type: ignore[arg-type]
    rb = world.robots[ib].collected if ib is not None and b is not None else 0
    return MatchRecord(
        seed=seed,
        a_alliance=a_alliance,
        rings=(world.robots[ia].collected, rb),
        fill_time_s=(fill[ia], fill.get(ib) if ib is not None else None),
        score=(sa, sb),
        pins=(core.pins[ia], core.pins[ib] if ib is not None and b is not None else 0),
        ended_by_pin=core.ended_by_pin,
        length_s=world.time_s,
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
        }

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
        return {
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
        w0 = max(len(r[0]) for r in rows)
        w1 = max(len(r[1]) for r in rows)
        lines = [f"{r[0]:<{w0}}  {r[1]:>{w1}}  {r[2]}" for r in rows]
        n = len(self.matches)
        lines.append(
            f"{self.a} wins {self.wins}/{n} ({self.win_rate:.0%}, 95 % CI {lo:.0%}-{hi:.0%}), "
            f"draws {self.draws}; {self.scenario}, {self.fidelity} fidelity, means +- 95 % CI"
        )
        return "\n".join(lines)


def evaluate(
    a: PlayerSpec,
    b: PlayerSpec | None,
    matches: int,
    seed: int,
    scenario: str = "capped",
    fidelity: str = "training",
    stop_when_filled: bool = False,
    base_env: dict[str, Any] | None = None,
    progress: Callable[[int, int], None] | None = None,
) -> Summary:
    """`matches` seeded matches of A against B (None: A alone), sides alternating per seed."""
    if matches < 1:
        raise EvalError(f"matches must be at least 1, got {matches}")
    specs = [s.spec for s in (a, b) if s is not None and s.spec is not None]
    if len({s.fingerprint() for s in specs}) > 1:
        raise EvalError("the two policies expect different observations; evaluate each alone")
    try:
        env = eval_env(scenario, fidelity, specs[0] if specs else None, base_env)
        cores = make_cores(env)
    except (ConfigError, ValueError) as e:
        raise EvalError(str(e)) from e
    summary = Summary(a.label, "nobody" if b is None else b.label, scenario, fidelity)
    pa = a.make()
    pb = b.make() if b is not None else None
    try:
        for k in range(matches):
            alliance = "red" if k % 2 == 0 else "blue"
            summary.matches.append(
                play_match(cores, pa, pb, seed + k // 2, alliance, stop_when_filled)
            )
            if progress is not None:
                progress(k + 1, matches)
    finally:
        for core in cores.values():
            core.close()
    return summary
