"""The Gymnasium and PettingZoo environments, rewards, symmetry, determinism and the CLI."""

from __future__ import annotations

from pathlib import Path

import gymnasium as gym
import numpy as np
import pytest
from gymnasium.utils.env_checker import check_env
from pettingzoo.test import parallel_api_test, parallel_seed_test
from PIL import Image

import sim.env
from jetson.autonomy.geometry import INCH
from sim.errors import ConfigError
from sim.match import REWARD_COMPONENTS, EnvConfig, MatchCore, make_config
from sim.parallel_env import parallel_env
from sim.world.state import DriveCommand

SHORT = {"interaction_s": 4.0}


def test_registered_and_passes_check_env() -> None:
    env = gym.make(sim.env.ENV_ID, world=SHORT)
    try:
        check_env(env.unwrapped, skip_render_check=False)
        obs, info = env.reset(seed=0)
        assert obs.shape == env.observation_space.shape
        assert set(info["reward_components"]) == set(REWARD_COMPONENTS)
        assert set(REWARD_COMPONENTS) == {
            "rings", "pin", "goals_end", "side_end", "elevated_end", "approach", "park",
            "clamp", "goal_approach", "score", "hurry", "partner"
        }  # fmt: skip
    finally:
        env.close()


def test_render_is_a_top_down_rgb_image() -> None:
    env = sim.env.TippingPointEnv(render_mode="rgb_array", world=SHORT)
    env.reset(seed=1)
    img = env.render()
    assert img is not None and img.ndim == 3 and img.shape[2] == 3 and img.dtype == np.uint8
    assert img.shape[0] >= 400
    env.close()


def rollout(env: sim.env.TippingPointEnv, seed: int, steps: int) -> list[tuple]:
    obs, _ = env.reset(seed=seed)
    env.action_space.seed(seed)
    out = [obs.tobytes()]
    for _ in range(steps):
        obs, r, term, trunc, info = env.step(env.action_space.sample())
        out.append((obs.tobytes(), r, term, trunc, info["rings_collected"]))
        if term or trunc:
            break
    return out


def test_deterministic_for_a_seed_across_instances_and_resets() -> None:
    cfg = {"world": {"start_jitter_m": 0.05, "start_jitter_deg": 10.0, "interaction_s": 8.0}}
    a = sim.env.TippingPointEnv(cfg)
    b = sim.env.TippingPointEnv(cfg)
    first = rollout(a, 7, 60)
    assert rollout(b, 7, 60) == first
    rollout(a, 8, 30)
    assert rollout(a, 7, 60) == first, "a reset must not carry state from the last episode"
    assert rollout(a, 9, 60) != first
    a.close()
    b.close()


def test_each_robots_noise_is_its_own_so_the_observation_spec_does_not_move_the_match() -> None:
    """Two matches on one seed whose observations differ in size (so their noise takes a
    different count of numbers) still give every robot the same GPS readings: players compared
    on the same seeds meet the same noise. A second read in one step is the same reading."""

    def readings(n_rings: int) -> list[tuple[float, float, float]]:
        core = MatchCore(make_config({"observation": {"n_rings": n_rings}}))
        core.reset(np.random.default_rng(11))
        out = []
        for _ in range(30):
            for i in range(core.n_robots):
                g = core.gps(i)
                assert core.view(i).x == g.x, "read twice in a step, the GPS must agree"
                out.append((g.x, g.y, g.heading_deg))
            core.step([DriveCommand(0.6, 0.5)] * core.n_robots)
        core.close()
        return out

    assert readings(4) == readings(12)


def test_random_alliance_plays_both_sides() -> None:
    env = sim.env.TippingPointEnv(agent_alliance="random", world=SHORT)
    sides = set()
    for seed in range(8):
        env.reset(seed=seed)
        sides.add(env.world.robots[env.agent_index].alliance)
    assert sides == {"red", "blue"}
    env.close()


