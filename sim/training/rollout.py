"""Self-play matches stepped in batches, on worker processes so both cores simulate.

    envs = VecMatches(env_config, RolloutConfig(workers=2, envs_per_worker=8), seed=1)
    step = envs.reset(kinds)                        # StepResult: learner and opponent observations
    step = envs.step(learner_actions, opponent_actions)
    envs.close()

Every slot is one 1v1 match on its own PyBullet client. One robot is the learner (its side drawn
per match when learner_side is "random": the observation is alliance-symmetric, so one policy
plays both); the other is the opponent, of a kind chosen per slot:

    policy     actions come from the caller (the self-play pool runs in the training process)
    planner    sim.baselines.planner's route planner
    scripted   sim.baselines.scripted's greedy chaser
    alliance   the whole game's scripted alliance (sim.baselines.alliance), its role's strategy
    random     uniform random actions
    idle       stands still
    none       no opponent robot on the field

A teacher (`teacher="planner"`) drives a shadow of the learner's robot: for every observation the
learner acts on, the action the planner would take from the same state (its own view: GPS pose,
visible rings, the field's layout), in the policy's action units. The trainer's imitation term
pulls the policy toward it (DAgger: the labels come from the states the learner visits). The
teacher plays the match's game: it drives onto the platform at the end only where the match's
reward pays for it, so in an uncapped match paid as ring collection it collects to the bell.
`teacher="route"` advises what jetson.autonomy.skills' route skill would drive from the learner's
own observation (pure pursuit onto the first route slot): a teacher whose every action follows from
what the policy sees, so the policy can copy it exactly, where the planner also acts on its
hidden target and back-off timers.

A slot's kind and tag (the caller's opponent id) change only when its match ends, so each match
has exactly one opponent, which is what ELO needs. Finished matches reset on their own; their
statistics come back as EpisodeStats. Each match draws its randomness from
np.random.default_rng((seed, slot, match number)), so a run is reproducible.

Where the workers run is the caller's choice (`launcher`): processes on this machine by default
(multiprocessing pipes), or anything else that builds one MatchGroup per GroupSpec and calls its
methods in lockstep (sim.training.ray_backend: Ray actors over a cluster). Every backend steps the
same MatchGroup, so the same seeds give the same StepResults wherever the matches run.

This module does not import torch: workers only simulate.
"""

from __future__ import annotations

import contextlib
import multiprocessing as mp
import signal
import traceback
from collections.abc import Callable, Sequence
from dataclasses import dataclass, field, replace
from typing import Any, Literal, Protocol

import numpy as np
from numpy.typing import ArrayLike

from jetson.autonomy.geometry import field_to_robot, other_alliance
from jetson.autonomy.skills import SkillConfig, SkillDriver, option_for
from jetson.autonomy.spec import ObservationSpec
from sim.baselines.alliance import AlliancePlayer
from sim.baselines.planner import Planner, PlannerConfig
from sim.config import RewardConfig, RobotConfig
from sim.errors import ConfigError, WorkerError
from sim.match import REWARD_COMPONENTS, EnvConfig, MatchCore
from sim.players import IdlePlayer, Player, RandomPlayer, ScriptedPlayer
from sim.world.state import DriveCommand

OPPONENT_KINDS = ("policy", "planner", "scripted", "alliance", "random", "idle", "none")
TEACHERS = ("none", "planner", "route")
ADVICE_SIZE = 2  # a teacher advises (linear, angular): the drive, not the intake or clamp


# The route teacher: jetson.autonomy.skills' controller with the route as its only option, always
# picked.
ROUTE_SKILL = SkillConfig(route_option=True, ring_options=0, goal_options=0, platform=False)
ROUTE_ACTION = np.ones(1)


