"""The whole game in the simulator's tools: `pete-sim eval --world`, `pete-sim match --world` (the
sim stack; the full stack refuses), the score by element and the fouls in their summaries, four
players for 2v2, and the pictures (platform tilt, goal owners, rings on branches and bases)."""

from __future__ import annotations

import json
import math
from dataclasses import replace
from pathlib import Path
from typing import Any

import numpy as np
import pytest
from PIL import Image

from sim.cli import main
from sim.config import world_preset
from sim.errors import EvalError
from sim.evaluate import (
    ELEMENTS,
    eval_env,
    evaluate,
    load_player,
    load_side,
    make_cores,
    play_match,
    side_label,
)
from sim.players import IdlePlayer
from sim.render import game_caption, goal_label, top_down
from sim.world import rules
from sim.world.physics import World
from sim.world.state import DriveCommand

RING_RACE_KEYS = [
    "a", "b", "scenario", "fidelity", "matches", "a_stats", "b_stats", "a_wins", "draws",
    "a_win_rate", "a_win_rate_ci95",
]  # fmt: skip


def test_a_side_is_one_name_for_all_its_robots_or_one_per_robot() -> None:
    assert [s.label for s in load_side("scripted")] == ["scripted"]
    both = load_side("planner, scripted")
    assert [s.label for s in both] == ["planner", "scripted"]
    assert side_label(both) == "planner+scripted" and side_label(load_side("idle,idle")) == "idle"
    with pytest.raises(EvalError, match="empty player name"):
        load_side("planner,")
    # A policy whose folder is named like a built-in player is told apart from it.
    assert load_player("jetson/models/alliance/policy.onnx").label == "policy:alliance"
    with pytest.raises(EvalError, match="unknown player 'wizard'"):
        load_side("planner,wizard")


def test_the_ring_race_summary_keeps_its_keys() -> None:
    summary = evaluate(load_player("idle"), None, 1, 0, base_env={"max_steps": 12})
    assert list(summary.as_dict()) == RING_RACE_KEYS
    assert all(m.breakdown is None for m in summary.matches)
    assert "by element" not in summary.table()


