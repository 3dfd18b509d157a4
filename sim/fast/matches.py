"""Self-play matches on the batched backend, with VecMatches' interface (sim.training.rollout).

    envs = FastMatches(env_config, RolloutConfig(envs_per_worker=4096, workers=0), seed=1)
    step = envs.reset()                         # StepResult: learner and opponent observations
    step = envs.step(learner_actions, opponent_actions)

A row is one learning robot. In a match of one robot a side (1v1) every row is one match of one
FastWorld; in a match of `a` robots a side (the whole game's 2v2: world.red and world.blue of
equal size) the learning alliance's robots are `a` consecutive rows of one match (row m * a + j:
robot j of match m's learning alliance), each acting on its own observation and paid its own
reward, and the opponent rows likewise hold the other alliance's robots, robot j's opposite
number in row m * a + j (the trainer's opponent actions). `rollout.n_envs` rows, all stepped
together; n_envs must be a multiple of `a`, and the rows of one match play one opponent kind.
The learner's side is drawn per match as VecMatches draws it (learner_side), from the same
per-match generator np.random.default_rng((seed, match, match number)), which then starts the
world as World.reset would. Rewards are MatchCore's components (sim.match.REWARD_COMPONENTS) for
each learning robot (its rings, clamps, pins and shapings; the alliance's score margin, goals,
platform and partners' contacts for each), the shaping potentials sim.rewards' (sim.fast.shaping:
compiled); the start curricula (goal_start_share, midgame_start_share) are drawn as MatchCore
draws them.
Opponents: "policy" (the caller's actions), "random", "idle", "planner" (sim.fast.planner: the
planner for every match at once, one for each opponent robot), and the Python players written
against MatchCore, playing their match through sim.fast.players.FastCore, a Python call per
robot and step: "scripted" (the greedy chaser) and "alliance" (the scripted alliance of the
whole game, sim.baselines.alliance, each robot its role's strategy); "none" (no opponent robot)
stays on the PyBullet backend (ConfigError names it). The ring and goal memories and the route
slots are batched (sim.fast.memory). A skill policy's scores drive each robot's SkillDriver
(jetson.autonomy.skills) for every robot of every match at once (sim.fast.skills), and intake
and clamp actions run the actuators as MatchCore.command does. Teachers: the route skill's
controller (sim.fast.skills) and the planner (sim.fast.planner, one for each learning robot),
batched, its label rollout.intent_label's (sim.fast.skills.OptionLabels for a skill policy).
"""

from __future__ import annotations

from dataclasses import replace
from typing import Any

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.skills import SkillConfig
from jetson.autonomy.spec import ObservationSpec
from sim.errors import ConfigError
from sim.fast.observe import FastObserver, unsupported_spec
from sim.fast.planner import FastPlanner
from sim.fast.players import FastCore, command_row
from sim.fast.shaping import learner_potentials
from sim.fast.skills import FastSkillDrivers, OptionLabels
from sim.fast.world import FastWorld, unsupported
from sim.match import (
    REWARD_COMPONENTS,
    EnvConfig,
    derived_spec,
    goal_start,
    midgame_start,
    skill_settings,
    with_prior,
)
from sim.players import Player
from sim.training.rollout import (
    ROUTE_ACTION,
    ROUTE_SKILL,
    TEACHERS,
    EpisodeStats,
    RolloutConfig,
    StepResult,
    advice_size,
    drive_label,
    make_player,
    teacher_for,
)

FAST_OPPONENTS = ("policy", "random", "idle", "planner", "scripted", "alliance")
PYTHON_PLAYERS = ("scripted", "alliance")  # played through FastCore, a call per robot and step
_COLUMNS = {name: i for i, name in enumerate(REWARD_COMPONENTS)}  # reward components' columns
F64 = NDArray[np.float64]
I64 = NDArray[np.int64]
Commands = tuple[F64, F64, NDArray[np.bool_], NDArray[np.int8]]  # linear, angular, intake, clamp


def fast_unsupported(config: EnvConfig, teacher: str = "none") -> list[str]:
    """What of a training setup the fast backend cannot run yet (empty: all of it)."""
    out = unsupported(config.world)
    red, blue = len(config.world.red), len(config.world.blue)
    if red != blue or red < 1:
        out.append(
            f"a match of {red} red and {blue} blue robots (training matches are alliances of "
            "equal size)"
        )
    if teacher not in TEACHERS:
        out.append(f"imitation.teacher = {teacher!r}")
    if config.observation is not None:
        out += [f"observation.{name}" for name in unsupported_spec(config.observation)]
    return out