def check_route_teacher(config: EnvConfig) -> None:
    """The route teacher advises a drive policy and reads the observation's route slot."""
    if config.skills is not None:
        raise ConfigError(
            "imitation.teacher = 'route' teaches a drive policy; a skill policy has the route "
            "as an option of its own (use teacher = 'planner', or drop [env.skills])"
        )
    if config.observation is None or not config.observation.route_slots:
        raise ConfigError(
            "imitation.teacher = 'route' drives to the observation's first route slot: set "
            "route_slots = 1 under [env.observation] (it needs ring_memory and version >= 4)"
        )


def drive_label(
    linear: ArrayLike, angular: ArrayLike, max_linear_mps: ArrayLike, max_angular_rad_s: ArrayLike
) -> np.ndarray:
    """(linear m/s, angular rad/s) in a drive policy's action units (a robot's top speeds),
    clipped to [-1, 1]: (2,) for one command, (B, 2) for arrays of them (the fast backend's)."""
    drive = np.stack(
        np.broadcast_arrays(
            np.divide(linear, max_linear_mps), np.divide(angular, max_angular_rad_s)
        ),
        -1,
    )
    return np.clip(drive.astype(np.float32), -1.0, 1.0)


def advice_size(config: EnvConfig) -> int:
    """A teacher's label width: (linear, angular), or one score per skill."""
    return config.skills.n_options if config.skills is not None else ADVICE_SIZE


LearnerSide = Literal["random", "red", "blue"]


@dataclass(frozen=True)
class RolloutConfig:
    """How experience is collected. buffer size = workers (or 1) x envs_per_worker x steps_per_env.

    workers = 0 steps every match in the training process (tests, debugging).
    """

    workers: int = 2
    envs_per_worker: int = 8
    steps_per_env: int = 128
    learner_side: LearnerSide = "random"
    fill_target: int = 10  # rings: the time a learner reaches this many is its "fill time"
    start_method: Literal["spawn", "forkserver", "fork"] = "spawn"
    # A share of the slots plays only the first short_steps of every match (truncated, with the
    # value bootstrapped): the opening, where the first rings are won, then gets several times
    # the experience it gets from full matches alone.
    short_share: float = 0.0
    short_steps: int = 240
    # End the learner's match, as a terminal state, once it has fill_target rings: for the
    # capped task, where nothing is left to earn then, every later step is a step not spent on
    # the opening.
    end_at_fill: bool = False

    def __post_init__(self) -> None:
        if self.workers < 0 or self.envs_per_worker < 1 or self.steps_per_env < 1:
            raise ConfigError("rollout: workers >= 0, envs_per_worker >= 1, steps_per_env >= 1")
        if not 0.0 <= self.short_share <= 1.0 or self.short_steps < 1:
            raise ConfigError("rollout: short_share within [0, 1] and short_steps >= 1")
        if self.learner_side not in ("random", "red", "blue"):
            raise ConfigError(
                f"rollout.learner_side must be random, red or blue: {self.learner_side!r}"
            )
        if self.start_method not in ("spawn", "forkserver", "fork"):
            raise ConfigError(f"rollout.start_method: {self.start_method!r}")

    @property
    def n_envs(self) -> int:
        return max(1, self.workers) * self.envs_per_worker

    @property
    def buffer_size(self) -> int:
        return self.n_envs * self.steps_per_env

    def slot_limit(self, slot: int) -> int | None:
        """Truncation of slot `slot`'s matches: short_steps for every 1/short_share-th position
        within a worker (the same count on every worker), else None."""
        k = slot % self.envs_per_worker
        n_short = round(self.short_share * self.envs_per_worker)
        # Spread the short positions evenly over the worker's slots.
        short = {int(i * self.envs_per_worker / n_short) for i in range(n_short)}
        return self.short_steps if k in short else None


@dataclass
class EpisodeStats:
    """One finished match, from the learner's side."""

    slot: int
    kind: str
    tag: int  # the caller's opponent id for policy opponents, else -1
    reward: float
    components: dict[str, float]
    rings: int
    fill_time_s: float | None
    score: float
    opponent_score: float
    opponent_rings: int
    result: float | None  # 1 win, 0.5 draw, 0 loss by match score; None without an opponent
    pins: int
    length: int
    ended_by_pin: bool
    # Collisions between the learner and its alliance partner (each time they came into
    # contact); 0 for a robot that plays alone.
    partner_collisions: int = 0


