"""A training run as one TOML file (sim/configs/*.toml):

    name = "default"
    seed = 1
    total_steps = 1_000_000        # learner steps (one robot, one control step each)
    checkpoint_steps = 100_000

    [env]                          # sim.match.EnvConfig: world, reward, observation, ...
    [ppo]                          # sim.ppo.PPOConfig
    [rollout]                      # sim.training.rollout.RolloutConfig
    [selfplay]                     # sim.training.selfplay.SelfPlayConfig
    [opponents]                    # share of the matches per opponent kind; pool = self-play
    pool = 1.0
    [evaluation]                   # periodic deterministic evaluation (EvalConfig)
    [imitation]                    # optional teacher the policy is pulled toward (ImitationConfig)
    backend = "pybullet"           # or "fast": sim.fast's batched matches (`--backend fast`)
    [fast]                         # the fast backend's matches per step and steps per iteration
    [[phases]]                     # optional curriculum: from_step = N, then [phases.env],
                                   # [phases.rollout] (short_share, short_steps, learner_side),
                                   # [phases.opponents], applied on top of what came before

Every value is checked against its field's type and range when the file loads
(jetson.config_check), and an error names the file, the key (`[ppo] gamma`), what the key takes
and what was found; unknown keys are errors naming the key and the known ones. TOML has no null:
in [env], the string "none" means None (ring_cap = "none" counts every ring). `load_config`
returns the TrainConfig and the resolved EnvConfig comes from `env_config()`.
"""

from __future__ import annotations

import tomllib
from dataclasses import asdict, dataclass, field, is_dataclass, replace
from pathlib import Path
from typing import Any, get_type_hints

from jetson.config_check import check_value, error_at, key_label
from sim.config import merge
from sim.errors import ConfigError
from sim.match import EnvConfig, make_config
from sim.ppo import PPOConfig
from sim.training.rollout import OPPONENT_KINDS, TEACHERS, RolloutConfig, check_route_teacher
from sim.training.selfplay import SelfPlayConfig

CONFIG_DIR = Path(__file__).resolve().parent.parent / "configs"


@dataclass(frozen=True)
class EvalConfig:
    """Deterministic evaluation during training, on seeds training never draws.

    every_steps = 0 turns it off. The best checkpoint (best.pt) is the one with the highest
    win rate + fill rate - 0.01 x median fill time (s) against `opponent` in the capped
    scenario (sim.training.trainer.quality).
    """

    every_steps: int = 0
    matches: int = 10
    opponent: str = "planner"
    seed: int = 1_000_000

    def __post_init__(self) -> None:
        if self.every_steps < 0 or self.matches < 1:
            raise ConfigError("evaluation: every_steps >= 0 and matches >= 1")


