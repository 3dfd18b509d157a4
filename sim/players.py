"""Who drives a robot in a match: one interface for policies, the planner, scripts and baselines.

    player.reset(core, index, rng)                 # a new match; `index` is the robot it drives
    command = player.act(core, index, obs)         # every control step; obs: jetson.autonomy.spec's

A player may read the World through `core` (the planner and the scripted chaser do: they see what
the robot's sensors give, via core.view); a learned policy only uses `obs`. Everything here is
deterministic for a given rng, so evaluations on the same seeds are comparable.

The whole game's players (sim/baselines/alliance.py): `AlliancePlayer`, one robot of the scripted
alliance (the robot's own strategy, jetson/autonomy/alliance.py, fed from the sensors), and
`ring_race_player(robot)`, one robot of the ring-race alliance. `PLAYERS` names the players a
tool can make by word.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Protocol

import numpy as np

from jetson.autonomy.skills import SkillConfig, SkillDriver
from sim.baselines.alliance import AlliancePlayer, ring_race_player
from sim.baselines.scripted import GreedyChaser
from sim.match import MatchCore
from sim.world.state import DriveCommand

ActionFn = Callable[[np.ndarray], np.ndarray]


class Player(Protocol):
    name: str

    def reset(self, core: MatchCore, index: int, rng: np.random.Generator) -> None: ...

    def act(self, core: MatchCore, index: int, obs: np.ndarray) -> DriveCommand: ...


class IdlePlayer:
    """Stands still at its start: an opponent that only takes up space."""

    name = "idle"

    def reset(self, core: MatchCore, index: int, rng: np.random.Generator) -> None:
        pass

    def act(self, core: MatchCore, index: int, obs: np.ndarray) -> DriveCommand:
        return DriveCommand(0.0, 0.0)


class RandomPlayer:
    """Uniform random actions in [-1, 1]: the floor every metric must be measured against."""

    name = "random"

    def __init__(self) -> None:
        self._rng = np.random.default_rng(0)

    def reset(self, core: MatchCore, index: int, rng: np.random.Generator) -> None:
        self._rng = np.random.default_rng(rng.integers(2**63))

    def act(self, core: MatchCore, index: int, obs: np.ndarray) -> DriveCommand:
        return core.command(index, self._rng.uniform(-1.0, 1.0, core.config.action_size))


class ScriptedPlayer:
    """sim.baselines.scripted's greedy ring-chaser (ground-truth rings): the stock opponent."""

    name = "scripted"

    def __init__(self) -> None:
        self._chaser: GreedyChaser | None = None

    def reset(self, core: MatchCore, index: int, rng: np.random.Generator) -> None:
        self._chaser = GreedyChaser(index)

    def act(self, core: MatchCore, index: int, obs: np.ndarray) -> DriveCommand:
        assert self._chaser is not None, "act() before reset()"
        return self._chaser.act(core.world)


class PolicyPlayer:
    """A policy that maps the stacked observation to an action in [-1, 1]^n, or, with
    `skills`, to one score per skill that its own controller drives (jetson/autonomy/skills.py)."""

    def __init__(self, fn: ActionFn, name: str = "policy", skills: SkillConfig | None = None):
        self.fn = fn
        self.name = name
        self.skills = skills
        self._driver: SkillDriver | None = None

    def reset(self, core: MatchCore, index: int, rng: np.random.Generator) -> None:
        if self.skills is not None:
            self._driver = core.skill_driver(index, self.skills)

    def act(self, core: MatchCore, index: int, obs: np.ndarray) -> DriveCommand:
        if self._driver is None:
            return core.command(index, self.fn(obs))
        action = np.asarray(self.fn(obs), dtype=np.float64)
        if not np.all(np.isfinite(action)):
            if core.claims:
                core.claims[index] = None  # a stop claims nothing
            return DriveCommand(0.0, 0.0)
        linear, angular = self._driver.command(obs, action)
        # The controller lets go of a goal in a tug of war it loses (release_dragged_s).
        command = DriveCommand(linear, angular, clamp=False if self._driver.release else None)
        core.claim(index, self._driver)  # its skill's target: its partner's observation reads it
        return command


def _ring_race_24() -> Player:
    return ring_race_player("24in")


def _ring_race_15() -> Player:
    return ring_race_player("15in")


# Players made by word (whole-game tools; `pete-sim eval` has its own list, sim/evaluate.py).
PLAYERS: dict[str, Callable[[], Player]] = {
    "alliance": AlliancePlayer,
    "ring-race-24in": _ring_race_24,
    "ring-race-15in": _ring_race_15,
    "scripted": ScriptedPlayer,
    "idle": IdlePlayer,
    "random": RandomPlayer,
}
