"""Evaluation and replay: statistics, players, and the eval / play commands on a tiny run."""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest
from PIL import Image

from sim.baselines.planner import Planner
from sim.cli import main
from sim.errors import EvalError
from sim.evaluate import evaluate, load_player, mean_ci, wilson
from sim.training.config import parse_config
from sim.training.trainer import train

TINY = {
    "name": "tiny-test",
    "seed": 2,
    "total_steps": 512,
    "env": {"max_steps": 64, "observation": {"n_stack": 1}},
    "ppo": {"hidden": [16, 16], "minibatch_size": 128},
    "rollout": {"workers": 0, "envs_per_worker": 4, "steps_per_env": 64},
    "opponents": {"scripted": 1.0},
}


@pytest.fixture(scope="module")
def tiny_run(tmp_path_factory: pytest.TempPathFactory) -> Path:
    run = tmp_path_factory.mktemp("tiny") / "run"
    train(parse_config(TINY), run, progress=False)
    return run


def test_intervals() -> None:
    s = mean_ci([1.0, 2.0, 3.0, 4.0])
    assert s.mean == 2.5
    # t(3) = 3.182, sd = 1.291: half width 3.182 * 1.291 / 2
    assert s.half_width == pytest.approx(3.182 * 1.2909944 / 2, rel=1e-4)
    lo, hi = wilson(8, 10)
    assert lo == pytest.approx(0.4902, abs=1e-3) and hi == pytest.approx(0.9433, abs=1e-3)
    assert math.isnan(mean_ci([]).mean)


def test_unknown_players_are_named(tmp_path: Path) -> None:
    with pytest.raises(EvalError, match="unknown player 'wizard'"):
        load_player("wizard")
    with pytest.raises(EvalError, match=r"no policy\.onnx"):
        load_player(str(tmp_path))
    bad = tmp_path / "x.txt"
    bad.write_text("x")
    with pytest.raises(EvalError, match=r"expected a \.onnx"):
        load_player(str(bad))


def test_the_collector_is_the_planner_that_does_not_park() -> None:
    # Where only rings pay (the uncapped benchmark) the fair planner collects to the bell.
    planner, collector = load_player("planner").make(), load_player("planner-collector").make()
    assert isinstance(planner, Planner) and isinstance(collector, Planner)
    assert planner.config.endgame and not collector.config.endgame
    assert collector.config.strategy == planner.config.strategy == "route"


def test_random_is_the_floor_and_sides_alternate() -> None:
    summary = evaluate(load_player("planner"), load_player("random"), 2, seed=7)
    assert [m.a_alliance for m in summary.matches] == ["red", "blue"]
    assert [m.seed for m in summary.matches] == [7, 7]
    a, b = summary.side(0), summary.side(1)
    assert a["fill_rate"] == 1.0 and a["fill_median_s"] < 10.0
    assert a["rings"].mean > b["rings"].mean + 10
    assert summary.win_rate == 1.0


def test_eval_command_on_a_tiny_run(tiny_run: Path, tmp_path: Path, capsys) -> None:
    out = tmp_path / "eval.json"
    policy = tiny_run / "policy.onnx"
    rc = main(
        ["eval", "--policy", str(policy), "--opponent", "random", "--matches", "2",
         "--seed", "3", "--json", str(out)]
    )  # fmt: skip
    assert rc == 0
    text = capsys.readouterr().out
    assert "rings" in text and "wins" in text and "+-" in text
    data = json.loads(out.read_text())
    assert data["matches"] == 2 and data["b"] == "random"
    assert set(data["a_stats"]) >= {"rings", "score", "pins", "fill_rate", "fill_median_s"}
    # A run folder and the checkpoint work as players too.
    assert load_player(str(tiny_run)).spec is not None
    assert load_player(str(tiny_run / "checkpoints" / "latest.pt")).spec is not None
    assert main(["eval", "--policy", "wizard", "--matches", "1"]) == 2
    assert "unknown player" in capsys.readouterr().err


def test_play_command_writes_a_gif_and_reward_plots(tiny_run: Path, tmp_path: Path) -> None:
    gif = tmp_path / "m" / "match.gif"
    rc = main(
        ["play", "--policy", str(tiny_run / "policy.onnx"), "--opponent", "planner",
         "--out", str(gif), "--seconds", "6", "--stride", "6", "--size", "240"]
    )  # fmt: skip
    assert rc == 0
    with Image.open(gif) as im:
        assert im.n_frames >= 10  # 72 steps / 6 + the first
        assert im.size[0] == 240
    plot = gif.with_name("match_rewards.png")
    with Image.open(plot) as im:
        assert np.asarray(im.convert("L")).std() > 10, "a plot, not a blank image"
    assert main(["play", "--policy", "planner", "--out", str(tmp_path / "x.png")]) == 2
