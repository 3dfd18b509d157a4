"""The whole game through the environments: the Gymnasium env's clamp action grabs and releases a
goal, the PettingZoo env plays a 2v2 whole-game match, and high fidelity plays one too."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from sim.baselines.scripted import GreedyChaser
from sim.config import world_preset
from sim.env import TippingPointEnv
from sim.world.physics import World

GAME = {"game": "tipping_point", "isolation_s": 0.0, "preloads": False}


def test_the_clamp_action_grabs_and_releases_a_goal() -> None:
    env = TippingPointEnv(opponent="none", action_clamp=True, world=GAME, obs_noise=False)
    try:
        env.reset(seed=0)
        w = env.world
        r = w.robots[env.agent_index]
        g = w.goals[5]  # neutral_tall
        w.place_goal(5, 0.0, 0.0)
        w.place_robot(r.index, 0.0, g.spec.base_radius + r.config.length_m / 2 + 0.03, 0.0)
        env.step(np.array([0.0, 0.0, 1.0], dtype=np.float32))  # clamp
        assert r.carried_goal == 5
        for _ in range(6):
            env.step(np.array([0.5, 0.0, 1.0], dtype=np.float32))
        assert g.y > 0.05
        for _ in range(3):
            env.step(np.array([0.0, 0.0, 1.0], dtype=np.float32))
        _, _, _, _, info = env.step(np.array([0.0, 0.0, -1.0], dtype=np.float32))  # release
        assert r.carried_goal is None and g.carried_by is None
        assert info["carrying_goal"] == -1
        for _ in range(6):
            env.step(np.array([0.5, 0.0, -1.0], dtype=np.float32))
        assert r.y - g.y > 0.5
    finally:
        env.close()


def test_a_2v2_whole_game_runs_in_the_parallel_env() -> None:
    from sim.parallel_env import parallel_env

    world = dict(GAME, red=["24in", "15in"], blue=["24in", "15in"], interaction_s=5.0)
    env = parallel_env(world=world, end_on_pin=False)
    try:
        env.reset(seed=1)
        rng = np.random.default_rng(1)
        steps = 0
        while env.agents:
            actions = {a: rng.uniform(-1, 1, env.action_space(a).shape) for a in env.agents}
            _, _, term, trunc, infos = env.step(actions)
            steps += 1
            if all(term.values()) or all(trunc.values()):
                break
        assert steps == 60
        assert {i["score_red"] for i in infos.values()} == {env.world.score()["red"].total}
    finally:
        env.close()


def test_a_2v2_whole_game_runs_in_high_fidelity() -> None:
    cfg = replace(world_preset("tipping_point_2v2"), fidelity="high", interaction_s=3.0)
    with World(cfg) as w:
        w.reset(np.random.default_rng(0))
        bots = [GreedyChaser(i) for i in range(len(w.robots))]
        while not w.over:
            w.step([b.act(w) for b in bots])
        assert w.autonomous is not None
        for alliance in ("red", "blue"):
            assert (
                w.board_angle(alliance)
                == w.platforms[alliance].tilt * w.field.platform(alliance).field_side
            )
        s = w.score()
        assert s["red"].fouls + s["blue"].fouls == len(w.fouls)
