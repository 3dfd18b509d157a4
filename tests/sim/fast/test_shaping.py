"""The compiled shaping potentials (sim.fast.shaping) against sim.rewards' numpy functions, value
for value: on random batches (rings gone, intakes full, goals held or none free, robots inside
and outside their platforms) and on FastMatches' learners through default.toml's matches."""

from __future__ import annotations

from dataclasses import replace

import numpy as np

from sim.fast.matches import FastMatches
from sim.fast.shaping import learner_potentials
from sim.rewards import goal_potential, park_potential, ring_potential
from sim.training.config import load_config
from sim.training.rollout import RolloutConfig


def _numpy(
    x: np.ndarray,
    y: np.ndarray,
    heading_deg: np.ndarray,
    half_length: np.ndarray,
    room: np.ndarray,
    ring_xy: np.ndarray,
    floor: np.ndarray,
    offsets: np.ndarray,
    goal_xy: np.ndarray,
    eligible: np.ndarray,
    holding: np.ndarray,
    platform: np.ndarray,
    flags: np.ndarray,
) -> np.ndarray:
    """The three potentials through sim.rewards, one robot a match ((B, 1, ...) batches)."""
    x, y = x[:, None], y[:, None]
    rad = np.radians(heading_deg)[:, None]
    length = half_length[:, None]
    front = np.stack([x + length * np.sin(rad), y + length * np.cos(rad)], -1)
    rings = ring_potential(front, room[:, None], ring_xy, floor)[:, 0]
    clamp = np.stack([x + offsets * np.sin(rad), y + offsets * np.cos(rad)], -1)[:, None]
    goals = goal_potential(clamp, goal_xy, eligible[:, None], holding[:, None])[:, 0]
    centre, half = platform[:, None, :2], platform[:, None, 2:]
    park = park_potential(np.stack([x, y], -1), centre, half, flags[:, 2:3])[:, 0]
    return np.where(flags, np.stack([rings, goals, park], -1), 0.0)


def _compiled(heading_deg: np.ndarray, *args: np.ndarray) -> np.ndarray:
    x, y, *rest, flags = args
    rad = np.radians(heading_deg)
    return learner_potentials(x, y, np.sin(rad), np.cos(rad), *rest, *flags.T)


def test_the_compiled_potentials_equal_sim_rewards_on_random_batches() -> None:
    rng = np.random.default_rng(0)
    b, n, g = 300, 48, 5
    x, y = rng.uniform(-1.8, 1.8, (2, b))
    heading = rng.uniform(0.0, 360.0, b)
    half_length = rng.choice([0.19, 0.3], b)
    room = rng.integers(-1, 3, b)
    ring_xy = rng.uniform(-1.8, 1.8, (b, n, 2))
    floor = rng.random((b, n)) < rng.choice([0.0, 0.05, 0.8], (b, 1))
    offsets = rng.choice([-0.25, -0.2, 0.2], (b, g))
    goal_xy = rng.uniform(-1.8, 1.8, (b, g, 2))
    eligible = rng.random((b, g)) < rng.choice([0.0, 0.5, 1.0], (b, 1))
    holding = rng.random(b) < 0.2
    platform = np.column_stack(
        [rng.uniform(-1.5, 1.5, (b, 2)), rng.uniform(0.0, 0.6, (b, 2))]
    )  # fmt: skip
    flags = rng.random((b, 3)) < 0.8
    args = (x, y, heading, half_length, room, ring_xy, floor, offsets, goal_xy, eligible,
            holding, platform, flags)  # fmt: skip
    want = _numpy(*args)
    got = _compiled(heading, x, y, *args[3:])
    np.testing.assert_array_equal(got, want)
    assert (want > 0).all(axis=0).sum() == 0 and (want > 0).any(axis=0).all()
    assert ((want[:, 2] == 0) & flags[:, 2]).any()  # inside the platform's box


def test_fast_matches_pay_sim_rewards_potentials() -> None:
    """default.toml's shapings (parking paid all match long), through matches that restart."""
    cfg = load_config("default")
    env = cfg.env_config()
    env = replace(env, max_steps=70, reward=replace(env.reward, park_from_s=500.0))
    n = 8
    fm = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=n), seed=4)
    fm.set_kinds([("policy", -1)] * n)
    fm.reset()
    rng = np.random.default_rng(2)
    w = fm.world
    rows = np.arange(n)
    paid = np.zeros(3)
    for _ in range(200):
        me = fm.learner
        weights = np.stack(
            [fm._reward_config(k) != 0 for k in ("approach", "goal_approach", "park")], -1
        )
        margin = fm._reward_config("park_margin_m")[:, None]
        platform = np.column_stack(
            [fm._platforms[me, :2], np.maximum(fm._platforms[me, 2:] / 2 - margin, 0.0)]
        )
        want = _numpy(
            w.x[rows, me], w.y[rows, me], w.heading[rows, me], w.half_l[me], w.room[rows, me],
            w.ring_xy, w.ring_floor, w.clamp_offsets[me], np.stack([w.gx, w.gy], -1),
            fm._scores_for[me] & (w.carrier < 0), w.carried[rows, me] >= 0, platform, weights,
        )  # fmt: skip
        got = fm._potential_now(0)
        for j, name in enumerate(("approach", "goal_approach", "park")):
            np.testing.assert_array_equal(got[name], want[:, j], err_msg=name)
        paid += (want != 0).sum(axis=0)
        actions = rng.normal(size=(n, env.action_size))
        fm.step(actions, actions)
    assert (paid > 100).all(), paid
