"""`pete-sim match --world tipping_point_2v2 --stack sim`: one seeded match of the whole game in the
simulator, every robot driven by a player from the registry (sim.evaluate.load_player), recorded
as a run folder:

    summary.txt / summary.json   both alliances' score by element and the fouls, one by one
    replay.gif / replay.png      top-down (sim.render): the platforms' tilt, the goals' owners,
                                 the rings on branches and bases; replay.png is the last frame

The full stack (sim/fullstack) drives one robot of the ring race and does not play the whole game
yet; the command line refuses --world with --stack full.
"""

from __future__ import annotations

import json
import time
from collections.abc import Callable
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from sim.errors import EvalError
from sim.evaluate import (
    ELEMENTS,
    YES_NO,
    element_breakdown,
    eval_env,
    load_side,
    make_cores,
    play_match,
    side_label,
)
from sim.match import MatchCore
from sim.world import rules


@dataclass(frozen=True)
class GameMatchOptions:
    """One whole-game match. red / blue: a player name for every robot of the alliance, or
    NAME,NAME one per robot (as `pete-sim eval` takes them); blue "none" leaves it empty."""

    world: str
    out: Path
    seed: int = 0
    red: str = "scripted"
    blue: str = "planner"
    scenario: str = "capped"
    seconds: float | None = None
    gif: bool = True
    gif_every_s: float = 0.5
    gif_size: int = 400


@dataclass
class GameMatchResult:
    world: str
    seed: int
    players: dict[str, list[str]]  # alliance -> each robot's "name (player)"
    sim_s: float
    wall_s: float
    score: dict[str, dict[str, Any]]  # alliance -> element_breakdown
    fouls: list[dict[str, Any]]
    files: dict[str, str] = field(default_factory=dict)

    @property
    def winner(self) -> str:
        red, blue = self.score["red"]["total"], self.score["blue"]["total"]
        return "red" if red > blue else "blue" if blue > red else "draw"

    def as_dict(self) -> dict[str, Any]:
        return {
            "stack": "sim",
            "world": self.world,
            "seed": self.seed,
            "players": self.players,
            "sim_s": self.sim_s,
            "wall_s": self.wall_s,
            "winner": self.winner,
            "score": self.score,
            "fouls": self.fouls,
            "files": self.files,
        }

    def table(self) -> str:
        red, blue = self.score["red"], self.score["blue"]
        rows = [("", "red", "blue"), ("score", str(red["total"]), str(blue["total"]))]
        for key, name in ELEMENTS:
            if key in YES_NO:
                rows.append((name, "yes" if red[key] else "no", "yes" if blue[key] else "no"))
            else:
                rows.append((name, str(red[key]), str(blue[key])))
        w0 = max(len(r[0]) for r in rows)
        w1 = max(len(r[1]) for r in rows)
        lines = [
            f"{self.world}, seed {self.seed}, {self.sim_s:.1f} s of play "
            f"({self.wall_s:.1f} s wall), sim stack",
            *(f"{al}: {', '.join(names)}" for al, names in self.players.items()),
            *(f"{r[0]:<{w0}}  {r[1]:>{w1}}  {r[2]}" for r in rows),
        ]
        result = "a draw" if self.winner == "draw" else f"{self.winner} wins"
        lines.append(f"{result}; fouls ({len(self.fouls)}):")
        lines += [f"  {f['time_s']:6.2f} s  {f['robot']:<7} {f['kind']}" for f in self.fouls] or [
            "  none"
        ]
        return "\n".join(lines)


def _labels(core: MatchCore, red: str, blue: str) -> dict[str, list[str]]:
    words = {"red": red, "blue": blue}
    out: dict[str, list[str]] = {}
    for alliance in rules.ALLIANCES:
        robots = [r for r in core.world.robots if r.alliance == alliance]
        names = [w.strip() for w in words[alliance].split(",")]
        if len(names) == 1:
            names = names * len(robots)
        pairs = zip(robots, names, strict=True)
        out[alliance] = [f"{r.name} {r.config.name} ({n})" for r, n in pairs]
    return out