@dataclass(frozen=True)
class ImitationConfig:
    """A teacher whose actions the policy is pulled toward, beside the PPO objective.

    teacher = "planner": in every training match the planner drives a shadow of the learner's
    robot and labels each state the learner visits with the (linear, angular) action it would
    take there (DAgger: labels on the learner's own states, not on the teacher's). The PPO loss
    gains coef x the mean squared distance between the actor's mean and that action from
    from_step on (a teacher can come back for a resumed run's fine-tune), and coef falls linearly
    to 0 at until_step (0: never falls), after which reward alone decides, so the policy can
    outgrow its teacher. uncapped_until_step, when set, is where the pull falls to 0 in
    uncapped matches instead (0: never falls there): the ring race is a fixed routine (collect
    to the bell) that reward alone learns short of the teacher, while the goal game needs
    reward to outgrow it. The planner sees rings without the observation's noise and
    knows the field's layout: privileged labels, for training only; the exported policy still
    acts on its observation alone.

    teacher = "route" (drive policies whose observation has a route slot): the label is what
    jetson.autonomy.skills' route skill drives from the learner's own observation, pure pursuit
    onto the first route slot. Every label follows from what the policy sees, so it can be copied
    exactly; the planner's labels also depend on its hidden target and back-off timers.
    """

    teacher: str = "none"
    coef: float = 1.0
    until_step: int = 0
    from_step: int = 0
    uncapped_until_step: int | None = None

    def __post_init__(self) -> None:
        if self.teacher not in TEACHERS:
            raise ConfigError(f"imitation.teacher must be one of {TEACHERS}: {self.teacher!r}")
        if self.coef < 0 or self.until_step < 0 or self.from_step < 0:
            raise ConfigError("imitation: coef, from_step and until_step must be >= 0")
        for name in ("until_step", "uncapped_until_step"):
            until = getattr(self, name)
            if until is not None and (not isinstance(until, int) or until < 0):
                raise ConfigError(f"imitation: {name} must be a step count >= 0: {until!r}")
            if until and until <= self.from_step:
                raise ConfigError(
                    f"imitation: {name} ({until}) must come after from_step "
                    f"({self.from_step}), or be 0 (never falls)"
                )

    def coef_at(self, step: int, uncapped: bool = False) -> float:
        """The teacher's weight at `step`, in an uncapped match or a capped one."""
        if self.teacher == "none" or step < self.from_step:
            return 0.0
        until = self.until_step
        if uncapped and self.uncapped_until_step is not None:
            until = self.uncapped_until_step
        if until == 0:
            return self.coef
        span = until - self.from_step
        return self.coef * max(0.0, 1.0 - (step - self.from_step) / span)


BACKENDS = ("pybullet", "fast")
FAST_OPPONENTS = ("pool", "random", "idle", "planner", "scripted", "alliance")


@dataclass(frozen=True)
class FastConfig:
    """How the batched backend (backend = "fast") collects experience: `envs` matches stepped
    together in one process, `steps_per_env` control steps of each per PPO iteration (the
    buffer is their product). It replaces [rollout]'s workers, envs_per_worker and
    steps_per_env; the rest of [rollout] holds."""

    envs: int = 1024
    steps_per_env: int = 64

    def __post_init__(self) -> None:
        if self.envs < 1 or self.steps_per_env < 1:
            raise ConfigError("[fast] envs and steps_per_env must be >= 1")


