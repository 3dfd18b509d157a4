"""Hyperparameter sweeps with Ray Tune (`pete-sim sweep`).

    pete-sim sweep --config tiny --param ppo.learning_rate=1e-3,5e-4 --param ppo.ent_coef=0,0.01

Each `--param KEY=VALUES` names a config key as the TOML file spells it (`ppo.learning_rate`,
`rollout.envs_per_worker`, `env.reward.ring`, `seed`) and what it takes:

    1e-3,5e-4,2e-4         a grid: every value (TOML values: numbers, true, "text", [32, 32])
    loguniform:1e-4:1e-2   drawn per trial (also uniform:LO:HI, randint:LO:HI)
    2                      one value: an override for every trial

Tune runs the trials: the grid's every combination, --samples times (the draws differ per sample;
a grid repeats, so give `--param seed=1,2` to repeat it on other seeds), as many at once as the
cluster has CPUs for (one trial holds max(1, rollout.workers) CPUs: its rollout workers are
processes on the trial's node), scheduled by Tune's FIFO or ASHA scheduler. Each trial is
`sim.training.trainer.train` on the config with its overrides, writing an ordinary run folder
(RUN/trials/<trial id>/), and reports to Tune at every periodic evaluation ([evaluation]
every_steps) and once at its end, where it evaluates the final policy itself when the last
iteration did not: the trainer's eval/* scalars and eval/quality, the score best.pt is chosen by.
What is ours is the parsing of --param, the trial function and the summary; search, scheduling,
placement and the trials' bookkeeping are Tune's (RUN/tune/).
"""

from __future__ import annotations

import json
import math
import tomllib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Literal

from sim.errors import ConfigError
from sim.training.config import TrainConfig, parse_config, resolve_config_path

DISTRIBUTIONS = ("uniform", "loguniform", "randint")
DEFAULT_METRIC = "eval/quality"
SUMMARY = "sweep.json"
Mode = Literal["max", "min"]


@dataclass(frozen=True)
class SweepParam:
    """One --param: a grid of values, or a distribution to draw from, or one value."""

    key: str  # dotted, as in the TOML file: ppo.learning_rate
    values: tuple[Any, ...] = ()
    distribution: tuple[str, float, float] | None = None  # (kind, low, high)

    @property
    def fixed(self) -> bool:
        return self.distribution is None and len(self.values) == 1

    def domain(self, tune: Any) -> Any:
        """What Tune's param_space takes for it."""
        if self.distribution is not None:
            kind, low, high = self.distribution
            if kind == "randint":
                return tune.randint(int(low), int(high) + 1)  # both ends included
            return getattr(tune, kind)(low, high)
        if self.fixed:
            return self.values[0]
        return tune.grid_search(list(self.values))

    def corners(self) -> tuple[Any, ...]:
        """Values every trial's could lie between: what is checked before Tune starts."""
        if self.distribution is not None:
            kind, low, high = self.distribution
            return (int(low), int(high)) if kind == "randint" else (low, high)
        return self.values


def _split_top(text: str) -> list[str]:
    """Split at commas outside brackets and quotes: "[32, 32],[64, 64]" is two values."""
    parts, depth, quote, start = [], 0, "", 0
    for i, c in enumerate(text):
        if quote:
            quote = "" if c == quote else quote
        elif c in "\"'":
            quote = c
        elif c in "[{":
            depth += 1
        elif c in "]}":
            depth -= 1
        elif c == "," and depth == 0:
            parts.append(text[start:i])
            start = i + 1
    parts.append(text[start:])
    return [p.strip() for p in parts]


def _value(text: str) -> Any:
    """A TOML value (1e-3, true, [32, 32], "planner"); a bare word is a string."""
    try:
        return tomllib.loads(f"v = {text}")["v"]
    except tomllib.TOMLDecodeError:
        return text


def parse_param(text: str) -> SweepParam:
    """A SweepParam from KEY=VALUES (see the module docstring)."""
    key, sep, values = text.partition("=")
    key = key.strip()
    if not sep or not key or not values.strip():
        raise ConfigError(
            f"--param {text!r}: expected KEY=VALUES, e.g. ppo.learning_rate=1e-3,5e-4 or "
            "ppo.learning_rate=loguniform:1e-4:1e-2"
        )
    kind, _, bounds = values.strip().partition(":")
    if kind in DISTRIBUTIONS:
        try:
            low, high = (float(b) for b in bounds.split(":"))
        except ValueError as e:
            raise ConfigError(f"--param {text!r}: expected {kind}:LOW:HIGH") from e
        if not low < high or (kind == "loguniform" and low <= 0):
            raise ConfigError(f"--param {text!r}: need 0 < LOW < HIGH for loguniform, LOW < HIGH")
        return SweepParam(key, distribution=(kind, low, high))
    items = _split_top(values)
    if not all(items):
        raise ConfigError(f"--param {text!r}: an empty value")
    return SweepParam(key, values=tuple(_value(v) for v in items))