def test_eval_plays_2v2_whole_game_matches_and_breaks_the_score_down(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "eval.json"
    argv = ["eval", "--world", "tipping_point_2v2", "--policy", "planner,scripted"]
    argv += ["--opponent", "scripted", "--matches", "2", "--seed", "1", "--json", str(out)]
    assert main([*argv, "--no-progress"]) == 0
    text = capsys.readouterr().out
    for _, name in ELEMENTS:
        assert name in text
    assert "planner+scripted wins" in text and "tipping_point_2v2" in text
    data = json.loads(out.read_text())
    assert data["world"] == "tipping_point_2v2" and data["a"] == "planner+scripted"
    assert [m["a_alliance"] for m in data["per_match"]] == ["red", "blue"]
    for m in data["per_match"]:
        for k, side in enumerate(("a", "b")):
            row = m[side]
            assert row["total"] == m["score"][k]
            assert row["fouls"] == sum(row["fouls_by_kind"].values())
            assert set(row) == {key for key, _ in ELEMENTS} | {"total", "fouls_by_kind"}
    means = data["a_elements"]
    assert means["fouls"]["mean"] == np.mean([m["a"]["fouls"] for m in data["per_match"]])
    assert 0.0 <= means["autonomous_win_point"] <= 1.0


def test_eval_names_a_side_with_the_wrong_number_of_players(
    capsys: pytest.CaptureFixture[str],
) -> None:
    argv = ["eval", "--world", "tipping_point_2v2", "--policy", "idle,idle,idle"]
    assert main([*argv, "--opponent", "idle", "--matches", "1", "--no-progress"]) == 2
    assert "3 players (idle,idle,idle) for an alliance of 2 robot(s)" in capsys.readouterr().err
    argv = ["eval", "--policy", "idle,scripted", "--opponent", "idle", "--matches", "1"]
    assert main([*argv, "--no-progress"]) == 2  # the ring race has one robot an alliance


def test_help_teaches_the_worlds(capsys: pytest.CaptureFixture[str]) -> None:
    for command in ("eval", "match"):
        with pytest.raises(SystemExit):
            main([command, "--help"])
        text = " ".join(capsys.readouterr().out.split())
        assert "--world {ring_race,tipping_point_1v1,tipping_point_2v2}" in text
        assert "NAME,NAME" in text


def test_the_sim_stack_refuses_the_full_stacks_options(capsys: pytest.CaptureFixture[str]) -> None:
    # (The full stack plays the whole game: tests/sim/fullstack/test_whole_game.py.)
    argv = ["match", "--stack", "sim", "--world", "tipping_point_2v2", "--fault", "link-cut"]
    assert main(argv) == 2
    assert "--fault belong(s) to the full stack" in capsys.readouterr().err


def test_match_plays_the_whole_game_in_the_sim_stack(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    out = tmp_path / "run"
    argv = ["match", "--stack", "sim", "--world", "tipping_point_2v2", "--seed", "3"]
    argv += ["--policy", "scripted", "--opponent", "idle,scripted", "--seconds", "20"]
    assert main([*argv, "--out", str(out), "--json", "--gif-every", "2"]) == 0
    data = json.loads(capsys.readouterr().out)
    assert data["world"] == "tipping_point_2v2" and data["sim_s"] == pytest.approx(20.0)
    assert data["players"]["red"] == ["red_0 24in (scripted)", "red_1 15in (scripted)"]
    assert data["players"]["blue"] == ["blue_0 24in (idle)", "blue_1 15in (scripted)"]
    for alliance in ("red", "blue"):
        row = data["score"][alliance]
        assert row["fouls"] == sum(1 for f in data["fouls"] if f["alliance"] == alliance)
    assert data["winner"] in ("red", "blue", "draw")
    assert json.loads((out / "summary.json").read_text())["score"] == data["score"]
    text = (out / "summary.txt").read_text()
    assert "rings high branch" in text and "fouls (" in text
    gif = Image.open(out / "replay.gif")
    assert gif.n_frames == 11  # the first step, one every 2 s after it, and the end
    assert (out / "replay.png").is_file()


def test_goal_labels_show_where_the_rings_sit() -> None:
    assert goal_label(0, 0, 0) == ""
    assert goal_label(0, 3, 0) == "3"
    assert goal_label(0, 3, 1) == "3/1"
    assert goal_label(2, 3, 1) == "2/3/1"


def _pixel(img: np.ndarray, world: World, x: float, y: float, size: int) -> np.ndarray:
    margin, half = 8, world.field.half
    scale = (size - 2 * margin) / world.field.size
    return img[round(margin + (half - y) * scale), round(margin + (x + half) * scale)]


def test_the_picture_shows_the_tilt_and_the_goals_owners() -> None:
    size = 480
    with World(world_preset("tipping_point_2v2")) as w:
        w.reset(np.random.default_rng(0))
        plat = w.field.platform("red")
        cx, cy = plat.center
        field_half = (cx + plat.field_side * plat.size[0] / 4, cy)
        wall_half = (cx - plat.field_side * plat.size[0] / 4, cy)
        down = top_down(w, size, show_frustum=False)
        # The field-side edge starts down: that half is shaded darker than the other.
        assert _pixel(down, w, *field_half, size).sum() < _pixel(down, w, *wall_half, size).sum()
        w.set_tilt("red", -plat.max_tilt_rad)
        up = top_down(w, size, show_frustum=False)
        assert _pixel(up, w, *field_half, size).sum() > _pixel(up, w, *wall_half, size).sum()
        # A red goal in red's zone scores for red: a red ring around its base.
        g = next(g for g in w.goals if g.spec.alliance == "red")
        assert rules.goal_owner(w, g) == ("red", False)
        ring = _pixel(down, w, g.x + g.spec.base_radius + 0.02, g.y, size)
        assert ring[0] > 150 and ring[2] < 100
        assert game_caption(w).startswith("t   0.0 s  isolation   red  40 (fouls 0)")


def test_a_player_class_sim_players_exports_is_a_player_by_its_name(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    import sim.players
    from sim.evaluate import registered_players

    class Parker:
        name = "parker"

        def reset(self, core: object, index: int, rng: object) -> None:
            pass

        def act(self, core: object, index: int, obs: object) -> object:
            return None

    assert {"idle", "random", "scripted"} <= set(registered_players())
    assert "policy" not in registered_players()  # PolicyPlayer needs its function
    with pytest.raises(EvalError, match="unknown player 'parker'"):
        load_player("parker")
    monkeypatch.setattr(sim.players, "Parker", Parker, raising=False)
    spec = load_player("parker")
    assert spec.label == "parker" and isinstance(spec.make(), Parker)
    assert [s.label for s in load_side("parker,scripted")] == ["parker", "scripted"]


def test_play_and_view_picture_the_whole_game(tmp_path: Path) -> None:
    gif = tmp_path / "game.gif"
    argv = ["play", "--world", "tipping_point_2v2", "--policy", "scripted", "--opponent"]
    argv += ["idle,scripted", "--seconds", "3", "--stride", "12", "--out", str(gif)]
    assert main(argv) == 0
    assert Image.open(gif).n_frames == 4  # the first step, then one a second up to 3 s
    assert (tmp_path / "game_rewards.png").is_file()
    out = tmp_path / "view"
    argv = ["view", "--world", "tipping_point_1v1", "--seconds", "1", "--no-camera"]
    assert main([*argv, "--out", str(out)]) == 0
    assert Image.open(out / "start.png").size == (480, 502)


def test_the_world_preset_merges_into_the_evaluations_env() -> None:
    from sim.evaluate import EVAL_WORLD, eval_env

    race = eval_env()
    assert race == eval_env(world="ring_race")  # the same config, so the same matches
    game = eval_env(base={"max_steps": 12}, world="tipping_point_1v1")
    assert game.max_steps == 12 and not game.end_on_pin and race.end_on_pin
    assert game.world.game == "tipping_point" and game.world.red == ("24in",)
    assert game.world.start_jitter_m == EVAL_WORLD["start_jitter_m"]
    with pytest.raises(EvalError, match="world must be one of"):
        eval_env(world="3v3")


def test_the_picture_frames_an_elevated_robot_in_white() -> None:
    size = 480
    with World(world_preset("tipping_point_2v2")) as w:
        w.reset(np.random.default_rng(1))
        plat = w.field.platform("red")
        r = w.robots[1]
        w.place_robot(1, plat.center[0], plat.center[1], 0.0)
        x = plat.center[0] + 0.4 * r.config.width_m  # on the inner frame's right side
        before = _pixel(top_down(w, size, show_frustum=False), w, x, plat.center[1], size)
        r.on_platform = "red"  # as if it drove on over the lowered edge
        w.set_tilt("red", 0.0)
        assert rules.robot_elevated(w, r)
        img = top_down(w, size, show_frustum=False)
        assert (_pixel(img, w, x, plat.center[1], size) >= 250).all()
        assert not (before >= 250).all()


class _Rammer:
    """Drives at its alliance partner, and backs off for a second after each contact (the two
    start in the open, 1.2 m apart)."""

    def __init__(self) -> None:
        self.back_until = -1.0

    def reset(self, core: Any, index: int, rng: object = None) -> None:
        self.back_until = -1.0
        slot = core.world.robots[index].slot
        core.world.place_robot(index, -0.8, 0.6 - 1.2 * slot, 90.0)

    def act(self, core: Any, index: int, obs: object = None) -> DriveCommand:
        w = core.world
        me = w.robots[index]
        mate = next(r for r in w.robots if r.alliance == me.alliance and r.index != index)
        if w.touching(index, mate.index):
            self.back_until = w.time_s + 1.0
        if w.time_s < self.back_until:
            return DriveCommand(-0.5, 0.0)
        bearing = math.degrees(math.atan2(mate.x - me.x, mate.y - me.y))
        error = (bearing - me.heading + 180.0) % 360.0 - 180.0
        return DriveCommand(0.6 if abs(error) < 30 else 0.0, math.radians(error) * 3.0)


def test_eval_counts_the_collisions_between_partners() -> None:
    """Each time two robots of one alliance come into contact is one partner collision."""
    env = eval_env(world="tipping_point_2v2")
    cores = make_cores(replace(env, max_steps=15 * 12))
    try:
        record = play_match(cores, [_Rammer(), _Rammer()], [IdlePlayer(), IdlePlayer()], 3, "red")
    finally:
        for core in cores.values():
            core.close()
    assert record.partner_collisions[0] >= 2 and record.partner_collisions[1] == 0
