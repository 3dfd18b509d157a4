"""Alliances on the batched backend: in a match of two robots a side, each learning robot is a row
of its own (its observation, its action, its reward), the opponent rows drive the other
alliance's robots one for one, the scripted alliance plays as an opponent, and the trainer runs
on it with the opponent kinds dealt per match."""

from __future__ import annotations

from dataclasses import replace
from pathlib import Path

import numpy as np
import pytest

from sim.config import WORLD_PRESETS
from sim.errors import ConfigError
from sim.fast.matches import FastMatches
from sim.match import make_config
from sim.training.config import FastConfig, load_config
from sim.training.rollout import RolloutConfig
from sim.training.trainer import train
from sim.world.physics import World

GAME = WORLD_PRESETS["tipping_point_2v2"]
OBSERVATION = {"match_length_s": 120.0, "partner": True, "n_other_robots": 3}


def matches(n: int = 4, seed: int = 5, **env: object) -> FastMatches:
    config = make_config({"world": GAME, "max_steps": 60, "observation": OBSERVATION, **env})
    return FastMatches(config, RolloutConfig(workers=0, envs_per_worker=n), seed=seed)


def test_each_row_is_one_learning_robot_of_its_match() -> None:
    fm = matches()
    assert (fm.a, fm.b, fm.n) == (2, 2, 4)
    fm.set_kinds([("policy", 3)] * 4)
    res = fm.reset()
    for m in range(fm.b):
        rng = np.random.default_rng((5, m, 0))
        side = 0 if rng.random() < 0.5 else 1
        assert fm.learner[m] == side
        with World(fm.config.world) as w:  # the match starts as World.reset starts it
            w.reset(rng)
            assert np.allclose([r.x for r in w.robots], fm.world.x[m])
        for j in range(2):
            me, them = side * 2 + j, (1 - side) * 2 + j
            assert fm.world.alliances[me] == ("red", "blue")[side]
            np.testing.assert_array_equal(res.learner_obs[m * 2 + j], fm.obs[m, me])
            np.testing.assert_array_equal(res.opponent_obs[m * 2 + j], fm.obs[m, them])
    assert fm.kinds == ["policy"] * 4 and fm.tags == [3] * 4


def test_each_row_drives_its_own_robot_and_each_opponent_row_its_opposite_number() -> None:
    fm = matches()
    fm.set_kinds([("policy", 0)] * 4)
    fm.reset()
    x0, y0 = fm.world.x.copy(), fm.world.y.copy()
    mine = np.zeros((4, 2), np.float32)
    mine[0::2] = (1.0, 0.0)  # the first robot of each learning alliance drives ahead
    theirs = np.zeros((4, 2), np.float32)
    theirs[1::2] = (1.0, 0.0)  # the second robot of each opposing alliance drives ahead
    for _ in range(8):
        fm.step(mine, theirs)
    moved = np.hypot(fm.world.x - x0, fm.world.y - y0)
    for m in range(fm.b):
        side = int(fm.learner[m])
        driven = {side * 2 + 0, (1 - side) * 2 + 1}
        for i in range(4):
            assert (moved[m, i] > 0.05) == (i in driven), (m, i, moved[m])


def test_each_row_is_paid_its_own_rings_and_its_alliances_score() -> None:
    """Rings collected are paid to the robot that took them; the score margin to both."""
    fm = matches(n=8, seed=2, reward={"ring": 1.0, "score": 0.1, "ring_cap": None})
    fm.set_kinds([("idle", -1)] * 8)
    fm.reset()
    forward = np.tile(np.float32([1.0, 0.0]), (8, 1))
    episodes = []
    for _ in range(60):
        episodes += fm.step(forward, np.zeros((8, 2), np.float32)).episodes
    assert sorted(ep.slot for ep in episodes) == list(range(8))
    for ep in episodes:
        assert ep.reward == pytest.approx(sum(ep.components.values()))
        assert ep.components["rings"] == pytest.approx(ep.rings)
        partner = next(p for p in episodes if p.slot == ep.slot ^ 1)
        assert ep.components["score"] == pytest.approx(partner.components["score"])
        assert (ep.score, ep.opponent_score) == (partner.score, partner.opponent_score)
    assert sum(ep.rings for ep in episodes) > 0  # driving ahead from the start meets rings
    by_robot = {ep.slot: ep.rings for ep in episodes}
    assert any(by_robot[k] != by_robot[k ^ 1] for k in by_robot)  # paid apart, not pooled