@dataclass
class StepResult:
    learner_obs: np.ndarray  # (n_envs, obs_size), the observation to act on next
    opponent_obs: np.ndarray  # (n_envs, obs_size), zeros where the opponent is not a policy
    rewards: np.ndarray  # (n_envs,) the learner's reward for the step just taken
    dones: np.ndarray  # (n_envs,) the match ended (terminated or truncated) with this step
    truncated: np.ndarray  # (n_envs,) ended by EnvConfig.max_steps: bootstrap from final_obs
    final_obs: np.ndarray  # (n_envs, obs_size), the last observation where truncated
    episodes: list[EpisodeStats] = field(default_factory=list)
    # (n_envs, ADVICE_SIZE): the teacher's (linear, angular) action for learner_obs, in
    # [-1, 1]; NaN without a teacher.
    advice: np.ndarray | None = None
    # (n_envs,): whether the learner's action for learner_obs decides anything (False while a
    # skill manoeuvre it committed to is under way: jetson.autonomy.skills, commit_goal_s).
    deciding: np.ndarray | None = None
    # (n_envs,): whether learner_obs belongs to an uncapped match (EnvConfig.uncapped_share),
    # where the trainer may keep its teacher longer (ImitationConfig.uncapped_until_step).
    uncapped: np.ndarray | None = None


def planner_label(teacher: Planner, core: Any, index: int, obs: np.ndarray) -> np.ndarray:
    """The planner teacher's label for robot `index`'s observation `obs`, the planner acting
    in `core` (a MatchCore, or sim.fast.players.FastCore): its (linear, angular) in action
    units for a drive policy; for a skill policy +1 for the option that does what the planner
    intends and -1 for the others, NaN where no option does it."""
    command = teacher.act(core, index)
    robot = core.world.robots[index]
    pose = (robot.x, robot.y, robot.heading)
    return intent_label(
        command, teacher.intent, robot.config, pose, obs, core.spec, core.config.skills
    )


def intent_label(
    command: DriveCommand,
    intent: tuple[str, np.ndarray | None],
    robot: RobotConfig,
    pose: tuple[float, float, float],
    obs: np.ndarray,
    spec: ObservationSpec,
    skills: SkillConfig | None,
) -> np.ndarray:
    """planner_label from what the planner did: its `command` and `intent` (Planner.intent)
    for a robot of config `robot` at `pose` (field frame, as the world has it). The fast
    backend labels every match at once with sim.fast.skills.OptionLabels, held to this by
    tests/sim/fast/test_skills.py."""
    if skills is None:
        return drive_label(
            command.linear, command.angular, robot.max_linear_mps, robot.max_angular_rad_s
        )
    kind, point = intent
    local = None
    if point is not None:
        local = field_to_robot(np.asarray(point)[None, :], pose[:2], pose[2])[0]
    k = option_for(kind, local, obs, spec, skills)
    if k is None:
        return np.full(skills.n_options, np.nan, np.float32)
    label = np.full(skills.n_options, -1.0, np.float32)
    label[k] = 1.0
    return label


def teacher_for(reward: RewardConfig) -> Planner:
    """The planner that teaches a match paid by `reward`: the usual one, parking at the end
    only when parking pays."""
    return Planner(PlannerConfig(endgame=reward.park > 0 or reward.elevated_end > 0))