def test_no_opponent_means_one_robot_and_policy_opponent_is_called() -> None:
    env = sim.env.TippingPointEnv(opponent="none", world=SHORT)
    env.reset(seed=0)
    assert len(env.world.robots) == 1
    env.close()
    calls = []

    def policy(obs: np.ndarray) -> np.ndarray:
        calls.append(obs.shape)
        return np.array([1.0, 0.0], dtype=np.float32)

    env = sim.env.TippingPointEnv(opponent="policy", opponent_policy=policy, world=SHORT)
    env.reset(seed=0)
    x0 = env.world.robots[1].x
    for _ in range(12):
        env.step(np.zeros(2, dtype=np.float32))
    assert len(calls) == 12 and calls[0] == env.observation_space.shape
    assert env.world.robots[1].x < x0 - 0.3, "blue drove forward (towards -x)"
    env.close()
    with pytest.raises(ConfigError, match="opponent_policy"):
        sim.env.TippingPointEnv(opponent="policy")


def test_bad_config_is_named() -> None:
    with pytest.raises(ConfigError, match="unknown keys"):
        make_config({"wrold": {}})
    with pytest.raises(ConfigError, match="agent_alliance"):
        make_config(agent_alliance="green")
    with pytest.raises(ConfigError, match="match_length_s"):
        MatchCore(make_config(world={"isolation_s": 15.0}, observation={"match_length_s": 105.0}))


def test_bad_action_shape_is_named() -> None:
    env = sim.env.TippingPointEnv(world=SHORT)
    env.reset(seed=0)
    with pytest.raises(ValueError, match="must have 2 values"):
        env.step(np.zeros(3, dtype=np.float32))
    env.close()


def test_ring_reward_is_capped_and_end_rewards_are_paid_once() -> None:
    cfg = make_config(
        world={"blue": [], "interaction_s": 3.0},
        reward={"ring_cap": 2, "hurry": -1.0},
        obs_noise=False,
        gps_noise=False,
    )
    core = MatchCore(cfg)
    core.reset(np.random.default_rng(0))
    w = core.world
    w.set_floor_rings(np.array([[0.8 + 0.15 * k, 0.0] for k in range(4)]))
    w.place_robot(0, 0.4, 0.0, 90.0)  # faces the blue side, rings ahead
    for i in range(len(w.goals)):
        w.place_goal(i, -1.5 + 0.5 * i, 1.6)
    totals = dict.fromkeys(REWARD_COMPONENTS, 0.0)
    ended = False
    n = 0
    filled_at = None
    while not ended:
        results, ended, _ = core.step([DriveCommand(0.5, 0.0)])
        for k, v in results[0].components.items():
            totals[k] += v
        n += 1
        if filled_at is None and w.robots[0].collected >= 2:
            filled_at = n
    r = w.robots[0]
    assert r.collected == 4
    assert totals["rings"] == pytest.approx(5.0 * 2), "5 per ring, only the first 2"
    assert filled_at is not None and 1 < filled_at < n
    assert totals["hurry"] == pytest.approx(-w.dt * filled_at), "time costs until the cap only"
    assert totals["side_end"] == pytest.approx(-17.5), "ended on the opponent's side"
    # Goals in red's home zone at the end, 12 each; the goals were lined up along the far wall.
    assert totals["goals_end"] == pytest.approx(12.0 * core.goals_counting("red"))
    assert n == 36
    assert results[0].info["episode_reward_components"] == pytest.approx(totals)
    core.close()


def test_pin_penalises_both_and_ends_the_episode() -> None:
    env = parallel_env(obs_noise=False, gps_noise=False)
    env.reset(seed=0)
    w = env.world
    w.set_floor_rings(np.zeros((0, 2)))
    for i in range(len(w.goals)):
        w.place_goal(i, -1.5 + 0.5 * i, 1.6)
    w.place_robot(0, -0.2, 0.0, 90.0)
    w.place_robot(1, 0.2, 0.0, 270.0)
    push = {"red_0": np.array([0.4, 0.0]), "blue_0": np.array([0.4, 0.0])}
    steps = 0
    while env.agents:
        _obs, rewards, terms, truncs, infos = env.step(push)
        steps += 1
    assert steps == 60
    assert rewards == {"red_0": -5.0, "blue_0": -5.0}
    assert all(terms.values()) and not any(truncs.values())
    assert infos["red_0"]["reward_components"]["goals_end"] == 0.0, "no end rewards after a pin"