class FastMatches:
    """VecMatches on a FastWorld (module docstring)."""

    def __init__(
        self, config: EnvConfig, rollout: RolloutConfig, seed: int, teacher: str = "none"
    ) -> None:
        missing = fast_unsupported(config, teacher)
        if missing:
            raise ConfigError("--backend fast does not run this config yet: " + "; ".join(missing))
        a = len(config.world.red)
        if rollout.n_envs % a or rollout.envs_per_worker % a:
            raise ConfigError(
                f"a match of {a} robots a side needs rows in multiples of {a}: "
                f"[fast] envs = {rollout.n_envs}"
            )
        self.config = config
        self.rollout = rollout
        self.seed = seed
        self.a = a  # learning robots a match
        self.n = rollout.n_envs  # rows: learning robots
        self.b = b = self.n // a  # matches
        self.world = FastWorld(config.world, b)
        spec = config.observation or derived_spec(
            self.world.match_length_s, [rc.ring_capacity for rc in self.world.robot_configs]
        )
        if spec.goal_memory and spec.goal_clamp_offset_m <= 0:
            # with_prior's clamp offset (World.clamp_offset of the first robot and goal), from
            # the fast world's own, so that with_prior needs nothing but the field.
            offset = abs(float(self.world.clamp_offsets[0, 0])) if self.world.n_goals else 0.0
            offset = offset or self.world.robot_configs[0].length_m / 2
            spec = replace(spec, goal_clamp_offset_m=round(offset, 4))
        self.spec: ObservationSpec = with_prior(spec, self.world)  # type: ignore[arg-type]
        if abs(self.spec.match_length_s - self.world.match_length_s) > 1e-9:
            raise ConfigError(
                f"observation.match_length_s is {self.spec.match_length_s} but the match lasts "
                f"{self.world.match_length_s} s: set them equal (as MatchCore asks)"
            )
        self.observer = FastObserver(
            self.world,
            self.spec,
            obs_noise=config.obs_noise,
            gps_noise=config.gps_noise,
            rng=np.random.default_rng((seed, 1 << 20)),
        )
        self._player_rng = np.random.default_rng((seed, 1 << 21))
        # Which goals score for red (row 0) and blue (row 1): the learner's row by its side.
        self._scores_for = self.world.field.goal_may_score.T
        self._match_kinds = ["idle"] * b
        self._match_tags = [-1] * b
        self._pending: dict[int, tuple[str, int]] = {}
        self.episode = np.zeros(b, dtype=np.int64)
        self.learner = np.zeros(b, dtype=np.int64)  # each match's learning side: 0 red, 1 blue
        self.uncapped = np.zeros(b, dtype=bool)
        # Each match's truncation: rollout.slot_limit over the matches, as over 1v1 rows.
        per_match = replace(rollout, envs_per_worker=rollout.envs_per_worker // a)
        self.limits = np.array(
            [
                min([x for x in (config.max_steps, per_match.slot_limit(m)) if x] or [1 << 40])
                for m in range(b)
            ]
        )
        self._rewards = {False: config.reward, True: config.match_reward(True)}
        self._per_match: dict[str, NDArray[Any]] = {}  # rewards by match: _reward_config's
        plats = [self.world.field.platform(s) for s in ("red", "blue")]
        self._platforms = np.array([[*p.center, *p.size] for p in plats])  # by learner side
        self.steps = np.zeros(b, dtype=np.int64)
        self.total = np.zeros(self.n)  # by row, as the rest of the rows' bookkeeping
        self.totals = np.zeros((self.n, len(REWARD_COMPONENTS)))
        self.fill_time = np.full(self.n, np.nan)
        self.pins = np.zeros(self.n, dtype=np.int64)
        self._potentials: list[dict[str, F64]] = [{} for _ in range(a)]  # by alliance robot
        self._margin = np.zeros(b)
        # The learning alliances' partner pairs (robot j and j + 1 of each side: World's order)
        # and whether each was in contact last step, for partner collisions.
        self._partner_pairs = np.array(
            [(s * a, s * a + 1) for s in (0, 1)] if a == 2 else [], dtype=np.int64
        ).reshape(-1, 2)
        self._partners_touching = np.zeros((b, len(self._partner_pairs)), dtype=bool)
        self.partner_collisions = np.zeros(b, dtype=np.int64)  # the learning alliance's
        self.obs = np.zeros((b, self.world.n_robots, self.spec.size), np.float32)
        # The route teacher: the route skill's controller of each learning robot.
        self._route_teacher = teacher == "route"
        self._routers: FastSkillDrivers | None = None
        if self._route_teacher:
            self._routers = self._skill_drivers(ROUTE_SKILL)
        # A skill policy's controllers: every robot's of every match (MatchCore.skill_driver).
        self._drivers: FastSkillDrivers | None = None
        if config.skills is not None:
            self._drivers = self._skill_drivers(config.skills)
        rcs = self.world.robot_configs
        self._max_v = np.array([rc.max_linear_mps for rc in rcs])  # drive_label's speeds
        self._max_w = np.array([rc.max_angular_rad_s for rc in rcs])
        # Python players: each opponent robot's (row m * a + j: robot j of match m's opponents).
        self._players: list[Player | None] = [None] * self.n
        # The planner: the opponent where `_planning` (one for each opponent robot), and the
        # teacher of every learning robot (one for each).
        self._planning = np.zeros(b, dtype=bool)
        self._opponent_planners = [FastPlanner(self.world) for _ in range(a)]
        self._teacher_configs = {
            u: teacher_for(config.match_reward(u)).config for u in (False, True)
        }
        self._teachers: list[FastPlanner] = []
        if teacher == "planner":
            cfg = self._teacher_configs[False]
            self._teachers = [FastPlanner(self.world, cfg) for _ in range(a)]
        if config.skills is not None:  # the planner's label for a skill policy
            self._labels = OptionLabels(self.spec, config.skills)

    # --- rows and robots ---------------------------------------------------------------------

    @property
    def kinds(self) -> list[str]:
        """Each row's opponent kind (its match's)."""
        return [k for k in self._match_kinds for _ in range(self.a)]

    @property
    def tags(self) -> list[int]:
        """Each row's opponent tag (its match's)."""
        return [t for t in self._match_tags for _ in range(self.a)]

    def robot_of(self, j: int, learning: bool = True) -> I64:
        """Robot j of each match's learning (else opposing) alliance: its index in the world
        (red robots first, as World lists them), (B,)."""
        side = self.learner if learning else 1 - self.learner
        return side * self.a + j

    def row_robots(self) -> I64:
        """Each row's learning robot (its index in its match's world), (n,)."""
        return np.stack([self.robot_of(j) for j in range(self.a)], -1).reshape(-1)

    def _rows(self, j: int) -> I64:
        """The rows of robot j of every match's alliance: m * a + j, (B,)."""
        return np.arange(self.b) * self.a + j

    def _by_robot(self, values: np.ndarray, j: int) -> np.ndarray:
        """Robot j's share of a by-row array: its rows, by match."""
        return values[self._rows(j)]

    # --- VecMatches' interface ---------------------------------------------------------------

    def set_kinds(self, kinds: list[tuple[str, int]]) -> None:
        """Each row's opponent from its match's next match on (VecMatches.set_kinds); the rows
        of one match name the same opponent."""
        if len(kinds) != self.n:
            raise ConfigError(f"set_kinds needs {self.n} kinds, got {len(kinds)}")
        for k, (kind, tag) in enumerate(kinds):
            if kind not in FAST_OPPONENTS:
                raise ConfigError(
                    f"--backend fast plays opponents {FAST_OPPONENTS}, not {kind!r} (set "
                    "[opponents] to the pool, or use the PyBullet backend)"
                )
            if kinds[k - k % self.a] != (kind, tag):
                raise ConfigError(
                    f"rows {k - k % self.a}..{k - k % self.a + self.a - 1} are one match and play "
                    f"one opponent, but row {k} names {(kind, tag)}"
                )
        for m in range(self.b):
            self._pending[m] = kinds[m * self.a]

    def reset(self) -> StepResult:
        self._start(np.arange(self.b))
        self.obs = self.observer.reset()
        return self._result(np.zeros(self.n, np.float32), np.zeros(self.n, bool), None, [])

    def step(self, actions: np.ndarray, opponent_actions: np.ndarray) -> StepResult:
        w = self.world
        n, b, a = self.n, self.b, self.a
        mr = np.arange(b)
        acts = np.asarray(actions, dtype=np.float64)
        opp = np.asarray(opponent_actions, dtype=np.float64)
        size = self.config.action_size
        if acts.shape != (n, size):
            raise ValueError(f"actions must have shape ({n}, {size})")
        if opp.shape != (n, size):
            raise ValueError(f"opponent actions must have shape ({n}, {size})")
        lin = np.zeros((b, w.n_robots))
        ang = np.zeros((b, w.n_robots))
        intake = np.ones((b, w.n_robots), dtype=bool)
        clamp = np.full((b, w.n_robots), -1, dtype=np.int8)
        random = self._player_rng.uniform(-1.0, 1.0, opp.shape)  # one draw a step, all rows
        cores: dict[int, FastCore] = {}  # each match as its Python players read it this step
        for j in range(a):
            me, them = self.robot_of(j), self.robot_of(j, learning=False)
            rows = self._rows(j)
            mine = self._commands(acts[rows], me)
            theirs = self._opponents(opp[rows], random[rows], j, cores)
            for cmd, who in ((mine, me), (theirs, them)):
                lin[mr, who], ang[mr, who], intake[mr, who], clamp[mr, who] = cmd
        before = [w.collected[mr, self.robot_of(j)].copy() for j in range(a)]
        events = w.step(lin, ang, intake, clamp)
        self.obs = self.observer.push()
        pinned = self._pinned(events.pins)  # (B, R)
        met = self._partners_met()  # (B,): the learning alliance's partners came into contact
        ended = events.match_over | (pinned.any(axis=1) & self.config.end_on_pin)
        rewards = np.zeros(n)
        comps = np.zeros((n, len(REWARD_COMPONENTS)))
        margin = self._margin_now()
        for j in range(a):
            me, rows = self.robot_of(j), self._rows(j)
            rewards[rows], comps[rows] = self._reward(
                j, before[j], events.clamped[mr, me], pinned[mr, me], ended, margin, met
            )
        self._margin = margin
        self.steps += 1
        self.total += rewards
        self.totals += comps
        robots = self.row_robots()
        by_row = np.repeat(mr, a)
        self.pins += pinned[by_row, robots]
        self.partner_collisions += met
        filled = np.isnan(self.fill_time) & (
            w.collected[by_row, robots] >= self.rollout.fill_target
        )
        self.fill_time = np.where(filled, w.time_s[by_row], self.fill_time)
        filled_all = ~np.isnan(self.fill_time).reshape(b, a).any(axis=1)  # every robot's
        terminal = ended | (filled_all & self.rollout.end_at_fill)
        truncated = ~terminal & (self.steps >= self.limits)
        done = terminal | truncated
        final = None
        episodes: list[EpisodeStats] = []
        if done.any():
            which = np.flatnonzero(done)
            if truncated.any():
                final = self.obs[by_row, robots].copy()
            red, blue = self.world.totals()
            by_pin = pinned.any(axis=1) & self.config.end_on_pin
            episodes = [
                self._stats(int(m), j, bool(by_pin[m]), red, blue) for m in which for j in range(a)
            ]
            self._start(which)
            self.obs[which] = self.observer.reset(which)[which]
        result = self._result(rewards.astype(np.float32), np.repeat(done, a), final, episodes)
        result.truncated = np.repeat(truncated, a)
        return result

    def close(self) -> None:
        """Nothing to release: no processes, no PyBullet clients."""

    def __enter__(self) -> FastMatches:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- matches ----------------------------------------------------------------------------

    def _start(self, which: I64) -> None:
        """New matches `which`: side, start, intakes, rewards, bookkeeping."""
        side = self.rollout.learner_side
        a = self.a
        rngs = []
        for m in which:
            if m in self._pending:
                self._match_kinds[m], self._match_tags[m] = self._pending.pop(m)
            rng = np.random.default_rng((self.seed, int(m), int(self.episode[m])))
            self.episode[m] += 1
            red = rng.random() < 0.5 if side == "random" else side == "red"
            self.learner[m] = 0 if red else 1
            rngs.append(rng)
        rngs = self.world.reset_matches(which, rngs)
        share = self.config.uncapped_share
        for m, rng in zip(which, rngs, strict=True):
            uncapped = share > 0 and rng.random() < share
            self.uncapped[m] = uncapped
            if uncapped:
                self.world.room_cap[m] = 1 << 30
            self._curricula(int(m), rng)
        self._per_match.clear()  # the matches' rewards change with their intakes
        for drivers in (self._routers, self._drivers):
            if drivers is not None:  # fresh controllers (MatchCore.skill_driver)
                drivers.reset(which)
        # The players start from the match as it starts (after the curricula), as on PyBullet
        # (their reset reads the field and the robots, not the sensors).
        for m, rng in zip(which, rngs, strict=True):
            kind = self._match_kinds[m]
            self._planning[m] = kind == "planner"
            core: Any = self._core(int(m)) if kind in PYTHON_PLAYERS else None
            for j in range(a):
                them = int(self.robot_of(j, learning=False)[m])
                row = int(m) * a + j
                self._players[row] = None
                if kind == "planner":
                    self._opponent_planners[j].reset(np.array([m]), np.array([them]))
                if core is not None:  # what a MatchCore gives its players
                    player = make_player(kind)
                    assert player is not None
                    player.reset(core, them, rng)
                    self._players[row] = player
                if self._teachers:
                    teaching = self._teacher_configs[bool(self.uncapped[m])]
                    me = int(self.robot_of(j)[m])
                    self._teachers[j].reset(np.array([m]), np.array([me]), teaching)
        self.steps[which] = 0
        self.partner_collisions[which] = 0
        if len(self._partner_pairs):
            gap = -self.world.overlaps(self._partner_pairs)[which]
            self._partners_touching[which] = gap <= self.world.config.pin_contact_m
        rows = (which[:, None] * a + np.arange(a)).reshape(-1)
        self.total[rows] = 0.0
        self.totals[rows] = 0.0
        self.fill_time[rows] = np.nan
        self.pins[rows] = 0
        for j in range(a):
            potentials = self._potential_now(j)
            for name, value in potentials.items():
                old = self._potentials[j].get(name, value)
                old[which] = value[which]
                self._potentials[j][name] = old
        margin = self._margin_now()
        self._margin[which] = margin[which]

    def _curricula(self, k: int, rng: np.random.Generator) -> None:
        """Match k's start curricula, drawn as MatchCore.reset draws them: some seconds in
        (midgame_start_share), or robots with their backs to their goals (goal_start_share)."""
        cfg = self.config
        w = self.world
        if cfg.midgame_start_share > 0 and rng.random() < cfg.midgame_start_share:
            floor = np.flatnonzero(w.ring_floor[k])
            robots = [
                (None if w.room_cap[k, i] >= 1 << 30 else int(w.room_cap[k, i]), int(w.room[k, i]))
                for i in range(w.n_robots)
            ]
            gone, taken = midgame_start(rng, floor, robots, lambda i, r: self._at_goal(k, i, r))
            for i, mine in enumerate(taken):
                w.held[k, i] += len(mine)
                w.collected[k, i] += len(mine)
            w.ring_floor[k, gone] = False
        elif cfg.goal_start_share > 0:
            for i in range(w.n_robots):
                if rng.random() < cfg.goal_start_share:
                    self._at_goal(k, i, rng)

    def _at_goal(self, k: int, i: int, rng: np.random.Generator) -> None:
        """Robot i of match k with its back to one of its alliance's goals (goal_start)."""
        w = self.world
        alliance = w.alliances[i]
        mine = [g for g, spec in enumerate(w.field.goals) if spec.alliance == alliance]
        pose = goal_start(
            rng,
            [(float(w.gx[k, g]), float(w.gy[k, g])) for g in mine],
            [abs(float(w.clamp_offsets[i, g])) for g in mine],
            w.field.half - float(w.radius[i]),
        )
        if pose is not None:
            w.place_robot(k, i, *pose)

    def _partners_met(self) -> NDArray[np.bool_]:
        """Whether each match's learning alliance's partners came into contact this step
        (within pin_contact_m, as World.touching): one partner collision, (B,)."""
        if not len(self._partner_pairs):
            return np.zeros(self.b, dtype=bool)
        gap = -self.world.overlaps(self._partner_pairs)
        touching = gap <= self.world.config.pin_contact_m  # (B, 2): red's pair, blue's
        began = touching & ~self._partners_touching
        self._partners_touching = touching
        return began[np.arange(self.b), self.learner]

    def _pinned(self, pins: NDArray[np.bool_]) -> NDArray[np.bool_]:
        """Each robot of each match in a pinned red-blue pair this step, (B, R)."""
        out = np.zeros((self.b, self.world.n_robots), dtype=bool)
        for p, (red, blue) in enumerate(self.world.pin_pairs):
            out[:, red] |= pins[:, p]
            out[:, blue] |= pins[:, p]
        return out

    def _opponents(self, actions: F64, random: F64, j: int, cores: dict[int, FastCore]) -> Commands:
        """Opponent robot j's commands in each match: the caller's actions for a policy
        opponent, uniform random ones (RandomPlayer: through MatchCore.command, as a policy's),
        a stop (idle), a Python player's, or the planner's."""
        kinds = np.array(self._match_kinds)
        a = np.where((kinds == "random")[:, None], random, actions)
        them = self.robot_of(j, learning=False)
        lin, ang, intake, clamp = self._commands(a, them)
        idle = kinds == "idle"  # IdlePlayer: DriveCommand(0, 0), intake on, clamp automatic
        lin[idle], ang[idle], intake[idle], clamp[idle] = 0.0, 0.0, True, -1
        for m in range(self.b):
            player = self._players[m * self.a + j]
            if player is not None:
                i = int(them[m])
                core: Any = cores.get(m)
                if core is None:  # one view of the match serves both its robots' players
                    core = cores[m] = self._core(m)
                cmd = player.act(core, i, self.obs[m, i])
                lin[m], ang[m], intake[m], clamp[m] = command_row(cmd)
                if core.claims:  # what the player claimed, for its partner's observation
                    got = core.claims[i]
                    self.observer.claims[m, i] = (np.nan, np.nan) if got is None else got
        p = self._planning
        if p.any():  # the planner's DriveCommand: intake on, clamp automatic
            o = self.observer
            plan = self._opponent_planners[j].act(p, o.seen_pose, o.seen_rings)
            lin[p], ang[p], intake[p], clamp[p] = plan.linear[p], plan.angular[p], True, -1
        return lin, ang, intake, clamp

    def _commands(self, actions: F64, who: I64) -> Commands:
        """Actions (B, action_size) of robot `who` of each match -> (linear, angular, intake,
        clamp: 1 grab, 0 release, -1 automatic), as MatchCore.command and skill_command: a
        drive action scaled to the robot's top speeds, or skill scores driven by the robot's
        SkillDriver; then the actuators; anything non-finite a stop, intake off."""
        cfg = self.config
        w = self.world
        ok = np.isfinite(actions).all(axis=1)
        a = np.clip(np.where(ok[:, None], actions, 0.0), -1.0, 1.0)
        if cfg.skills is None or self._drivers is None:
            lin, ang, n = a[:, 0] * w.max_v[who], a[:, 1] * w.max_w[who], 2
        else:
            n = cfg.skills.n_options
            obs = self.obs[np.arange(self.b), who]
            lin, ang = self._drivers.command(obs, actions[:, :n], who, ok)
            if self.spec.partner:  # only the partner block reads the claims
                self._claim(who, ok)
        tail = a[:, n:]
        intake = ok & (tail[:, 0] > 0 if cfg.action_intake else True)
        clamp = np.full(self.b, -1, dtype=np.int8)
        if cfg.action_clamp:
            clamp = np.where(ok, (tail[:, int(cfg.action_intake)] > 0).astype(np.int8), -1)
        return lin, ang, intake, clamp.astype(np.int8)

    def _claim(self, who: I64, ok: NDArray[np.bool_]) -> None:
        """Robot who[b] of each match claims what its skill driver just drove to (MatchCore.claim:
        the field frame from where it stands), for its partner's observation; nothing where its
        action was not finite."""
        assert self._drivers is not None
        w = self.world
        mr = np.arange(self.b)
        kind, local = self._drivers.targets(who)
        rad = np.radians(w.heading[mr, who])
        s, c = np.sin(rad), np.cos(rad)
        fx = w.x[mr, who] + local[:, 0] * c + local[:, 1] * s
        fy = w.y[mr, who] - local[:, 0] * s + local[:, 1] * c
        claimed = ok & (kind > 0)
        claim = np.stack([np.where(claimed, fx, np.nan), np.where(claimed, fy, np.nan)], -1)
        self.observer.claims[mr, who] = claim

    # --- rewards ----------------------------------------------------------------------------

    def _reward_config(self, name: str) -> F64:
        """A RewardConfig weight per match (uncapped matches have their own reward), read-only:
        kept until a match starts."""
        weight = self._per_match.get(name)
        if weight is None:
            weight = np.where(
                self.uncapped,
                float(getattr(self._rewards[True], name) or 0.0),
                float(getattr(self._rewards[False], name) or 0.0),
            )
            weight.flags.writeable = False
            self._per_match[name] = weight
        return weight

    def _paid(self, name: str) -> bool:
        """Whether either of this run's rewards pays RewardConfig weight `name`."""
        return any(getattr(r, name) for r in self._rewards.values())

    def _potential_now(self, j: int) -> dict[str, F64]:
        """Learning robot j's shaping potentials now, (B,) each (MatchCore._shapings:
        sim.rewards' potentials, sim.fast.shaping's loop); a shaping neither reward pays is 0."""
        w = self.world
        mr = np.arange(self.b)
        me = self.robot_of(j)
        side = self.learner
        rad = np.radians(w.heading[mr, me])
        approach = self._paid("approach") & (self._reward_config("approach") != 0)
        goal = (self._paid("goal_approach") and w.n_goals > 0) & (
            self._reward_config("goal_approach") != 0
        )
        park = np.zeros(self.b, dtype=bool)
        platform = np.zeros((self.b, 4))
        if self._paid("park"):
            park_from = self._reward_config("park_from_s")
            park = (self._reward_config("park") != 0) & (w.time_s >= w.match_length_s - park_from)
            margin = self._reward_config("park_margin_m")[:, None]  # by match's reward
            platform[:, :2] = self._platforms[side, :2]
            platform[:, 2:] = np.maximum(self._platforms[side, 2:] / 2 - margin, 0.0)
        out = learner_potentials(
            w.x[mr, me], w.y[mr, me], np.sin(rad), np.cos(rad), w.half_l[me],
            w.room[mr, me], w.ring_xy, w.ring_floor, w.clamp_offsets[me],
            np.stack([w.gx, w.gy], -1), self._scores_for[side] & (w.carrier < 0),
            w.carried[mr, me] >= 0, platform, approach, goal, park,
        )  # fmt: skip
        return {"approach": out[:, 0], "goal_approach": out[:, 1], "park": out[:, 2]}

    def _margin_now(self) -> F64:
        """The learning alliance's lead in match score (0 when no reward pays it), (B,)."""
        if not self._paid("score"):
            return np.zeros(self.b)
        red, blue = self.world.totals()
        margin = (red - blue).astype(np.float64)
        return np.where(self.learner == 0, margin, -margin)

    def _reward(
        self,
        j: int,
        before: I64,
        clamped: I64,
        pinned: NDArray[np.bool_],
        ended: NDArray[np.bool_],
        margin: F64,
        met: NDArray[np.bool_],
    ) -> tuple[F64, F64]:
        """Learning robot j's reward for the step just taken (MatchCore.step's components),
        (B,) and (B, components): its own rings, pins, shapings and clamps; its alliance's
        score margin, goals, side and platform at the end; both partners' contact."""
        w = self.world
        mr = np.arange(self.b)
        me = self.robot_of(j)
        side = self.learner
        comp = np.zeros((self.b, len(REWARD_COMPONENTS)))
        col = _COLUMNS
        cap = self._ring_cap()
        now = w.collected[mr, me]
        counted = np.where(cap < 0, now - before, np.minimum(now, cap) - np.minimum(before, cap))
        comp[:, col["rings"]] = self._reward_config("ring") * counted
        comp[:, col["pin"]] = np.where(pinned, self._reward_config("pin"), 0.0)
        potentials = self._potential_now(j)
        for name, value in potentials.items():
            weight = self._reward_config(name)
            comp[:, col[name]] = weight * (self._potentials[j][name] - value)
            self._potentials[j][name] = value
        hurry = self._reward_config("hurry")
        comp[:, col["hurry"]] = np.where((cap >= 0) & (before < cap), hurry * w.dt, 0.0)
        if w.n_goals:
            ok = clamped >= 0
            g = np.where(ok, clamped, 0)
            scores = self._scores_for[side, g] & ok
            comp[:, col["clamp"]] = np.where(scores, self._reward_config("clamp"), 0.0)
        comp[:, col["score"]] = self._reward_config("score") * (margin - self._margin)
        comp[:, col["partner"]] = np.where(met, self._reward_config("partner_contact"), 0.0)
        end = ended & ~(pinned & self.config.end_on_pin)
        if end.any():
            comp[:, col["goals_end"]] = np.where(
                end, self._reward_config("goal_end") * self._goals_counting(), 0.0
            )
            theirs = np.where(side == 0, w.x[mr, me] > 0, w.x[mr, me] < 0)
            comp[:, col["side_end"]] = np.where(
                end & theirs, self._reward_config("opponent_side_end"), 0.0
            )
            plat_up = self._elevated()
            comp[:, col["elevated_end"]] = np.where(
                end & plat_up, self._reward_config("elevated_end"), 0.0
            )
        return comp.sum(axis=1), comp

    def _ring_cap(self) -> I64:
        """RewardConfig.ring_cap per match, -1 for none (read-only, kept as _reward_config's)."""
        cap = self._per_match.get(" ring_cap")
        if cap is None:
            caps = {u: -1 if r.ring_cap is None else r.ring_cap for u, r in self._rewards.items()}
            cap = np.where(self.uncapped, caps[True], caps[False])
            cap.flags.writeable = False
            self._per_match[" ring_cap"] = cap
        return cap

    def _goals_counting(self) -> F64:
        """Goals counting for the learning alliance in its own zone (MatchCore.goals_counting)."""
        w = self.world
        side = self.learner
        mine = self._scores_for[side]  # (B, G)
        if self.config.reward.goal_zone == "home":
            owner, _, _ = w.owners()
            counts = owner == (side + 1)[:, None]
        else:
            counts = (w.gx < 0) == (side == 0)[:, None]
        return (counts & mine).sum(axis=1).astype(np.float64)

    def _elevated(self) -> NDArray[np.bool_]:
        _, _, elevated = self.world.owners()
        return elevated[np.arange(self.b), self.learner]

    # --- results ----------------------------------------------------------------------------

    def _stats(self, m: int, j: int, by_pin: bool, red: I64, blue: I64) -> EpisodeStats:
        """Learning robot j's statistics of match m (red, blue: every match's score now): its
        reward, rings and pins; the match's score, and the opposing alliance's rings."""
        w = self.world
        row = m * self.a + j
        side = int(self.learner[m])
        me = int(self.robot_of(j)[m])
        mine, theirs = (red[m], blue[m]) if side == 0 else (blue[m], red[m])
        others = [i for i in range(w.n_robots) if i // self.a != side]
        fill = self.fill_time[row]
        return EpisodeStats(
            slot=row,
            kind=self._match_kinds[m],
            tag=self._match_tags[m],
            reward=float(self.total[row]),
            components={
                n: float(v) for n, v in zip(REWARD_COMPONENTS, self.totals[row], strict=True)
            },
            rings=int(w.collected[m, me]),
            fill_time_s=None if np.isnan(fill) else float(fill),
            score=float(mine),
            opponent_score=float(theirs),
            opponent_rings=int(w.collected[m, others].sum()),
            result=1.0 if mine > theirs else 0.5 if mine == theirs else 0.0,
            pins=int(self.pins[row]),
            length=int(self.steps[m]),
            ended_by_pin=by_pin,
            partner_collisions=int(self.partner_collisions[m]),
        )

    def _core(self, k: int) -> FastCore:
        """Match k now, as MatchCore's players read it."""
        return FastCore.of(self.world, self.observer, self.spec, self.config, k)

    def _skill_drivers(self, skills: SkillConfig) -> FastSkillDrivers:
        """Controllers for every robot of every match (MatchCore.skill_driver's: each robot's
        platform, size and speeds)."""
        w = self.world
        configs = [
            replace(skills, **skill_settings(w.field, w.alliances[i], w.robot_configs[i]))
            for i in range(w.n_robots)
        ]
        return FastSkillDrivers(configs, self.spec, self.b, w.dt)

    def _learner_obs(self) -> NDArray[np.float32]:
        """Each row's observation (n, spec.size)."""
        return self.obs[np.repeat(np.arange(self.b), self.a), self.row_robots()]

    def _deciding(self, mine: NDArray[np.float32]) -> NDArray[np.bool_]:
        """Whether each row's next action decides anything (VecMatches' deciding): False while
        a skill manoeuvre it committed to is under way."""
        if self._drivers is None:
            return np.ones(self.n, bool)
        out = np.ones(self.n, bool)
        everyone = np.ones(self.b, bool)
        for j in range(self.a):
            rows = self._rows(j)
            out[rows] = ~self._drivers.committed(mine[rows], self.robot_of(j), everyone)
        return out

    def _advice(self, mine: NDArray[np.float32]) -> NDArray[np.float32]:
        """The teacher's label for each row's observation (VecMatches' advice): the planner's
        (rollout.intent_label of what the batched planner does), or what the route skill
        drives (linear, angular in action units); NaN without a teacher."""
        out = np.full((self.n, advice_size(self.config)), np.nan, np.float32)
        if not self._teachers and self._routers is None:
            return out
        w, o = self.world, self.observer
        mr = np.arange(self.b)
        everyone = np.ones(self.b, dtype=bool)
        for j in range(self.a):
            rows, me = self._rows(j), self.robot_of(j)
            if self._teachers:
                plan = self._teachers[j].act(everyone, o.seen_pose, o.seen_rings)
                if self.config.skills is None:
                    out[rows] = drive_label(
                        plan.linear, plan.angular, self._max_v[me], self._max_w[me]
                    )
                else:
                    pose = np.stack([w.x[mr, me], w.y[mr, me], w.heading[mr, me]], -1)
                    out[rows] = self._labels(plan.intent, plan.point, pose, mine[rows])
            elif self._routers is not None:
                actions = np.broadcast_to(ROUTE_ACTION, (self.b, len(ROUTE_ACTION)))
                v, turn = self._routers.command(mine[rows], actions, me, everyone)
                out[rows] = drive_label(v, turn, self._max_v[me], self._max_w[me])
        return out

    def _result(
        self,
        rewards: NDArray[np.float32],
        dones: NDArray[np.bool_],
        final: NDArray[np.float32] | None,
        episodes: list[EpisodeStats],
    ) -> StepResult:
        mine = self._learner_obs()
        by_row = np.repeat(np.arange(self.b), self.a)
        opposite = np.stack([self.robot_of(j, learning=False) for j in range(self.a)], -1).reshape(
            -1
        )
        policy = np.array([k == "policy" for k in self.kinds])
        theirs = np.where(policy[:, None], self.obs[by_row, opposite], 0.0).astype(np.float32)
        return StepResult(
            mine,
            theirs,
            rewards,
            dones,
            np.zeros(self.n, bool),
            final if final is not None else np.zeros_like(mine),
            episodes,
            self._advice(mine),
            self._deciding(mine),
            np.repeat(self.uncapped, self.a),
        )