def test_the_scripted_alliance_plays_both_opposing_robots_and_claims_its_targets() -> None:
    fm = matches(n=4, seed=1, max_steps=400)
    fm.set_kinds([("alliance", -1)] * 4)
    fm.reset()
    claimed = np.zeros((fm.b, 4), bool)
    driven = np.zeros((fm.b, 4))  # metres each robot drove
    for _ in range(300):
        x0, y0 = fm.world.x.copy(), fm.world.y.copy()
        fm.step(np.zeros((4, 2), np.float32), np.zeros((4, 2), np.float32))
        driven += np.hypot(fm.world.x - x0, fm.world.y - y0)
        claimed |= ~np.isnan(fm.observer.claims).any(axis=-1)
    for m in range(fm.b):
        them = [(1 - int(fm.learner[m])) * 2 + j for j in range(2)]
        mine = [int(fm.learner[m]) * 2 + j for j in range(2)]
        assert (driven[m, them] > 1.0).all() and (driven[m, mine] < 0.05).all(), driven[m]
        assert claimed[m, them].all()  # each robot told its partner what it goes for
    assert all(p is not None for p in fm._players)


def test_rows_of_one_match_play_one_opponent_and_rows_come_in_whole_matches() -> None:
    fm = matches()
    with pytest.raises(ConfigError, match="one match and play one opponent"):
        fm.set_kinds([("policy", 1), ("policy", 2), ("idle", -1), ("idle", -1)])
    with pytest.raises(ConfigError, match="multiples of 2"):
        matches(n=3)


def test_the_trainer_trains_an_alliance_on_the_fast_backend(tmp_path: Path) -> None:
    """`pete-sim train --backend fast` on the 2v2 whole game: the kinds are dealt per match, both
    robots of every learning alliance are rows of the PPO batch, and the scripted alliance and
    past snapshots are opponents."""
    cfg = replace(
        load_config("tiny"),
        backend="fast",
        fast=FastConfig(envs=8, steps_per_env=32),
        total_steps=512,
        checkpoint_steps=512,
        opponents={"pool": 0.5, "alliance": 0.5},
    )
    world = {**cfg.env["world"], **GAME}
    observation = {**cfg.env["observation"], **OBSERVATION}
    cfg = replace(
        cfg, env={**cfg.env, "world": world, "observation": observation, "max_steps": 40}
    ).on_backend()
    kinds = cfg.opponent_slots()
    assert kinds[0::2] == kinds[1::2] and set(kinds) == {"pool", "alliance"}
    result = train(cfg, tmp_path / "run", progress=False, export=False)
    assert result.steps == 512 and result.episodes >= 8


def test_partners_that_drive_into_each_other_count_a_collision() -> None:
    """A collision is counted (and paid partner_contact, to both) as the partners meet, once
    however long they push; MatchCore pays it the same."""
    fm = matches(n=4, seed=4, max_steps=30, reward={"partner_contact": -2.0})
    fm.set_kinds([("idle", -1)] * 4)
    fm.reset()
    side = int(fm.learner[0])
    fm.world.place_robot(0, side * 2, -0.9, 0.45, 180.0)  # match 0: face to face, 0.9 m apart
    fm.world.place_robot(0, side * 2 + 1, -0.9, -0.45, 0.0)
    ahead = np.tile(np.float32([0.6, 0.0]), (4, 1))
    ahead[2:] = 0.0  # match 1's robots stand where they started, apart
    episodes = []
    for _ in range(30):
        episodes += fm.step(ahead, np.zeros((4, 2), np.float32)).episodes
    by_row = {ep.slot: ep.partner_collisions for ep in episodes}
    assert by_row[0] == by_row[1] == 1 and by_row[2] == by_row[3] == 0
    paid = {ep.slot: ep.components["partner"] for ep in episodes}
    assert paid == {0: -2.0, 1: -2.0, 2: 0.0, 3: 0.0}


def test_matchcore_pays_partner_contact_as_the_fast_backend_does() -> None:
    from sim.match import MatchCore
    from sim.world.state import DriveCommand

    config = make_config(
        {"world": GAME, "observation": OBSERVATION, "reward": {"partner_contact": -2.0}}
    )
    core = MatchCore(config)
    try:
        core.reset(np.random.default_rng(0))
        core.world.place_robot(0, -0.9, 0.45, 180.0)  # red's two robots face to face
        core.world.place_robot(1, -0.9, -0.45, 0.0)
        paid = np.zeros(4)
        for _ in range(30):
            ahead = DriveCommand(0.5, 0.0)
            results, _, _ = core.step([ahead, ahead, DriveCommand(), DriveCommand()])
            paid += [r.components["partner"] for r in results]
    finally:
        core.close()
    assert paid.tolist() == [-2.0, -2.0, 0.0, 0.0]