class _Slot:
    """One match with its learner, opponent and bookkeeping."""

    def __init__(
        self,
        config: EnvConfig,
        rollout: RolloutConfig,
        seed: int,
        slot: int,
        teacher: str = "none",
    ) -> None:
        self.config = config
        self.rollout = rollout
        self.seed = seed
        self.slot = slot
        self.episode = 0
        self._cores: dict[tuple[str, bool], MatchCore] = {}
        self.kind = "idle"
        self.tag = -1
        self.pending: tuple[str, int] | None = None
        self.core: MatchCore
        self.learner = 0
        self.opponent: int | None = None
        self.player: Player | None = None
        self.obs: list[np.ndarray] = []
        self.steps = 0
        self.reward = 0.0
        self.fill_time: float | None = None
        self.teacher: Planner | None = None
        self._teachers: dict[bool, Planner] = {}
        if teacher == "planner":
            self._teachers = {u: teacher_for(config.match_reward(u)) for u in (False, True)}
        self._route_teacher = teacher == "route"
        self._router: SkillDriver | None = None

    def _core(self, alliance: str, solo: bool) -> MatchCore:
        key = (alliance, solo)
        if key not in self._cores:
            wc = self.config.world
            if solo:
                wc = replace(wc, **{other_alliance(alliance): ()})  # type: ignore[arg-type]
            if not getattr(wc, alliance):
                raise ConfigError(f"the learner plays {alliance} but world.{alliance} is empty")
            self._cores[key] = MatchCore(self.config, wc)
        return self._cores[key]

    def set_kind(self, kind: str, tag: int) -> None:
        if kind not in OPPONENT_KINDS:
            raise ConfigError(f"opponent kind must be one of {OPPONENT_KINDS}, got {kind!r}")
        self.pending = (kind, tag)

    def reset(self) -> None:
        if self.pending is not None:
            self.kind, self.tag = self.pending
            self.pending = None
        rng = np.random.default_rng((self.seed, self.slot, self.episode))
        self.episode += 1
        side = self.rollout.learner_side
        alliance = ("red" if rng.random() < 0.5 else "blue") if side == "random" else side
        self.core = self._core(alliance, self.kind == "none")
        self.obs = self.core.reset(rng)
        lineup = self.core.world.lineup
        self.learner = next(i for i, (a, _) in enumerate(lineup) if a == alliance)
        others = [i for i, (a, _) in enumerate(lineup) if a != alliance]
        if len(lineup) - 1 != len(others) or len(others) > 1:
            raise ConfigError("training matches are 1v1: one robot per alliance")
        self.opponent = others[0] if others else None
        self.player = make_player(self.kind) if self.opponent is not None else None
        if self.player is not None and self.opponent is not None:
            self.player.reset(self.core, self.opponent, rng)
        if self._teachers:
            self.teacher = self._teachers[self.core.uncapped]
            self.teacher.reset(self.core, self.learner, rng)
        if self._route_teacher:
            self._router = self.core.skill_driver(self.learner, ROUTE_SKILL)
        self.steps = 0
        self.reward = 0.0
        self.fill_time = None

    def step(self, action: np.ndarray, opponent_action: np.ndarray) -> tuple[float, bool, bool]:
        core = self.core
        commands: list[DriveCommand] = [DriveCommand(0.0, 0.0)] * len(core.world.robots)
        commands[self.learner] = core.command(self.learner, action)
        if self.opponent is not None:
            if self.kind == "policy":
                commands[self.opponent] = core.command(self.opponent, opponent_action)
            else:
                assert self.player is not None
                commands[self.opponent] = self.player.act(
                    core, self.opponent, self.obs[self.opponent]
                )
        results, ended, _ = core.step(commands)
        self.obs = [r.observation for r in results]
        self.steps += 1
        me = results[self.learner]
        self.reward += me.reward
        robot = core.world.robots[self.learner]
        if self.fill_time is None and robot.collected >= self.rollout.fill_target:
            self.fill_time = core.world.time_s
            if self.rollout.end_at_fill:
                return me.reward, True, False
        limits = [x for x in (self.config.max_steps, self.rollout.slot_limit(self.slot)) if x]
        limit = min(limits) if limits else None
        truncated = bool(not ended and limit is not None and self.steps >= limit)
        return me.reward, bool(ended) or truncated, truncated

    def stats(self) -> EpisodeStats:
        core = self.core
        world = core.world
        me = world.robots[self.learner]
        score = world.score()
        mine = float(score[me.alliance].total)
        theirs = float(score[other_alliance(me.alliance)].total)
        result = None
        opp_rings = 0
        if self.opponent is not None:
            result = 1.0 if mine > theirs else 0.5 if mine == theirs else 0.0
            opp_rings = world.robots[self.opponent].collected
        return EpisodeStats(
            slot=self.slot,
            kind=self.kind,
            tag=self.tag,
            reward=self.reward,
            components={k: float(core.totals[self.learner][k]) for k in REWARD_COMPONENTS},
            rings=me.collected,
            fill_time_s=self.fill_time,
            score=mine,
            opponent_score=theirs,
            opponent_rings=opp_rings,
            result=result,
            pins=core.pins[self.learner],
            length=self.steps,
            ended_by_pin=core.ended_by_pin,
        )

    def observations(self) -> tuple[np.ndarray, np.ndarray]:
        mine = self.obs[self.learner]
        if self.opponent is not None and self.kind == "policy":
            return mine, self.obs[self.opponent]
        return mine, np.zeros_like(mine)

    def deciding(self) -> bool:
        """Whether the learner's next action will decide anything (see StepResult.deciding)."""
        if self.config.skills is None or not self.core.drivers:
            return True
        return not self.core.drivers[self.learner].committed(self.obs[self.learner])

    def advice(self) -> np.ndarray:
        """The teacher's action for the learner's current state; call once per state (the
        planner keeps a map and a trail of poses, as when it drives). For a skill policy: +1
        for the option that does what the planner intends, -1 for the others. The route
        teacher: what the route skill drives from the learner's observation."""
        rc = self.core.world.robots[self.learner].config
        if self._router is not None:
            v, w = self._router.command(self.obs[self.learner], ROUTE_ACTION)
            return drive_label(v, w, rc.max_linear_mps, rc.max_angular_rad_s)
        if self.teacher is None:
            return np.full(advice_size(self.config), np.nan, np.float32)
        return planner_label(self.teacher, self.core, self.learner, self.obs[self.learner])

    def close(self) -> None:
        for core in self._cores.values():
            core.close()