def with_overrides(data: dict[str, Any], overrides: dict[str, Any]) -> dict[str, Any]:
    """The TOML document `data` with dotted keys set (tables created where missing)."""
    out = json.loads(json.dumps(data))  # a deep copy of plain TOML data
    for dotted, value in overrides.items():
        *tables, last = dotted.split(".")
        node = out
        for name in tables:
            child = node.setdefault(name, {})
            if not isinstance(child, dict):
                raise ConfigError(f"--param {dotted}: {name} is a value, not a table")
            node = child
        node[last] = value
    return out


def trial_config(data: dict[str, Any], overrides: dict[str, Any], where: str) -> TrainConfig:
    """The TrainConfig of one trial: the file's document with the trial's values, checked as a
    file is (an unknown key or a bad value names the key)."""
    return parse_config(with_overrides(data, overrides), f"{where} with {overrides}")


@dataclass(frozen=True)
class SweepOptions:
    config: str  # a TOML file, or the name of one in sim/configs/
    params: tuple[SweepParam, ...]
    run_dir: Path
    samples: int = 1
    metric: str = DEFAULT_METRIC
    mode: Mode = "max"
    scheduler: Literal["fifo", "asha"] = "fifo"
    steps: int | None = None  # overrides total_steps in every trial
    max_concurrent: int = 0  # 0: as many as the cluster has CPUs for
    verbose: int = 1  # Tune's console output: 0 silent, 1 a status table now and then

    def __post_init__(self) -> None:
        if self.samples < 1 or self.max_concurrent < 0:
            raise ConfigError("--samples must be >= 1 and --max-concurrent >= 0")
        if self.steps is not None and self.steps < 1:
            raise ConfigError("--steps must be >= 1")
        if self.mode not in ("max", "min"):
            raise ConfigError(f"--mode must be max or min, got {self.mode!r}")
        keys = [p.key for p in self.params]
        if len(set(keys)) != len(keys):
            raise ConfigError(f"--param: a key given twice in {keys}")


def _finite(stats: dict[str, float]) -> dict[str, float]:
    return {k: float(v) for k, v in stats.items() if math.isfinite(v)}


def run_trial(
    params: dict[str, Any], *, data: dict[str, Any], where: str, root: str, steps: int | None
) -> None:
    """One Tune trial: train the config with the trial's values, report its evaluations."""
    from dataclasses import replace

    from ray import tune

    from sim.training.trainer import Progress, evaluate_agent, quality, train

    cfg = trial_config(data, params, where)
    if steps is not None:
        cfg = replace(cfg, total_steps=steps)
    ev_cfg = cfg.evaluation
    run_dir = Path(root) / "trials" / tune.get_context().get_trial_id()

    def report(p: Progress) -> bool:
        ev = {k: v for k, v in p.stats.items() if k.startswith("eval/")}
        if not ev and p.step >= cfg.total_steps:  # the end: evaluate the final policy
            skills = cfg.at_step(p.step).env_config().skills
            ev = evaluate_agent(
                p.agent, p.spec, ev_cfg.opponent, ev_cfg.matches, ev_cfg.seed, skills
            )
        if ev:
            metrics = {**_finite(p.stats), **ev, "eval/quality": quality(ev)}
            tune.report({**metrics, "step": p.step, "iteration": p.iteration})
        return False

    train(cfg, run_dir, progress=False, callback=report)


@dataclass
class TrialRow:
    trial: str
    params: dict[str, Any]
    status: str  # done, or error
    metric: float | None
    step: int | None
    run_dir: str
    error: str | None = None