def test_mirrored_robots_get_equal_observations() -> None:
    """The field is point-symmetric: red and blue start mirrored, so with noise off they see
    the same vector, and mirrored driving keeps it that way."""
    env = parallel_env(obs_noise=False, gps_noise=False)
    obs, _ = env.reset(seed=3)
    assert np.allclose(obs["red_0"], obs["blue_0"], atol=1e-5)
    action = np.array([0.8, 0.3], dtype=np.float32)
    for _ in range(24):
        obs, *_ = env.step({"red_0": action, "blue_0": action})
    assert np.allclose(obs["red_0"], obs["blue_0"], atol=1e-4)
    env.close()


def test_parallel_env_passes_pettingzoo_api_and_seed_tests() -> None:
    parallel_api_test(parallel_env(max_steps=150), num_cycles=200)
    parallel_seed_test(lambda: parallel_env(max_steps=60), num_cycles=60)


def test_parallel_env_two_versus_two() -> None:
    env = parallel_env(world={"red": ["24in", "15in"], "blue": ["24in", "15in"], **SHORT})
    obs, _infos = env.reset(seed=2)
    assert env.agents == ["red_0", "red_1", "blue_0", "blue_1"]
    assert all(o.shape == env.observation_space("red_0").shape for o in obs.values())
    n = 0
    while env.agents:
        env.step({a: env.action_space(a).sample() for a in env.agents})
        n += 1
    assert n == 48
    assert env.state().ndim == 1
    env.close()


def test_high_fidelity_env_runs() -> None:
    env = sim.env.TippingPointEnv(world={"fidelity": "high", "interaction_s": 1.0})
    env.reset(seed=0)
    n = 0
    term = False
    while not term:
        _, _, term, _, _ = env.step(np.array([0.5, 0.0], dtype=np.float32))
        n += 1
    assert n == 12
    env.close()


def test_cli_view_writes_png_and_gif(tmp_path: Path) -> None:
    from sim.cli import main

    assert (
        main(["view", "--seed", "2", "--out", str(tmp_path), "--seconds", "2", "--size", "240"])
        == 0
    )
    start = Image.open(tmp_path / "start.png")
    assert start.size[0] == 240
    gif = Image.open(tmp_path / "match.gif")
    assert gif.n_frames == 1 + 24 // 4
    assert Image.open(tmp_path / "camera.png").size == (320, 240)
    assert main(["view", "--stride", "0", "--out", str(tmp_path)]) == 2


def test_env_config_merges_nested_overrides() -> None:
    base = EnvConfig()
    cfg = make_config(base, world={"fidelity": "high"}, reward={"ring": 1.0})
    assert cfg.world.fidelity == "high" and cfg.world.red == base.world.red
    assert cfg.reward.ring == 1.0 and cfg.reward.pin == base.reward.pin
    # A TOML-style table reaching into one robot's camera keeps everything else.
    cfg = make_config({"world": {"robots": {"15in": {"ring_capacity": None}}}})
    assert cfg.world.robots["15in"].ring_capacity is None
    assert cfg.world.robots["15in"].max_linear_mps == base.world.robots["15in"].max_linear_mps
    assert cfg.world.robots["24in"] == base.world.robots["24in"]
    with pytest.raises(ConfigError, match=r"robots\.15in"):
        make_config(world={"robots": {"15in": {"wheels": 6}}})
    with pytest.raises(ConfigError, match="n_rings"):
        make_config(observation={"n_rings": 0})