def make_player(kind: str) -> Player | None:
    """The player of opponent kind `kind` (None for a policy, which the caller drives, and for
    none: no robot). "alliance" is the whole game's scripted alliance (sim.baselines.alliance),
    each robot playing its role's strategy."""
    if kind == "alliance":
        return AlliancePlayer()
    if kind == "planner":
        return Planner()
    if kind == "scripted":
        return ScriptedPlayer()
    if kind == "random":
        return RandomPlayer()
    if kind == "idle":
        return IdlePlayer()
    return None  # policy: the caller acts; none: no robot


class MatchGroup:
    """The slots one worker steps: what a worker process (or a Ray actor) holds."""

    def __init__(
        self,
        config: EnvConfig,
        rollout: RolloutConfig,
        seed: int,
        first_slot: int,
        count: int,
        teacher: str = "none",
    ) -> None:
        self.slots = [_Slot(config, rollout, seed, first_slot + k, teacher) for k in range(count)]

    def set_kinds(self, kinds: list[tuple[str, int]]) -> None:
        for s, (kind, tag) in zip(self.slots, kinds, strict=True):
            s.set_kind(kind, tag)

    def reset(self) -> StepResult:
        for s in self.slots:
            s.reset()
        return self._gather(
            np.zeros(len(self.slots), np.float32), np.zeros(len(self.slots), bool), None, []
        )

    def step(self, actions: np.ndarray, opponent_actions: np.ndarray) -> StepResult:
        n = len(self.slots)
        rewards = np.zeros(n, np.float32)
        dones = np.zeros(n, bool)
        truncs = np.zeros(n, bool)
        final: np.ndarray | None = None
        episodes = []
        for k, s in enumerate(self.slots):
            r, done, trunc = s.step(actions[k], opponent_actions[k])
            rewards[k], dones[k], truncs[k] = r, done, trunc
            if trunc:
                if final is None:
                    final = np.zeros((n, len(s.obs[s.learner])), np.float32)
                final[k] = s.obs[s.learner]
            if done:
                episodes.append(s.stats())
                s.reset()
        result = self._gather(rewards, dones, final, episodes)
        result.truncated = truncs
        return result

    def _gather(
        self,
        rewards: np.ndarray,
        dones: np.ndarray,
        final: np.ndarray | None,
        episodes: list[EpisodeStats],
    ) -> StepResult:
        pairs = [s.observations() for s in self.slots]
        mine = np.stack([p[0] for p in pairs]).astype(np.float32)
        theirs = np.stack([p[1] for p in pairs]).astype(np.float32)
        return StepResult(
            mine,
            theirs,
            rewards,
            dones,
            np.zeros(len(self.slots), bool),
            final if final is not None else np.zeros_like(mine),
            episodes,
            np.stack([s.advice() for s in self.slots]),
            np.array([s.deciding() for s in self.slots], bool),
            np.array([s.core.uncapped for s in self.slots], bool),
        )

    def close(self) -> None:
        for s in self.slots:
            s.close()


