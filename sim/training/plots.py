"""The training curve of a run (history.jsonl) as one PNG: what the README shows.

python -m sim.training.plots runs/default jetson/models/policy/training_curve.png
"""

from __future__ import annotations

import json
import math
import sys
from pathlib import Path

import numpy as np


def load_history(run_dir: Path) -> list[dict[str, float]]:
    path = run_dir / "history.jsonl"
    if not path.is_file():
        raise FileNotFoundError(f"no {path}")
    return [json.loads(line) for line in path.read_text().splitlines() if line.strip()]


def _smooth(steps: list[float], values: list[float], window: int = 15) -> tuple[list, list]:
    if len(values) < window:
        return steps, values
    kernel = np.ones(window) / window
    return steps[window - 1 :], list(np.convolve(values, kernel, mode="valid"))


def plot_history(run_dir: Path, out: Path) -> Path:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    rows = load_history(run_dir)

    def series(key: str) -> tuple[list[float], list[float]]:
        pts = [(r["step"], r[key]) for r in rows if key in r and math.isfinite(r[key])]
        return [p[0] / 1e6 for p in pts], [p[1] for p in pts]

    fig, axes = plt.subplots(1, 3, figsize=(15, 4))
    ax = axes[0]
    x, y = series("eval/score")
    ax.plot(x, y, "o-", label="ours")
    xm, margin = series("eval/score_margin")
    ax.plot(xm, [s - m for s, m in zip(y, margin, strict=False)], "s--", label="planner")
    ax.set_xlabel("learner steps (millions)")
    ax.set_title("match score, deterministic eval vs the planner")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)

    ax = axes[1]
    x, y = series("eval/fill_median_s")
    ax.plot(x, y, "o-", label="ours: median time to 10 rings")
    x, y = series("eval/opponent_fill_median_s")
    ax.plot(x, y, "s--", label="planner, same matches")
    ax.set_xlabel("learner steps (millions)")
    ax.set_ylabel("seconds")
    ax.set_title("deterministic eval vs the planner (capped task)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)

    ax = axes[2]
    x, y = series("selfplay/elo")
    ax.plot(x, y, label="self-play ELO")
    ax.set_xlabel("learner steps (millions)")
    ax.set_title("ELO against past snapshots")
    ax.grid(alpha=0.3)
    ax2 = ax.twinx()
    x, y = series("charts/steps_per_s")
    ax2.plot(*_smooth(x, y), color="tab:gray", alpha=0.6, label="steps/s")
    ax2.set_ylabel("steps/s (2 workers)", color="tab:gray")

    # Curriculum phases (config.json) as dotted lines: the game changes there.
    config = run_dir / "config.json"
    if config.is_file():
        for phase in json.loads(config.read_text()).get("phases", []):
            for a in axes:
                a.axvline(phase["from_step"] / 1e6, color="black", linestyle=":", alpha=0.5)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=80)
    plt.close(fig)
    return out


if __name__ == "__main__":
    if len(sys.argv) != 3:
        print("usage: python -m sim.training.plots RUN_DIR OUT.png", file=sys.stderr)
        sys.exit(2)
    print(plot_history(Path(sys.argv[1]), Path(sys.argv[2])))