def test_ending_the_match_on_the_own_platform_earns_elevated_end() -> None:
    def end_on(x: float) -> float:
        cfg = make_config(
            world={"blue": [], "interaction_s": 1.0},
            reward={"elevated_end": 7.0},
            obs_noise=False,
            gps_noise=False,
        )
        core = MatchCore(cfg)
        core.reset(np.random.default_rng(0))
        core.world.place_robot(0, x, 0.0, 0.0)
        total, ended = 0.0, False
        while not ended:
            results, ended, _ = core.step([DriveCommand(0.0, 0.0)])
            total += results[0].components["elevated_end"]
        core.close()
        return total

    assert end_on(-60 * INCH) == pytest.approx(7.0), "parked on red's platform"
    assert end_on(60 * INCH) == 0.0, "blue's platform does not count for red"
    assert end_on(0.0) == 0.0


def test_approach_shaping_pays_for_getting_closer_and_sums_to_the_potential_change() -> None:
    cfg = make_config(
        world={"blue": [], "interaction_s": 2.0},
        reward={"approach": 2.0, "ring": 0.0},
        obs_noise=False,
        gps_noise=False,
    )
    core = MatchCore(cfg)
    core.reset(np.random.default_rng(0))
    w = core.world
    w.set_floor_rings(np.array([[1.0, 0.0], [-1.2, 0.0]]))
    w.place_robot(0, 0.0, 0.0, 90.0)  # faces the ring at x = 1
    core._potentials["approach"][0] = core._ring_potential(0)
    front = w.robots[0].config.length_m / 2
    assert core._potentials["approach"][0] == pytest.approx(1.0 - front)
    total, first = 0.0, None
    for _ in range(6):
        results, _, _ = core.step([DriveCommand(0.5, 0.0)])
        step = results[0].components["approach"]
        first = step if first is None else first
        total += step
    assert first > 0, "driving at the ring pays"
    assert total == pytest.approx(2.0 * (1.0 - front - core._ring_potential(0)))
    core.close()


def test_park_shaping_pays_for_nearing_the_own_platform_only_at_the_end() -> None:
    cfg = make_config(
        world={"blue": [], "interaction_s": 3.0},
        reward={"park": 4.0, "park_from_s": 1.0, "ring": 0.0},
        obs_noise=False,
        gps_noise=False,
    )
    core = MatchCore(cfg)
    core.reset(np.random.default_rng(0))
    w = core.world
    w.set_floor_rings(np.zeros((0, 2)))
    w.place_robot(0, -0.6, 0.0, 270.0)  # faces red's platform (its edge at x = -1.22 m)
    steps, ended = [], False
    while not ended:
        results, ended, _ = core.step([DriveCommand(0.1, 0.0)])
        steps.append((w.time_s, results[0].components["park"]))
    early = [v for t, v in steps if t < 2.0 - 1e-9]
    late = [v for t, v in steps if t >= 2.0 - 1e-9]
    assert early and all(v == 0.0 for v in early), "nothing before the last park_from_s s"
    assert late[0] < 0 and all(v > 0 for v in late[1:]), "the potential appears, then nearing pays"
    # The sum telescopes: it is the (negative) weighted distance left at the end.
    assert sum(late) == pytest.approx(-4.0 * core._park_potential(0))
    core.close()


def test_park_margin_pulls_past_the_platform_edge() -> None:
    def potential(margin: float) -> float:
        cfg = make_config(
            world={"blue": [], "interaction_s": 3.0},
            reward={"park": 1.0, "park_from_s": 10.0, "park_margin_m": margin},
            obs_noise=False,
            gps_noise=False,
        )
        core = MatchCore(cfg)
        core.reset(np.random.default_rng(0))
        plat = core.world.field.platform("red")
        inner_edge = plat.center[0] + plat.size[0] / 2  # the edge facing the field
        core.world.place_robot(0, inner_edge - 0.05, plat.center[1], 270.0)  # 5 cm inside
        value = core._park_potential(0)
        core.close()
        return value

    assert potential(0.0) == pytest.approx(0.0), "inside the platform: nothing left to gain"
    assert potential(0.2) == pytest.approx(0.15), "the target is 20 cm in from the edge"
    with pytest.raises(ConfigError, match="park_margin_m"):
        make_config(reward={"park_margin_m": -0.1})