@dataclass(frozen=True)
class GroupSpec:
    """What one worker's MatchGroup is built from: slots first_slot ... first_slot + count - 1."""

    config: EnvConfig
    rollout: RolloutConfig
    seed: int
    first_slot: int
    count: int
    teacher: str = "none"

    def build(self) -> MatchGroup:
        return MatchGroup(
            self.config, self.rollout, self.seed, self.first_slot, self.count, self.teacher
        )


class Workers(Protocol):
    """The workers of a VecMatches: one MatchGroup per GroupSpec, called in lockstep."""

    def call(self, method: str, args: Sequence[tuple[Any, ...]]) -> list[Any]:
        """MatchGroup.<method>(*args[w]) on every worker w, their results in worker order; a
        failure is a WorkerError (the workers are closed)."""
        ...

    def close(self) -> None: ...


# Builds the workers for a list of GroupSpecs (VecMatches' `launcher`).
Launcher = Callable[[list[GroupSpec]], Workers]
GROUP_METHODS = ("reset", "step", "set_kinds")


def _worker(conn: Any, spec: GroupSpec) -> None:
    # Ctrl-C reaches the whole process group: the training process decides, and closes us.
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    group: MatchGroup | None = None
    try:
        group = spec.build()
        conn.send(("ok", None))
        while True:
            cmd, data = conn.recv()
            if cmd == "close":
                break
            if cmd not in GROUP_METHODS:
                raise ValueError(f"unknown worker command {cmd!r}")
            conn.send(("ok", getattr(group, cmd)(*data)))
    except Exception:  # the training process re-raises it with the worker's traceback
        conn.send(("error", traceback.format_exc()))
    finally:
        if group is not None:
            group.close()
        conn.close()


class ProcessWorkers:
    """Workers as processes on this machine, one pipe each (the default launcher)."""

    def __init__(self, specs: list[GroupSpec], start_method: str = "spawn") -> None:
        ctx = mp.get_context(start_method)
        self._conns: list[Any] = []
        self._procs: list[Any] = []
        for spec in specs:
            parent, child = ctx.Pipe()
            proc = ctx.Process(target=_worker, args=(child, spec), daemon=True)
            proc.start()
            child.close()
            self._conns.append(parent)
            self._procs.append(proc)
        for conn in self._conns:
            self._receive(conn)

    def _receive(self, conn: Any) -> Any:
        try:
            status, payload = conn.recv()
        except EOFError as e:
            self.close()
            raise WorkerError("a rollout worker exited without a reply") from e
        if status == "error":
            self.close()
            raise WorkerError(f"rollout worker failed:\n{payload}")
        return payload

    def call(self, method: str, args: Sequence[tuple[Any, ...]]) -> list[Any]:
        for conn, a in zip(self._conns, args, strict=True):
            conn.send((method, a))
        return [self._receive(c) for c in list(self._conns)]

    def close(self) -> None:
        for conn in self._conns:
            with contextlib.suppress(BrokenPipeError, OSError):
                conn.send(("close", None))
        for proc in self._procs:
            proc.join(timeout=5)
            if proc.is_alive():
                proc.terminate()
        self._conns, self._procs = [], []