@dataclass(frozen=True)
class TrainConfig:
    name: str = "default"
    seed: int = 1
    total_steps: int = 1_000_000
    checkpoint_steps: int = 100_000
    keep_checkpoints: int = 3
    # Threads for the PPO update. Acting runs one batch of a few dozen rows per step, where a
    # second thread only adds hand-off latency (4 ms per layer measured on a busy 2-core
    # machine, against 0.05 ms on one), so acting always uses one.
    torch_threads: int = 1
    env: dict[str, Any] = field(default_factory=dict)
    ppo: PPOConfig = field(default_factory=PPOConfig)
    rollout: RolloutConfig = field(default_factory=RolloutConfig)
    selfplay: SelfPlayConfig = field(default_factory=SelfPlayConfig)
    opponents: dict[str, float] = field(default_factory=lambda: {"pool": 1.0})
    evaluation: EvalConfig = field(default_factory=EvalConfig)
    imitation: ImitationConfig = field(default_factory=ImitationConfig)
    # Where the matches run: "pybullet" (sim.world, worker processes) or "fast" (sim.fast's
    # batched numpy matches; what it does not run yet is refused by name: on_backend()).
    backend: str = "pybullet"
    fast: FastConfig = field(default_factory=FastConfig)
    # A curriculum: from `from_step` on, [env] / [rollout] / [opponents] change (each phase
    # applies on top of the ones before it). See at_step().
    phases: tuple[dict[str, Any], ...] = ()

    def __post_init__(self) -> None:
        if self.backend not in BACKENDS:
            raise ConfigError(f"backend must be one of {BACKENDS}, got {self.backend!r}")
        if self.total_steps < 1 or self.checkpoint_steps < 1 or self.keep_checkpoints < 1:
            raise ConfigError("total_steps, checkpoint_steps and keep_checkpoints must be >= 1")
        kinds = {"pool", *OPPONENT_KINDS} - {"policy"}
        unknown = sorted(set(self.opponents) - kinds)
        if unknown:
            raise ConfigError(f"opponents: unknown kinds {unknown} (known: {sorted(kinds)})")
        if any(v < 0 for v in self.opponents.values()) or sum(self.opponents.values()) <= 0:
            raise ConfigError("opponents: shares must be >= 0 and not all zero")
        self.env_config()  # fail on a bad env table now, not in a worker
        last = 0
        for k, phase in enumerate(self.phases):
            table = f"phases[{k}]"
            unknown = sorted(set(phase) - set(_PHASE_KEYS))
            if unknown:
                raise ConfigError(
                    f"[{table}]: unknown keys {unknown} (known: {sorted(_PHASE_KEYS)})"
                )
            for key, hint in _PHASE_KEYS.items():
                if key in phase:
                    check_value(phase[key], hint, key_label(table, key), ConfigError)
            start = phase.get("from_step")
            if not isinstance(start, int) or start <= last:
                raise ConfigError(f"phases[{k}].from_step must be an integer above {last}")
            last = start
            fixed = set(phase.get("rollout", {})) - _PHASE_ROLLOUT
            if fixed:
                # The buffers are sized once: only how matches are played may change.
                raise ConfigError(f"phases[{k}].rollout may set only {sorted(_PHASE_ROLLOUT)}")
            try:
                self.at_step(start)
            except ConfigError as e:
                if "phases[" in str(getattr(e, "config_key", "")):
                    raise
                label = key_label(table)
                raise error_at(ConfigError, label, f"(merged on what came before) {e}") from e

    def at_step(self, step: int) -> TrainConfig:
        """The config in force at learner step `step`: the base with every phase that has
        started merged in order (no phases left in the result)."""
        env = dict(self.env)
        rollout = self.rollout
        opponents = dict(self.opponents)
        for k, phase in enumerate(self.phases):
            if phase["from_step"] > step:
                break
            env = _deep_merge(env, phase.get("env", {}))
            rollout = merge(rollout, phase.get("rollout"), f"phases[{k}].rollout")
            if "opponents" in phase:
                opponents = {str(n): float(v) for n, v in phase["opponents"].items()}
        return replace(self, env=env, rollout=rollout, opponents=opponents, phases=())

    def phase_index(self, step: int) -> int:
        """0 before the first phase, k after phases[k - 1] has started."""
        return sum(1 for p in self.phases if p["from_step"] <= step)

    def on_backend(self) -> TrainConfig:
        """The config as its backend runs it: on "fast", [fast] sets the rollout's size, and
        anything the batched matches do not run yet (sim.fast.matches.fast_unsupported, an
        opponent other than the pool, random or idle) is a ConfigError naming it."""
        if self.backend != "fast":
            return self
        from sim.fast.matches import fast_unsupported

        missing = fast_unsupported(self.env_config(), self.imitation.teacher)
        kinds = sorted(k for k, share in self.opponents.items() if share > 0)
        missing += [f"opponents.{k}" for k in kinds if k not in FAST_OPPONENTS]
        if missing:
            raise ConfigError(
                f"config {self.name!r} on --backend fast: the fast backend does not run "
                + "; ".join(missing)
                + " yet (train it with --backend pybullet)"
            )
        rollout = replace(
            self.rollout,
            workers=0,
            envs_per_worker=self.fast.envs,
            steps_per_env=self.fast.steps_per_env,
        )
        return replace(self, rollout=rollout)

    def env_config(self) -> EnvConfig:
        return make_config(_nones(self.env))

    def opponent_slots(self) -> list[str]:
        """The opponent kind of each rollout slot: shares apportioned by largest remainder, dealt
        round-robin over the workers so every worker gets a similar mix. On the fast backend a
        match of `a` robots a side is `a` slots (its learning robots, sim.fast.matches): the
        kinds are dealt per match, each repeated for the match's slots."""
        group = len(self.env_config().world.red) if self.backend == "fast" else 1
        workers = max(1, self.rollout.workers)
        per = self.rollout.envs_per_worker // group  # matches a worker steps
        total = sum(self.opponents.values())
        n = workers * per
        exact = {k: v / total * n for k, v in self.opponents.items() if v > 0}
        counts = {k: int(x) for k, x in exact.items()}
        for k in sorted(exact, key=lambda k: counts[k] - exact[k])[: n - sum(counts.values())]:
            counts[k] += 1
        order = [k for k in sorted(counts) for _ in range(counts[k])]
        # Deal round-robin: match w * per + j gets the (j * workers + w)-th kind, each repeated
        # for the match's slots.
        return [
            order[j * workers + w] for w in range(workers) for j in range(per) for _ in range(group)
        ]

    def to_dict(self) -> dict[str, Any]:
        return _plain(asdict(self))


