"""The batched world against the PyBullet twin's training fidelity: the same start from the same
seed, the same motion where nothing touches, and the same rules (intake, clamp, transfer, score,
pins) on its own states."""

from __future__ import annotations

import numpy as np
import pytest

from sim.config import WorldConfig
from sim.errors import ConfigError
from sim.fast.view import match_view
from sim.fast.world import FastWorld
from sim.world import rules
from sim.world.physics import World
from sim.world.state import DriveCommand

JITTER = {"start_jitter_m": 0.1, "start_jitter_deg": 30.0, "ring_jitter_m": 0.03}


def test_the_same_seed_starts_the_same_match() -> None:
    cfg = WorldConfig(**JITTER)
    fast = FastWorld(cfg, 3)
    fast.reset([5, 6, 7])
    for k, seed in enumerate([5, 6, 7]):
        with World(cfg) as w:
            w.reset(np.random.default_rng(seed))
            ref = np.array([(r.x, r.y, r.heading) for r in w.robots])
            assert np.allclose(ref, np.stack([fast.x[k], fast.y[k], fast.heading[k]], -1))
            assert np.allclose(w.ring_xy, fast.ring_xy[k])


def test_a_robot_alone_in_the_open_moves_as_in_pybullet() -> None:
    cfg = WorldConfig(blue=())
    fast = FastWorld(cfg, 1)
    fast.reset([0])
    rng = np.random.default_rng(3)
    with World(cfg) as w:
        w.reset(np.random.default_rng(0))
        w.place_robot(0, -0.6, 0.3, 10.0)
        fast.x[0, 0], fast.y[0, 0], fast.heading[0, 0] = -0.6, 0.3, 10.0
        for _ in range(8):
            lin, ang = rng.uniform(-0.3, 0.6), rng.uniform(-2.0, 2.0)
            w.step([DriveCommand(lin, ang)])
            fast.step(np.array([[lin]]), np.array([[ang]]))
            r = w.robots[0]
            assert (fast.x[0, 0], fast.y[0, 0]) == pytest.approx((r.x, r.y), abs=1e-4)
            assert fast.heading[0, 0] == pytest.approx(r.heading, abs=1e-3)
            assert fast.measured_v[0, 0] == pytest.approx(r.measured_v, abs=1e-3)


def test_driving_forward_collects_the_rings_ahead_and_the_clamp_scores_them() -> None:
    cfg = WorldConfig(blue=())
    fast = FastWorld(cfg, 2)
    fast.reset([0, 1])
    fast.ring_floor[:] = False
    fast.ring_floor[:, :3] = True
    fast.ring_xy[:, :3] = [(0.5, -0.4), (0.5, -0.2), (0.5, 0.0)]
    fast.x[:, 0], fast.y[:, 0], fast.heading[:, 0] = 0.5, -0.8, 0.0
    fast.ring_floor[1] = False  # the second match has no rings
    for _ in range(24):
        fast.step(np.full((2, 1), 0.6), np.zeros((2, 1)))
    assert list(fast.collected[:, 0]) == [3, 0]
    # Back onto the red goal in the corner: the auto clamp takes it, then rings move onto it.
    g = 0
    gx, gy = fast.gx[0, g], fast.gy[0, g]
    fast.x[0, 0], fast.y[0, 0], fast.heading[0, 0] = gx + 0.5, gy, 90.0
    events = [fast.step(np.array([[-0.5], [0.0]]), np.zeros((2, 1))) for _ in range(12)]
    assert fast.carried[0, 0] == g and fast.carrier[0, g] == 0
    assert any(e.clamped[0, 0] == g for e in events)
    for _ in range(30):
        fast.step(np.zeros((2, 1)), np.zeros((2, 1)))
    assert fast.goal_rings[0, g] == 3 and fast.held[0, 0] == 0
    red, _ = fast.totals()
    assert red[0] == rules.score(match_view(fast, 0))["red"].total > 0


def test_the_score_is_the_rules_score_of_each_match() -> None:
    cfg = WorldConfig(red=("24in", "15in"), blue=("24in", "15in"), **JITTER)
    fast = FastWorld(cfg, 6)
    fast.reset(range(6))
    rng = np.random.default_rng(1)
    for t in range(120):
        fast.step(rng.uniform(-1.0, 1.5, (6, 4)), rng.uniform(-3, 3, (6, 4)))
        if t % 20 == 0:
            fast.goal_rings[:] = rng.integers(0, 5, fast.goal_rings.shape)
            red, blue = fast.totals()
            for k in range(6):
                s = rules.score(match_view(fast, k))
                assert (s["red"].total, s["blue"].total) == (red[k], blue[k])


