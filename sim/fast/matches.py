"""Self-play matches on the batched backend, with VecMatches' interface (sim.training.rollout).

    envs = FastMatches(env_config, RolloutConfig(envs_per_worker=4096, workers=0), seed=1)
    step = envs.reset()                         # StepResult: learner and opponent observations
    step = envs.step(learner_actions, opponent_actions)

Every slot is one 1v1 match of one FastWorld; `rollout.n_envs` slots, all stepped together. The
learner's side is drawn per match as VecMatches draws it (learner_side), from the same per-match
generator np.random.default_rng((seed, slot, match number)), which then starts the world as
World.reset would. Rewards are MatchCore's components (sim.match.REWARD_COMPONENTS) for the
learner, the shaping potentials sim.rewards' (sim.fast.shaping: compiled); the start curricula
(goal_start_share, midgame_start_share) are drawn as MatchCore draws them. Opponents: "policy"
(the caller's actions), "random", "idle", "planner" (sim.fast.planner: the planner for every
match at once) and "scripted" (the greedy chaser, written against MatchCore, playing its match
through sim.fast.players.FastCore, a Python call per match and step); "none" (no opponent robot)
stays on the PyBullet backend (ConfigError names it). The ring and goal memories and the route
slots are batched (sim.fast.memory). A skill policy's scores drive each robot's SkillDriver
(jetson.autonomy.skills) for every robot of every match at once (sim.fast.skills), and intake and
clamp actions run the actuators as MatchCore.command does. Teachers: the route skill's
controller (sim.fast.skills, one for each match's learner) and the planner (sim.fast.planner),
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
from sim.players import Player, ScriptedPlayer
from sim.training.rollout import (
    ROUTE_ACTION,
    ROUTE_SKILL,
    TEACHERS,
    EpisodeStats,
    RolloutConfig,
    StepResult,
    advice_size,
    drive_label,
    teacher_for,
)

FAST_OPPONENTS = ("policy", "random", "idle", "planner", "scripted")
_COLUMNS = {name: i for i, name in enumerate(REWARD_COMPONENTS)}  # reward components' columns
F64 = NDArray[np.float64]
Commands = tuple[F64, F64, NDArray[np.bool_], NDArray[np.int8]]  # linear, angular, intake, clamp


def fast_unsupported(config: EnvConfig, teacher: str = "none") -> list[str]:
    """What of a training setup the fast backend cannot run yet (empty: all of it)."""
    out = unsupported(config.world)
    if len(config.world.red) != 1 or len(config.world.blue) != 1:
        out.append("a match that is not 1v1 (training matches are one robot a side)")
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
        self.config = config
        self.rollout = rollout
        self.seed = seed
        n = rollout.n_envs
        self.n = n
        self.world = FastWorld(config.world, n)
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
        self.kinds = ["idle"] * n
        self.tags = [-1] * n
        self._pending: dict[int, tuple[str, int]] = {}
        self.episode = np.zeros(n, dtype=np.int64)
        self.learner = np.zeros(n, dtype=np.int64)  # 0 red, 1 blue (1v1)
        self.uncapped = np.zeros(n, dtype=bool)
        self.limits = np.array(
            [
                min([x for x in (config.max_steps, rollout.slot_limit(k)) if x] or [1 << 40])
                for k in range(n)
            ]
        )
        self._rewards = {False: config.reward, True: config.match_reward(True)}
        self._per_match: dict[str, NDArray[Any]] = {}  # rewards by match: _reward_config's
        plats = [self.world.field.platform(a) for a in ("red", "blue")]
        self._platforms = np.array([[*p.center, *p.size] for p in plats])  # by learner side
        self.steps = np.zeros(n, dtype=np.int64)
        self.total = np.zeros(n)
        self.totals = np.zeros((n, len(REWARD_COMPONENTS)))
        self.fill_time = np.full(n, np.nan)
        self.pins = np.zeros(n, dtype=np.int64)
        self._potentials: dict[str, F64] = {}
        self._margin = np.zeros(n)
        self.obs = np.zeros((n, 2, self.spec.size), np.float32)
        # The route teacher: the route skill's controller of each match's learner.
        self._route_teacher = teacher == "route"
        self._routers: FastSkillDrivers | None = None
        if self._route_teacher:
            self._routers = self._skill_drivers(ROUTE_SKILL)
        # A skill policy's controllers: each match's two robots' (MatchCore.skill_driver).
        self._drivers: FastSkillDrivers | None = None
        if config.skills is not None:
            self._drivers = self._skill_drivers(config.skills)
        rcs = self.world.robot_configs
        self._max_v = np.array([rc.max_linear_mps for rc in rcs])  # drive_label's speeds
        self._max_w = np.array([rc.max_angular_rad_s for rc in rcs])
        # Python players: each match's scripted chaser.
        self._players: list[Player | None] = [None] * n
        # The planner: the opponent where `_planning`, and the teacher of every learner.
        self._planning = np.zeros(n, dtype=bool)
        self._opponent_planner = FastPlanner(self.world)
        self._teacher_configs = {
            u: teacher_for(config.match_reward(u)).config for u in (False, True)
        }
        self._teacher: FastPlanner | None = None
        if teacher == "planner":
            self._teacher = FastPlanner(self.world, self._teacher_configs[False])
        if config.skills is not None:  # the planner's label for a skill policy
            self._labels = OptionLabels(self.spec, config.skills)

    # --- VecMatches' interface ---------------------------------------------------------------

    def set_kinds(self, kinds: list[tuple[str, int]]) -> None:
        """Each slot's opponent from its next match on (VecMatches.set_kinds)."""
        if len(kinds) != self.n:
            raise ConfigError(f"set_kinds needs {self.n} kinds, got {len(kinds)}")
        for k, (kind, tag) in enumerate(kinds):
            if kind not in FAST_OPPONENTS:
                raise ConfigError(
                    f"--backend fast plays opponents {FAST_OPPONENTS}, not {kind!r} (set "
                    "[opponents] to the pool, or use the PyBullet backend)"
                )
            self._pending[k] = (kind, tag)

    def reset(self) -> StepResult:
        self._start(np.arange(self.n))
        self.obs = self.observer.reset()
        return self._result(np.zeros(self.n, np.float32), np.zeros(self.n, bool), None, [])

    def step(self, actions: np.ndarray, opponent_actions: np.ndarray) -> StepResult:
        w = self.world
        rows = np.arange(self.n)
        me, them = self.learner, 1 - self.learner
        lin = np.zeros((self.n, 2))
        ang = np.zeros((self.n, 2))
        intake = np.ones((self.n, 2), dtype=bool)
        clamp = np.full((self.n, 2), -1, dtype=np.int8)
        mine = self._drive(np.asarray(actions, dtype=np.float64))
        theirs = self._opponents(np.asarray(opponent_actions, dtype=np.float64))
        for cmd, who in ((mine, me), (theirs, them)):
            lin[rows, who], ang[rows, who], intake[rows, who], clamp[rows, who] = cmd
        before = w.collected[rows, me].copy()
        events = w.step(lin, ang, intake, clamp)
        self.obs = self.observer.push()
        pinned = events.pins[:, 0] if events.pins.shape[1] else np.zeros(self.n, bool)
        ended = events.match_over | (pinned & self.config.end_on_pin)
        rewards, comps = self._reward(before, events.clamped[rows, me], pinned, ended)
        self.steps += 1
        self.total += rewards
        self.totals += comps
        self.pins += pinned
        filled = np.isnan(self.fill_time) & (w.collected[rows, me] >= self.rollout.fill_target)
        self.fill_time = np.where(filled, w.time_s, self.fill_time)
        terminal = ended | (filled & self.rollout.end_at_fill)
        truncated = ~terminal & (self.steps >= self.limits)
        done = terminal | truncated
        final = None
        episodes: list[EpisodeStats] = []
        if done.any():
            which = np.flatnonzero(done)
            if truncated.any():
                final = self.obs[rows, me].copy()
            red, blue = self.world.totals()
            by_pin = pinned & self.config.end_on_pin
            episodes = [self._stats(int(k), bool(by_pin[k]), red, blue) for k in which]
            self._start(which)
            self.obs[which] = self.observer.reset(which)[which]
        result = self._result(rewards.astype(np.float32), done, final, episodes)
        result.truncated = truncated
        return result

    def close(self) -> None:
        """Nothing to release: no processes, no PyBullet clients."""

    def __enter__(self) -> FastMatches:
        return self

    def __exit__(self, *exc: object) -> None:
        self.close()

    # --- matches ----------------------------------------------------------------------------

    def _start(self, which: NDArray[np.int64]) -> None:
        """New matches in slots `which`: side, start, intakes, rewards, bookkeeping."""
        side = self.rollout.learner_side
        rngs = []
        for k in which:
            if k in self._pending:
                self.kinds[k], self.tags[k] = self._pending.pop(k)
            rng = np.random.default_rng((self.seed, int(k), int(self.episode[k])))
            self.episode[k] += 1
            red = rng.random() < 0.5 if side == "random" else side == "red"
            self.learner[k] = 0 if red else 1
            rngs.append(rng)
        rngs = self.world.reset_matches(which, rngs)
        share = self.config.uncapped_share
        for k, rng in zip(which, rngs, strict=True):
            uncapped = share > 0 and rng.random() < share
            self.uncapped[k] = uncapped
            if uncapped:
                self.world.room_cap[k] = 1 << 30
            self._curricula(int(k), rng)
        self._per_match.clear()  # the matches' rewards change with their intakes
        for drivers in (self._routers, self._drivers):
            if drivers is not None:  # fresh controllers (MatchCore.skill_driver)
                drivers.reset(which)
        # The players start from the match as it starts (after the curricula), as on PyBullet
        # (their reset reads the field and the robots, not the sensors).
        for k, rng in zip(which, rngs, strict=True):
            kind = self.kinds[k]
            me = int(self.learner[k])
            self._players[k] = None
            self._planning[k] = kind == "planner"
            if kind == "planner":
                self._opponent_planner.reset(np.array([k]), np.array([1 - me]))
            if kind == "scripted":
                core: Any = self._core(int(k))  # what a MatchCore gives its players
                player = ScriptedPlayer()
                player.reset(core, 1 - me, rng)
                self._players[k] = player
            if self._teacher is not None:
                teaching = self._teacher_configs[bool(self.uncapped[k])]
                self._teacher.reset(np.array([k]), np.array([me]), teaching)
        self.steps[which] = 0
        self.total[which] = 0.0
        self.totals[which] = 0.0
        self.fill_time[which] = np.nan
        self.pins[which] = 0
        potentials = self._potential_now()
        for name, value in potentials.items():
            old = self._potentials.get(name, value)
            old[which] = value[which]
            self._potentials[name] = old
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

    def _drive(self, actions: F64) -> Commands:
        """The learners' actions (B, action_size) -> their commands (MatchCore.command)."""
        if actions.shape != (self.n, self.config.action_size):
            raise ValueError(f"actions must have shape ({self.n}, {self.config.action_size})")
        return self._commands(actions, self.learner)

    def _opponents(self, actions: F64) -> Commands:
        """The opponents' commands: the caller's actions for a policy opponent, uniform random
        ones (RandomPlayer: through MatchCore.command, as a policy's), or a stop (idle)."""
        if actions.shape != (self.n, self.config.action_size):
            raise ValueError(
                f"opponent actions must have shape ({self.n}, {self.config.action_size})"
            )
        kinds = np.array(self.kinds)
        random = self._player_rng.uniform(-1.0, 1.0, actions.shape)
        a = np.where((kinds == "random")[:, None], random, actions)
        them = 1 - self.learner
        lin, ang, intake, clamp = self._commands(a, them)
        idle = kinds == "idle"  # IdlePlayer: DriveCommand(0, 0), intake on, clamp automatic
        lin[idle], ang[idle], intake[idle], clamp[idle] = 0.0, 0.0, True, -1
        for k, player in enumerate(self._players):
            if player is not None:
                i = int(them[k])
                core: Any = self._core(k)
                cmd = player.act(core, i, self.obs[k, i])
                lin[k], ang[k], intake[k], clamp[k] = command_row(cmd)
        p = self._planning
        if p.any():  # the planner's DriveCommand: intake on, clamp automatic
            o = self.observer
            plan = self._opponent_planner.act(p, o.seen_pose, o.seen_rings)
            lin[p], ang[p], intake[p], clamp[p] = plan.linear[p], plan.angular[p], True, -1
        return lin, ang, intake, clamp

    def _commands(self, actions: F64, who: NDArray[np.int64]) -> Commands:
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
            obs = self.obs[np.arange(self.n), who]
            lin, ang = self._drivers.command(obs, actions[:, :n], who, ok)
            if self.spec.partner:  # only the partner block reads the claims
                self._claim(who, ok)
        tail = a[:, n:]
        intake = ok & (tail[:, 0] > 0 if cfg.action_intake else True)
        clamp = np.full(self.n, -1, dtype=np.int8)
        if cfg.action_clamp:
            clamp = np.where(ok, (tail[:, int(cfg.action_intake)] > 0).astype(np.int8), -1)
        return lin, ang, intake, clamp.astype(np.int8)

    def _claim(self, who: NDArray[np.int64], ok: NDArray[np.bool_]) -> None:
        """Robot who[b] of each match claims what its skill driver just drove to (MatchCore.claim:
        the field frame from where it stands), for its partner's observation; nothing where its
        action was not finite."""
        assert self._drivers is not None
        w = self.world
        rows = np.arange(self.n)
        kind, local = self._drivers.targets(who)
        rad = np.radians(w.heading[rows, who])
        s, c = np.sin(rad), np.cos(rad)
        fx = w.x[rows, who] + local[:, 0] * c + local[:, 1] * s
        fy = w.y[rows, who] - local[:, 0] * s + local[:, 1] * c
        claimed = ok & (kind > 0)
        claim = np.stack([np.where(claimed, fx, np.nan), np.where(claimed, fy, np.nan)], -1)
        self.observer.claims[rows, who] = claim

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

    def _potential_now(self) -> dict[str, F64]:
        """The learner's shaping potentials now, (B,) each (MatchCore._shapings: sim.rewards'
        potentials, sim.fast.shaping's loop); a shaping neither reward pays is 0."""
        w = self.world
        rows = np.arange(self.n)
        me = self.learner
        rad = np.radians(w.heading[rows, me])
        approach = self._paid("approach") & (self._reward_config("approach") != 0)
        goal = (self._paid("goal_approach") and w.n_goals > 0) & (
            self._reward_config("goal_approach") != 0
        )
        park = np.zeros(self.n, dtype=bool)
        platform = np.zeros((self.n, 4))
        if self._paid("park"):
            park_from = self._reward_config("park_from_s")
            park = (self._reward_config("park") != 0) & (w.time_s >= w.match_length_s - park_from)
            margin = self._reward_config("park_margin_m")[:, None]  # by match's reward
            platform[:, :2] = self._platforms[me, :2]
            platform[:, 2:] = np.maximum(self._platforms[me, 2:] / 2 - margin, 0.0)
        out = learner_potentials(
            w.x[rows, me], w.y[rows, me], np.sin(rad), np.cos(rad), w.half_l[me],
            w.room[rows, me], w.ring_xy, w.ring_floor, w.clamp_offsets[me],
            np.stack([w.gx, w.gy], -1), self._scores_for[me] & (w.carrier < 0),
            w.carried[rows, me] >= 0, platform, approach, goal, park,
        )  # fmt: skip
        return {"approach": out[:, 0], "goal_approach": out[:, 1], "park": out[:, 2]}

    def _margin_now(self) -> F64:
        """The learner alliance's lead in match score (0 when no reward pays it)."""
        if not self._paid("score"):
            return np.zeros(self.n)
        red, blue = self.world.totals()
        margin = (red - blue).astype(np.float64)
        return np.where(self.learner == 0, margin, -margin)

    def _reward(
        self,
        before: NDArray[np.int64],
        clamped: NDArray[np.int64],
        pinned: NDArray[np.bool_],
        ended: NDArray[np.bool_],
    ) -> tuple[F64, F64]:
        """The learner's reward for the step just taken (MatchCore.step's components)."""
        w = self.world
        rows = np.arange(self.n)
        me = self.learner
        comp = np.zeros((self.n, len(REWARD_COMPONENTS)))
        col = _COLUMNS
        cap = self._ring_cap()
        now = w.collected[rows, me]
        counted = np.where(cap < 0, now - before, np.minimum(now, cap) - np.minimum(before, cap))
        comp[:, col["rings"]] = self._reward_config("ring") * counted
        comp[:, col["pin"]] = np.where(pinned, self._reward_config("pin"), 0.0)
        potentials = self._potential_now()
        for name, value in potentials.items():
            weight = self._reward_config(name)
            comp[:, col[name]] = weight * (self._potentials[name] - value)
            self._potentials[name] = value
        hurry = self._reward_config("hurry")
        comp[:, col["hurry"]] = np.where((cap >= 0) & (before < cap), hurry * w.dt, 0.0)
        if w.n_goals:
            ok = clamped >= 0
            g = np.where(ok, clamped, 0)
            scores = self._scores_for[me, g] & ok
            comp[:, col["clamp"]] = np.where(scores, self._reward_config("clamp"), 0.0)
        margin = self._margin_now()
        comp[:, col["score"]] = self._reward_config("score") * (margin - self._margin)
        self._margin = margin
        end = ended & ~(pinned & self.config.end_on_pin)
        if end.any():
            comp[:, col["goals_end"]] = np.where(
                end, self._reward_config("goal_end") * self._goals_counting(), 0.0
            )
            theirs = np.where(me == 0, w.x[rows, me] > 0, w.x[rows, me] < 0)
            comp[:, col["side_end"]] = np.where(
                end & theirs, self._reward_config("opponent_side_end"), 0.0
            )
            plat_up = self._elevated()
            comp[:, col["elevated_end"]] = np.where(
                end & plat_up, self._reward_config("elevated_end"), 0.0
            )
        return comp.sum(axis=1), comp

    def _ring_cap(self) -> NDArray[np.int64]:
        """RewardConfig.ring_cap per match, -1 for none (read-only, kept as _reward_config's)."""
        cap = self._per_match.get(" ring_cap")
        if cap is None:
            caps = {u: -1 if r.ring_cap is None else r.ring_cap for u, r in self._rewards.items()}
            cap = np.where(self.uncapped, caps[True], caps[False])
            cap.flags.writeable = False
            self._per_match[" ring_cap"] = cap
        return cap

    def _goals_counting(self) -> F64:
        """Goals counting for the learner's alliance in its own zone (MatchCore.goals_counting)."""
        w = self.world
        me = self.learner
        mine = self._scores_for[me]  # (B, G)
        if self.config.reward.goal_zone == "home":
            owner, _, _ = w.owners()
            counts = owner == (me + 1)[:, None]
        else:
            counts = (w.gx < 0) == (me == 0)[:, None]
        return (counts & mine).sum(axis=1).astype(np.float64)

    def _elevated(self) -> NDArray[np.bool_]:
        _, _, elevated = self.world.owners()
        return elevated[np.arange(self.n), self.learner]

    # --- results ----------------------------------------------------------------------------

    def _stats(
        self, k: int, by_pin: bool, red: NDArray[np.int64], blue: NDArray[np.int64]
    ) -> EpisodeStats:
        """Match k's statistics (red, blue: every match's score now)."""
        w = self.world
        me = int(self.learner[k])
        mine, theirs = (red[k], blue[k]) if me == 0 else (blue[k], red[k])
        kind = self.kinds[k]
        fill = self.fill_time[k]
        return EpisodeStats(
            slot=k,
            kind=kind,
            tag=self.tags[k],
            reward=float(self.total[k]),
            components={
                n: float(v) for n, v in zip(REWARD_COMPONENTS, self.totals[k], strict=True)
            },
            rings=int(w.collected[k, me]),
            fill_time_s=None if np.isnan(fill) else float(fill),
            score=float(mine),
            opponent_score=float(theirs),
            opponent_rings=int(w.collected[k, 1 - me]),
            result=1.0 if mine > theirs else 0.5 if mine == theirs else 0.0,
            pins=int(self.pins[k]),
            length=int(self.steps[k]),
            ended_by_pin=by_pin,
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
        return FastSkillDrivers(configs, self.spec, self.n, w.dt)

    def _deciding(self, mine: NDArray[np.float32]) -> NDArray[np.bool_]:
        """Whether each learner's next action decides anything (VecMatches' deciding): False
        while a skill manoeuvre it committed to is under way."""
        if self._drivers is None:
            return np.ones(self.n, bool)
        return ~self._drivers.committed(mine, self.learner, np.ones(self.n, bool))

    def _advice(self, mine: NDArray[np.float32]) -> NDArray[np.float32]:
        """The teacher's label for each learner observation (VecMatches' advice): the
        planner's (rollout.intent_label of what the batched planner does), or what the route
        skill drives (linear, angular in action units); NaN without a teacher."""
        out = np.full((self.n, advice_size(self.config)), np.nan, np.float32)
        me = self.learner
        everyone = np.ones(self.n, dtype=bool)
        if self._teacher is not None:
            w, o = self.world, self.observer
            plan = self._teacher.act(everyone, o.seen_pose, o.seen_rings)
            if self.config.skills is None:
                return drive_label(plan.linear, plan.angular, self._max_v[me], self._max_w[me])
            rows = np.arange(self.n)
            pose = np.stack([w.x[rows, me], w.y[rows, me], w.heading[rows, me]], -1)
            return self._labels(plan.intent, plan.point, pose, mine)
        if self._routers is None:
            return out
        actions = np.broadcast_to(ROUTE_ACTION, (self.n, len(ROUTE_ACTION)))
        v, w = self._routers.command(mine, actions, me, everyone)
        return drive_label(v, w, self._max_v[me], self._max_w[me])

    def _result(
        self,
        rewards: NDArray[np.float32],
        dones: NDArray[np.bool_],
        final: NDArray[np.float32] | None,
        episodes: list[EpisodeStats],
    ) -> StepResult:
        rows = np.arange(self.n)
        mine = self.obs[rows, self.learner]
        policy = np.array([k == "policy" for k in self.kinds])
        theirs = np.where(policy[:, None], self.obs[rows, 1 - self.learner], 0.0).astype(np.float32)
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
            self.uncapped.copy(),
        )