def run_game_match(
    options: GameMatchOptions, progress: Callable[[str], None] | None = None
) -> GameMatchResult:
    """Play the match and write its run folder; EvalError names what is wrong with the options."""
    from sim.render import save_gif, save_png, top_down

    o = options
    if o.gif_every_s <= 0:
        raise EvalError(f"--gif-every must be positive, got {o.gif_every_s}")
    if not 64 <= o.gif_size <= 2048:
        raise EvalError(f"--gif-size must be within 64..2048, got {o.gif_size}")
    wall0 = time.perf_counter()
    red = load_side(o.red)
    blue = None if o.blue == "none" else load_side(o.blue)
    specs = [s.spec for s in red + (blue or ()) if s.spec is not None]
    if len({s.fingerprint() for s in specs}) > 1:
        raise EvalError("the players' policies expect different observations")
    env = eval_env(o.scenario, "training", specs[0] if specs else None, world=o.world)
    if o.seconds is not None:
        if o.seconds <= 0:
            raise EvalError(f"--seconds must be positive, got {o.seconds}")
        env = replace(env, max_steps=max(1, round(o.seconds * env.world.control_hz)))
    cores = make_cores(env)
    core = cores["duel"] if blue is not None else cores["solo-red"]
    counts = {al: sum(1 for x, _ in core.world.lineup if x == al) for al in rules.ALLIANCES}

    def players(specs: tuple[Any, ...], n: int) -> list[Any]:
        if len(specs) not in (1, n):
            raise EvalError(
                f"{len(specs)} players ({side_label(specs)}) for an alliance of {n} robot(s): "
                "give one name for all its robots, or one per robot"
            )
        return [s.make() for s in (specs * n if len(specs) == 1 else specs)]

    frames: list[np.ndarray] = []
    next_gif = [0.0]
    report = progress or (lambda _msg: None)
    next_note = [15.0]

    def on_step(core: MatchCore, results: list[Any]) -> None:
        w = core.world
        if o.gif and w.time_s + 1e-9 >= next_gif[0]:
            if not frames:  # the start, before the first step's picture
                next_gif[0] = w.time_s
            frames.append(top_down(w, o.gif_size))
            next_gif[0] += o.gif_every_s
        if w.time_s + 1e-9 >= next_note[0]:
            s = w.score()
            report(f"{w.time_s:5.1f} s: red {s['red'].total}, blue {s['blue'].total}")
            next_note[0] += 15.0

    try:
        play_match(
            cores,
            players(red, counts["red"]),
            players(blue, counts["blue"]) if blue is not None else None,
            o.seed,
            "red",
            on_step=on_step,
        )
        w = core.world
        labels = _labels(core, o.red, o.blue if blue is not None else "")
        if o.gif:
            frames.append(top_down(w, o.gif_size))
        result = GameMatchResult(
            world=o.world,
            seed=o.seed,
            players={k: v for k, v in labels.items() if v},
            sim_s=round(w.time_s, 6),
            wall_s=0.0,
            score=element_breakdown(w),
            fouls=[
                {
                    "time_s": round(f.time_s, 3),
                    "robot": w.robots[f.robot].name,
                    "alliance": f.alliance,
                    "kind": f.kind,
                }
                for f in w.fouls
            ],
        )
    finally:
        for c in cores.values():
            c.close()
    folder = o.out
    folder.mkdir(parents=True, exist_ok=True)
    if frames:
        fps = min(25.0, max(2.0, 4.0 / o.gif_every_s))
        result.files["gif"] = str(save_gif(frames, folder / "replay.gif", fps=fps))
        result.files["png"] = str(save_png(frames[-1], folder / "replay.png"))
    result.files["summary"] = str(folder / "summary.txt")
    result.files["summary_json"] = str(folder / "summary.json")
    result.wall_s = round(time.perf_counter() - wall0, 3)
    (folder / "summary.txt").write_text(result.table() + "\n")
    (folder / "summary.json").write_text(json.dumps(result.as_dict(), indent=1) + "\n")
    return result