def test_robots_stay_inside_the_walls_and_do_not_pass_through_each_other() -> None:
    cfg = WorldConfig(red=("24in", "15in"), blue=("24in", "15in"), **JITTER)
    fast = FastWorld(cfg, 32)
    fast.reset(range(32))
    rng = np.random.default_rng(2)
    for t in range(300):
        if t % 12 == 0:
            lin, ang = rng.uniform(-1.0, 1.5, (32, 4)), rng.uniform(-4, 4, (32, 4))
        fast.step(lin, ang)
        assert np.all(np.abs(fast.x) < fast.field.half) and np.all(np.abs(fast.y) < fast.field.half)
        assert fast.overlaps().max() < 0.05  # what one substep may leave to the next


def test_a_pin_is_called_after_pin_time_in_contact() -> None:
    cfg = WorldConfig(pin_time_s=1.0)
    fast = FastWorld(cfg, 1)
    fast.reset([0])
    fast.x[0], fast.y[0], fast.heading[0] = (-0.2, 0.2), (0.45, 0.45), (90.0, 270.0)
    pins = [fast.step(np.array([[0.3, 0.3]]), np.zeros((1, 2))).pins[0, 0] for _ in range(24)]
    assert sum(pins) == 2 and pins.index(True) == 11  # every 12 steps of contact at 12 Hz


def test_a_world_it_cannot_model_is_refused_by_name() -> None:
    with pytest.raises(ConfigError, match="occlude_with_rings"):
        FastWorld(WorldConfig(occlude_with_rings=True))
    with pytest.raises(ConfigError, match="fidelity"):
        FastWorld(WorldConfig(fidelity="high"))


def test_a_non_finite_command_stops_the_robot_and_an_ended_match_stands_still() -> None:
    cfg = WorldConfig(blue=(), interaction_s=1.0)
    fast = FastWorld(cfg, 2)
    fast.reset([0, 1])
    for _ in range(3):
        fast.step(np.array([[0.6], [0.6]]), np.zeros((2, 1)))
    fast.step(np.array([[np.nan], [0.6]]), np.zeros((2, 1)))
    assert fast.v[0, 0] < fast.v[1, 0]
    for _ in range(12):
        events = fast.step(np.full((2, 1), 0.6), np.zeros((2, 1)))
    assert events.match_over.all()
    x = fast.x.copy()
    fast.step(np.full((2, 1), 0.6), np.zeros((2, 1)))
    assert np.array_equal(fast.x, x) and np.allclose(fast.time_s, 1.0)


def test_intake_and_pushed_rings_are_the_twins_arithmetic() -> None:
    """Robots at rest with rings scattered at their fronts and under them: one step takes and
    shoves the same rings to the same places in both worlds."""
    cfg = WorldConfig(push_rings=True, blue=())
    rng = np.random.default_rng(4)
    fast = FastWorld(cfg, 1)
    with World(cfg) as w:
        for trial in range(12):
            w.reset(np.random.default_rng(trial))
            fast.reset([trial])
            # Clear of every goal, so nothing moves the robot in the step.
            x = rng.choice([-1, 1]) * rng.uniform(0.45, 0.8)
            y, h = rng.uniform(-0.4, 0.4), rng.uniform(0, 360)
            w.place_robot(0, x, y, h)
            fast.x[0, 0], fast.y[0, 0], fast.heading[0, 0] = x, y, h
            n = len(w.ring_xy)
            near = np.array([x, y]) + rng.uniform(-0.35, 0.35, (n, 2))
            w.set_floor_rings(near)
            fast.ring_xy[0, : len(near)] = near
            fast.ring_floor[0] = False
            fast.ring_floor[0, : len(near)] = True
            w.step([DriveCommand(0.0, 0.0)])
            fast.step(np.zeros((1, 1)), np.zeros((1, 1)))
            assert fast.collected[0, 0] == w.robots[0].collected > 0
            floor = w.ring_state == 0
            assert np.array_equal(fast.ring_floor[0, :n], floor[: len(near)])
            assert np.allclose(fast.ring_xy[0, :n][floor], w.ring_xy[floor], atol=1e-9)


def test_commands_of_the_wrong_shape_are_refused_by_name() -> None:
    fast = FastWorld(WorldConfig(), 3)
    fast.reset(range(3))
    with pytest.raises(ValueError, match=r"linear must have shape \(3, 2\)"):
        fast.step(np.zeros((2, 3)), np.zeros((3, 2)))
    with pytest.raises(ValueError, match="clamp must have shape"):
        fast.step(np.zeros((3, 2)), np.zeros((3, 2)), clamp=np.zeros(3))
    assert not fast.steps.any()  # nothing moved


def test_small_batches_run_their_compiled_loops_on_one_thread() -> None:
    import numba

    from sim.fast.kernels import SERIAL_BELOW, threads_for

    before = numba.get_num_threads()
    with threads_for(SERIAL_BELOW - 1):
        assert numba.get_num_threads() == 1
    assert numba.get_num_threads() == before  # the caller's setting comes back
    with threads_for(SERIAL_BELOW):
        assert numba.get_num_threads() == before