_PHASE_ROLLOUT = {"short_share", "short_steps", "learner_side"}
_PHASE_KEYS: dict[str, Any] = {
    "from_step": int,
    "env": dict[str, Any],
    "rollout": dict[str, Any],
    "opponents": dict[str, float],
}


def _deep_merge(base: dict[str, Any], extra: dict[str, Any]) -> dict[str, Any]:
    out = dict(base)
    for k, v in extra.items():
        out[k] = (
            _deep_merge(out[k], v) if isinstance(v, dict) and isinstance(out.get(k), dict) else v
        )
    return out


def _nones(value: Any) -> Any:
    """TOML has no null: the string "none" stands for None (ring_cap = "none": every ring)."""
    if isinstance(value, dict):
        return {k: _nones(v) for k, v in value.items()}
    if isinstance(value, str) and value.lower() == "none":
        return None
    return value


def _plain(value: Any) -> Any:
    if is_dataclass(value):
        return _plain(asdict(value))  # type: ignore[arg-type]
    if isinstance(value, dict):
        return {k: _plain(v) for k, v in value.items()}
    if isinstance(value, list | tuple):
        return [_plain(v) for v in value]
    return value


def parse_config(data: dict[str, Any], where: str = "config") -> TrainConfig:
    """A TrainConfig from a TOML document's tables, every value checked against its field's type
    (jetson.config_check) and range; an error names `where` (the file) and the key."""
    try:
        if not isinstance(data, dict):
            raise ConfigError(f"expected a table, found {type(data).__name__}")
        data = dict(data)
        # [opponents] replaces the default shares ({"pool": 1.0}) instead of merging into them.
        opponents = data.pop("opponents", None)
        cfg = merge(TrainConfig(), data, "")
        if opponents is not None:
            check_value(opponents, _HINTS["opponents"], key_label("", "opponents"), ConfigError)
            cfg = replace(cfg, opponents={str(k): float(v) for k, v in opponents.items()})
        if cfg.imitation.teacher == "route":
            check_route_teacher(cfg.env_config())
        return cfg
    except (TypeError, ValueError) as e:
        raise ConfigError(f"{where}: {e}") from e


_HINTS = get_type_hints(TrainConfig)


def load_config(path: str | Path) -> TrainConfig:
    """A TrainConfig from a TOML file: a path, or the name of a file in sim/configs/."""
    p = resolve_config_path(path)
    try:
        data = tomllib.loads(p.read_text())
    except tomllib.TOMLDecodeError as e:
        raise ConfigError(f"{p}: not valid TOML: {e}") from e
    return parse_config(data, str(p))


def resolve_config_path(path: str | Path) -> Path:
    p = Path(path)
    if p.is_file():
        return p
    named = CONFIG_DIR / (p.name if p.suffix == ".toml" else f"{p.name}.toml")
    if named.is_file() and len(p.parts) == 1:
        return named
    shipped = sorted(x.stem for x in CONFIG_DIR.glob("*.toml"))
    raise ConfigError(f"no config file {str(path)!r} (shipped: {shipped})")
