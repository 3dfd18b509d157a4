"""The whole VEX AI match as a config: a 24" and a 15" robot an alliance, starting in their home
zones with their preloads, 15 s of isolation and 105 s of interaction, fouls counted."""

from __future__ import annotations

import numpy as np
import pytest

from sim.baselines.scripted import GreedyChaser
from sim.config import ROBOTS, WORLD_PRESETS, WorldConfig, world_preset
from sim.errors import ConfigError
from sim.world import rules
from sim.world.physics import World

INCH = 0.0254


def test_the_robots_are_the_vex_ai_pair() -> None:
    big, small = ROBOTS["24in"], ROBOTS["15in"]
    assert (big.width_m, big.length_m) == pytest.approx((24 * INCH, 24 * INCH))
    assert (small.width_m, small.length_m) == pytest.approx((15 * INCH, 15 * INCH))
    assert big.reaches_high_branch and not small.reaches_high_branch
    assert big.clamp == small.clamp == "back" and big.loads == small.loads == "branch"
    assert big.pull_n > small.pull_n


def test_the_default_world_is_still_the_ring_race() -> None:
    cfg = WorldConfig()
    assert cfg.game == "ring_race" and cfg.red == ("15in",) and cfg.blue == ("15in",)
    assert cfg.isolation_s == 0.0 and not cfg.preloads and cfg.isolation_barrier
    assert world_preset("ring_race") == cfg
    with pytest.raises(ConfigError):
        WorldConfig(game="tic_tac_toe")  # type: ignore[arg-type]
    with pytest.raises(ConfigError):
        world_preset("3v3")


def test_the_2v2_match_starts_as_the_manual_says() -> None:
    cfg = world_preset("tipping_point_2v2")
    assert cfg.game == "tipping_point" and cfg.red == cfg.blue == ("24in", "15in")
    with World(cfg) as w:
        w.reset()
        assert (w.isolation_s, w.interaction_s, w.match_length_s) == (15.0, 105.0, 120.0)
        assert w.phase == "isolation"
        assert [r.held for r in w.robots] == [w.field.ring.preloads_per_robot] * 4
        for r in w.robots:
            zone = w.field.home_zones[r.alliance]
            assert zone.contains_point(r.x, r.y)
            assert r.on_platform is None and not rules.robot_elevated(w, r)
        assert w.platforms["red"].tilt == pytest.approx(w.field.platform("red").max_tilt_rad)
        s = w.score()  # each alliance's two goals start in its zone
        assert s["red"].total == s["blue"].total == 40
        assert w.autonomous is None


def play(seed: int) -> World:
    w = World(world_preset("tipping_point_2v2"))
    w.reset(np.random.default_rng(seed))
    bots = [GreedyChaser(i) for i in range(len(w.robots))]
    phase_changes = 0
    while not w.over:
        ev = w.step([b.act(w) for b in bots])
        phase_changes += ev.phase_changed
        if ev.phase_changed:
            assert w.time_s == pytest.approx(15.0)
            assert w.autonomous is not None
    assert phase_changes == 1 and w.steps == 1440
    return w


def test_a_whole_scripted_match_is_seeded_and_counts_its_fouls() -> None:
    a, b = play(3), play(3)
    try:
        sa, sb = a.score(), b.score()
        assert sa == sb
        assert a.fouls == b.fouls
        for alliance in ("red", "blue"):
            assert sa[alliance].fouls == sum(1 for f in a.fouls if f.alliance == alliance)
            assert sa[alliance].total >= 0
        assert a.autonomous == b.autonomous
        assert sa["red"].autonomous_bonus + sa["blue"].autonomous_bonus in (0, 20)
    finally:
        a.close()
        b.close()


def test_presets_name_only_world_fields() -> None:
    for name in WORLD_PRESETS:
        world_preset(name)