def _merge(results: list[StepResult]) -> StepResult:
    if len(results) == 1:
        return results[0]
    return StepResult(
        np.concatenate([r.learner_obs for r in results]),
        np.concatenate([r.opponent_obs for r in results]),
        np.concatenate([r.rewards for r in results]),
        np.concatenate([r.dones for r in results]),
        np.concatenate([r.truncated for r in results]),
        np.concatenate([r.final_obs for r in results]),
        [e for r in results for e in r.episodes],
        np.concatenate([r.advice for r in results if r.advice is not None]),
        np.concatenate([r.deciding for r in results if r.deciding is not None]),
        np.concatenate([r.uncapped for r in results if r.uncapped is not None]),
    )


class VecMatches:
    """n_envs matches, split over `workers` workers (or stepped here when workers = 0).

    teacher: "planner" labels every learner observation with the planner's action
    (StepResult.advice); "none" leaves advice NaN. launcher: where the workers run (default:
    processes on this machine, ProcessWorkers; sim.training.ray_backend.RayBackend.launch puts
    them on a Ray cluster).
    """

    def __init__(
        self,
        config: EnvConfig,
        rollout: RolloutConfig,
        seed: int,
        teacher: str = "none",
        launcher: Launcher | None = None,
    ) -> None:
        if teacher not in TEACHERS:
            raise ConfigError(f"teacher must be one of {TEACHERS}, got {teacher!r}")
        if teacher == "route":
            check_route_teacher(config)
        self.config = config
        self.rollout = rollout
        self.n_envs = rollout.n_envs
        self._local: MatchGroup | None = None
        self._workers: Workers | None = None
        per = rollout.envs_per_worker
        specs = [
            GroupSpec(config, rollout, seed, w * per, per, teacher)
            for w in range(max(1, rollout.workers))
        ]
        if rollout.workers == 0:
            self._local = specs[0].build()
        elif launcher is None:
            self._workers = ProcessWorkers(specs, rollout.start_method)
        else:
            self._workers = launcher(specs)

    def _call(self, method: str, args: list[tuple[Any, ...]]) -> list[Any]:
        assert self._workers is not None, "VecMatches is closed"
        return self._workers.call(method, args)

    def _split(self, array: np.ndarray) -> list[np.ndarray]:
        per = self.rollout.envs_per_worker
        return [array[w * per : (w + 1) * per] for w in range(self.rollout.workers)]

    def set_kinds(self, kinds: list[tuple[str, int]]) -> None:
        """Opponent (kind, tag) per slot, applied when each slot's current match ends (and to
        every slot at reset())."""
        if len(kinds) != self.n_envs:
            raise ValueError(f"expected {self.n_envs} opponent kinds, got {len(kinds)}")
        if self._local is not None:
            self._local.set_kinds(kinds)
            return
        per = self.rollout.envs_per_worker
        self._call(
            "set_kinds", [(kinds[w * per : (w + 1) * per],) for w in range(self.rollout.workers)]
        )

    def reset(self) -> StepResult:
        if self._local is not None:
            return self._local.reset()
        return _merge(self._call("reset", [()] * self.rollout.workers))

    def step(self, actions: np.ndarray, opponent_actions: np.ndarray) -> StepResult:
        actions = np.asarray(actions, dtype=np.float32)
        opponent_actions = np.asarray(opponent_actions, dtype=np.float32)
        if self._local is not None:
            return self._local.step(actions, opponent_actions)
        pairs = list(zip(self._split(actions), self._split(opponent_actions), strict=True))
        return _merge(self._call("step", pairs))

    def close(self) -> None:
        if self._local is not None:
            self._local.close()
            self._local = None
        if self._workers is not None:
            self._workers.close()
            self._workers = None

    def __enter__(self) -> VecMatches:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()
