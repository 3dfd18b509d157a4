"""`pete-sim play`: one seeded match as a top-down GIF with a score overlay, and a plot of every
reward component over time.

    pete-sim play --policy jetson/models/policy/policy.onnx --opponent planner --out match.gif

writes match.gif and match_rewards.png (cumulative reward per component, rings and match score,
for every robot). With `world` (sim.config.WORLD_PRESETS) the match is that world's, e.g. the whole
game's 2v2, and a side is one player for all its alliance's robots or one per robot; the GIF then
shows the platforms' tilt, the goals' owners and their rings (sim.render).
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass, field, replace
from pathlib import Path
from typing import Any

import numpy as np

from sim.errors import EvalError
from sim.evaluate import MatchRecord, PlayerSpec, eval_env, make_cores, play_match, side_label
from sim.match import REWARD_COMPONENTS, MatchCore
from sim.players import Player
from sim.render import game_caption, save_gif, top_down
from sim.world import rules


@dataclass
class Trace:
    """Per control step, per robot: time, cumulative reward components, rings, score."""

    labels: list[str]
    alliances: list[str]
    time_s: list[float] = field(default_factory=list)
    components: list[list[dict[str, float]]] = field(default_factory=list)
    rings: list[list[int]] = field(default_factory=list)
    score: list[list[float]] = field(default_factory=list)


def _caption(core: MatchCore, labels: dict[str, str]) -> str:
    w = core.world
    if rules.whole_game(w):
        return game_caption(w)
    s = w.score()
    parts = [f"t {w.time_s:5.1f}s"]
    for r in w.robots:
        parts.append(
            f"{r.alliance} {labels[r.alliance]}: {s[r.alliance].total} pts {r.collected} rings"
        )
    return "   ".join(parts)


def _players(side: PlayerSpec | Sequence[PlayerSpec], robots: int) -> list[Player]:
    specs = [side] if isinstance(side, PlayerSpec) else list(side)
    if len(specs) == 1:
        specs = specs * robots
    if len(specs) != robots:
        raise EvalError(
            f"{len(specs)} players for an alliance of {robots} robot(s): give one name for all "
            "its robots, or one per robot"
        )
    return [s.make() for s in specs]


def record_match(
    a: PlayerSpec | Sequence[PlayerSpec],
    b: PlayerSpec | Sequence[PlayerSpec] | None,
    seed: int,
    scenario: str = "capped",
    fidelity: str = "training",
    a_alliance: str = "red",
    stride: int = 3,
    size: int = 480,
    seconds: float | None = None,
    world: str | None = None,
) -> tuple[list[np.ndarray], Trace, MatchRecord]:
    if stride < 1:
        raise EvalError(f"stride must be at least 1, got {stride}")
    if not 64 <= size <= 2048:
        raise EvalError(f"size must be within 64..2048, got {size}")
    if a_alliance not in ("red", "blue"):
        raise EvalError(f"side must be red or blue, got {a_alliance!r}")
    side_a = [a] if isinstance(a, PlayerSpec) else list(a)
    side_b = [] if b is None else [b] if isinstance(b, PlayerSpec) else list(b)
    specs = [s.spec for s in side_a + side_b if s.spec is not None]
    env = eval_env(scenario, fidelity, specs[0] if specs else None, world=world)
    if seconds is not None:
        if seconds <= 0:
            raise EvalError(f"seconds must be positive, got {seconds}")
        env = replace(env, max_steps=max(1, round(seconds * env.world.control_hz)))
    cores = make_cores(env)
    other = "blue" if a_alliance == "red" else "red"
    labels = {a_alliance: side_label(side_a), other: side_label(side_b) if side_b else "-"}
    counts = {al: sum(1 for x, _ in cores["duel"].world.lineup if x == al) for al in labels}
    frames: list[np.ndarray] = []
    trace: Trace | None = None

    def on_step(core: MatchCore, results: list[Any]) -> None:
        nonlocal trace
        w = core.world
        if trace is None:
            trace = Trace([labels[r.alliance] for r in w.robots], [r.alliance for r in w.robots])
            frames.append(top_down(w, size, title=_caption(core, labels)))
        score = w.score()
        trace.time_s.append(w.time_s)
        trace.components.append([dict(res.info["episode_reward_components"]) for res in results])
        trace.rings.append([r.collected for r in w.robots])
        trace.score.append([float(score[r.alliance].total) for r in w.robots])
        if w.steps % stride == 0 or w.over:
            frames.append(top_down(w, size, title=_caption(core, labels)))

    try:
        record = play_match(
            cores,
            _players(side_a, counts[a_alliance]),
            _players(side_b, counts[other]) if side_b else None,
            seed,
            a_alliance,
            on_step=on_step,
        )
    finally:
        for core in cores.values():
            core.close()
    assert trace is not None
    return frames, trace, record


def plot_trace(trace: Trace, path: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    n = len(trace.labels)
    fig, axes = plt.subplots(2, n, figsize=(5.5 * n, 6.5), squeeze=False, sharex=True)
    t = np.asarray(trace.time_s)
    for k in range(n):
        ax = axes[0][k]
        for name in REWARD_COMPONENTS:
            ax.plot(t, [step[k][name] for step in trace.components], label=name)
        total = [sum(step[k].values()) for step in trace.components]
        ax.plot(t, total, color="black", linewidth=2, label="total")
        ax.set_title(f"{trace.alliances[k]}: {trace.labels[k]} - cumulative reward")
        ax.legend(fontsize=8, loc="upper left")
        ax.grid(alpha=0.3)
        ax2 = axes[1][k]
        ax2.plot(t, [s[k] for s in trace.score], color="tab:purple", label="match score")
        ax2.plot(t, [r[k] for r in trace.rings], color="tab:green", label="rings collected")
        ax2.set_xlabel("match time (s)")
        ax2.legend(fontsize=8, loc="upper left")
        ax2.grid(alpha=0.3)
    fig.tight_layout()
    path.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(path, dpi=80)
    plt.close(fig)
    return path


def write_replay(
    a: PlayerSpec | Sequence[PlayerSpec],
    b: PlayerSpec | Sequence[PlayerSpec] | None,
    out: Path,
    seed: int = 0,
    scenario: str = "capped",
    fidelity: str = "training",
    a_alliance: str = "red",
    stride: int = 3,
    size: int = 480,
    seconds: float | None = None,
    plot: Path | None = None,
    world: str | None = None,
) -> tuple[list[Path], MatchRecord]:
    """Write the GIF (and the reward plot, default <out>_rewards.png); return paths and result."""
    if out.suffix.lower() != ".gif":
        raise EvalError(f"--out must name a .gif file, got {out}")
    frames, trace, record = record_match(
        a, b, seed, scenario, fidelity, a_alliance, stride, size, seconds, world
    )
    # Three times real time: a 105 s match plays in 35 s.
    fps = 12.0 / stride * 3
    written = [save_gif(frames, out, fps=fps)]
    plot = plot or out.with_name(out.stem + "_rewards.png")
    written.append(plot_trace(trace, plot))
    return written, record
