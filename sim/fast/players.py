"""Players written against MatchCore (the planner, the scripted chaser) on one fast match.

    core = FastCore.of(matches.world, matches.observer, matches.spec, matches.config, k)
    command = planner.act(core, index)

MatchCore gives a player two things: the match's world (sim.world.state's robots, goals, rings
and clock) and each robot's view (its GPS reading and the rings its camera sees, MatchCore.view).
FastCore gives the same for match k of a FastWorld: match_view(world, k), and the reading and
rings the FastObserver built that robot's frame from in this control step (the same reading,
as MatchCore's GPS read twice in one step is). The players themselves are unchanged: the
greedy chaser as an opponent in FastMatches, a Python call per match and step, as on PyBullet;
and the planner, which FastMatches plays batched (sim.fast.planner) and the tests hold to the
planner playing through FastCore.
"""

from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.observation import RobotView
from jetson.autonomy.spec import ObservationSpec
from sim.fast.observe import FastObserver
from sim.fast.view import MatchView, match_view
from sim.fast.world import FastWorld
from sim.match import EnvConfig, robot_view
from sim.world.state import DriveCommand


@dataclass
class FastCore:
    """One fast match as a MatchCore's player reads it (module docstring)."""

    world: MatchView
    spec: ObservationSpec
    config: EnvConfig
    seen_pose: NDArray[np.float64]  # (R, 3): each robot's GPS reading this step
    seen_rings: NDArray[np.bool_]  # (R, N): the floor rings each robot's camera saw
    # Each robot's claimed target (field frame, None: nothing), as MatchCore.claims: empty
    # unless the spec has the partner block. A player writes its robot's claim here and
    # FastMatches hands it on to the observer.
    claims: list[tuple[float, float] | None] = field(default_factory=list)

    @classmethod
    def of(
        cls,
        world: FastWorld,
        observer: FastObserver,
        spec: ObservationSpec,
        config: EnvConfig,
        k: int,
    ) -> FastCore:
        """Match k now (a copy: stepping the world does not change it)."""
        claims: list[tuple[float, float] | None] = []
        if spec.partner:
            claims = [
                None if np.isnan(c).any() else (float(c[0]), float(c[1]))
                for c in observer.claims[k]
            ]
        return cls(
            match_view(world, k),
            spec,
            config,
            observer.seen_pose[k].copy(),
            observer.seen_rings[k].copy(),
            claims,
        )

    def view(self, index: int) -> RobotView:
        """What robot `index` knows (MatchCore.view): the GPS reading, the rings its camera
        saw this step in its frame, the other robots, its intake and clamp."""
        x, y, h = (float(v) for v in self.seen_pose[index])
        rings = np.flatnonzero(self.seen_rings[index])
        claims = self.claims or None
        return robot_view(self.world, self.spec, index, (x, y, h), rings, claims)  # type: ignore[arg-type]


def command_row(cmd: DriveCommand) -> tuple[float, float, bool, int]:
    """A DriveCommand as FastWorld.step's row: linear, angular, intake, clamp (1 grab,
    0 release, -1 automatic)."""
    clamp = -1 if cmd.clamp is None else int(bool(cmd.clamp))
    return float(cmd.linear), float(cmd.angular), bool(cmd.intake), clamp