@dataclass
class SweepResult:
    options: SweepOptions
    rows: list[TrialRow]
    best: TrialRow | None
    summary: Path

    def table(self) -> str:
        keys = [p.key for p in self.options.params if not p.fixed]
        head = ["trial", *keys, self.options.metric, "step", "status"]
        lines = [head]
        for r in self.rows:
            value = "-" if r.metric is None else f"{r.metric:.4g}"
            shown = [_short(r.params.get(k)) for k in keys]
            step = "-" if r.step is None else str(r.step)
            mark = " (best)" if r is self.best else ""
            lines.append([r.trial, *shown, value, step, r.status + mark])
        widths = [max(len(row[i]) for row in lines) for i in range(len(head))]
        out = ["  ".join(c.ljust(w) for c, w in zip(row, widths, strict=True)) for row in lines]
        for r in self.rows:
            if r.error:
                out.append(f"{r.trial} failed: {r.error.strip().splitlines()[-1]}")
        return "\n".join(out)

    def as_dict(self) -> dict[str, Any]:
        o = self.options
        return {
            "config": o.config,
            "metric": o.metric,
            "mode": o.mode,
            "scheduler": o.scheduler,
            "samples": o.samples,
            "steps": o.steps,
            "params": {
                p.key: (list(p.distribution) if p.distribution else list(p.values))
                for p in o.params
            },
            "best": None if self.best is None else self.best.trial,
            "trials": [r.__dict__ for r in self.rows],
        }


def _trial_dirname(trial: Any) -> str:
    """A trial's folder under RUN/tune/ is named by its id, as its run folder under RUN/trials/."""
    return str(trial.trial_id)


def _short(value: Any) -> str:
    return f"{value:.4g}" if isinstance(value, float) else str(value)


def run_sweep(
    options: SweepOptions, address: str | None = None, log: Callable[[str], None] = print
) -> SweepResult:
    """Run the sweep on the Ray cluster at `address` (None: a Ray started here for it)."""
    from sim.training.ray_backend import RayBackend, require_ray

    require_ray("pete-sim sweep (Ray Tune runs its trials)")
    path = resolve_config_path(options.config)
    try:
        data = tomllib.loads(path.read_text())
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{path}: not valid TOML: {e}") from e
    base = trial_config(data, {}, str(path))
    fixed = {p.key: p.values[0] for p in options.params if p.fixed}
    for p in options.params:  # a bad key or value fails here, not in every trial
        for value in p.corners():
            trial_config(data, {**fixed, p.key: value}, str(path))
    workers = base.rollout.workers
    run_dir = options.run_dir.resolve()
    run_dir.mkdir(parents=True, exist_ok=True)

    from ray import tune

    trainable = tune.with_parameters(
        run_trial, data=data, where=str(path), root=str(run_dir), steps=options.steps
    )
    trainable = tune.with_resources(trainable, {"cpu": max(1, workers)})
    scheduler = None
    if options.scheduler == "asha":
        scheduler = tune.schedulers.ASHAScheduler(grace_period=1, reduction_factor=2)
    with RayBackend(address or "local") as backend:
        log(f"sweep of {path.name} on {backend.describe()}")
        tuner = tune.Tuner(
            trainable,
            param_space={p.key: p.domain(tune) for p in options.params},
            tune_config=tune.TuneConfig(
                metric=options.metric,
                mode=options.mode,
                num_samples=options.samples,
                scheduler=scheduler,
                max_concurrent_trials=options.max_concurrent or None,
                trial_dirname_creator=_trial_dirname,
            ),
            run_config=tune.RunConfig(
                name="tune", storage_path=str(run_dir), verbose=options.verbose
            ),
        )
        grid = tuner.fit()
    rows = []
    for k in range(len(grid)):
        r = grid[k]
        trial = Path(str(r.path)).name  # the trial's id (_trial_dirname)
        value = r.metrics.get(options.metric)
        rows.append(
            TrialRow(
                trial=trial,
                params={p.key: r.config.get(p.key) for p in options.params},
                status="error" if r.error else "done",
                metric=float(value) if isinstance(value, int | float) else None,
                step=int(r.metrics["step"]) if "step" in r.metrics else None,
                run_dir=str(run_dir / "trials" / trial),
                error=None if r.error is None else str(r.error),
            )
        )
    scored = [r for r in rows if r.metric is not None and math.isfinite(r.metric)]
    sign = 1.0 if options.mode == "max" else -1.0
    best = max(scored, key=lambda r: sign * (r.metric or 0.0)) if scored else None
    result = SweepResult(options, rows, best, run_dir / SUMMARY)
    result.summary.write_text(json.dumps(result.as_dict(), indent=1, default=str) + "\n")
    return result
