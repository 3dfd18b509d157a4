"""The batched observation against the per-robot builder the Jetson runs: value for value without
noise, the spec's noise within its bounds, and the stack newest first."""

from __future__ import annotations

import numpy as np
import pytest

from jetson.autonomy.geometry import field_to_robot
from jetson.autonomy.observation import RobotView, build_frame
from jetson.autonomy.spec import ObservationSpec
from sim.config import WorldConfig, world_preset
from sim.fast.observe import FastObserver
from sim.fast.view import match_view
from sim.fast.world import FastWorld
from sim.world import sensors
from tests.sim.fast.worlds import RING_RACE_2V2


def _reference(world: FastWorld, spec: ObservationSpec, k: int, i: int) -> np.ndarray:
    """build_frame of robot i of match k, from the view MatchCore would give it (truth pose)."""
    v = match_view(world, k)
    r = v.robots[i]
    rings = sensors.visible_rings(v, i)
    seen = sensors.rings_in_robot_frame(v, i, rings) if len(rings) else np.zeros((0, 2))
    pts = np.array([(o.x, o.y) for o in v.robots if o.index != i]).reshape(-1, 2)
    view = RobotView(
        x=r.x,
        y=r.y,
        heading_deg=r.heading,
        alliance=r.alliance,
        time_s=v.time_s,
        rings_robot_xy=seen,
        rings_held=r.held,
        others_robot_xy=field_to_robot(pts, r.xy, r.heading),
        intake_fills=r.config.ring_capacity is not None,
    )
    return build_frame(spec, view)


@pytest.mark.parametrize("game", ["ring_race", "tipping_point"])
def test_frames_equal_the_jetson_builder_value_for_value(game: str) -> None:
    """The ring race 2v2, and the whole game (its isolation period, see-saws and tugs)."""
    length = 120.0 if game == "tipping_point" else 105.0
    spec = ObservationSpec(
        version=5, n_other_robots=3, n_stack=0, intake_flag=True, match_length_s=length
    )
    cfg = world_preset("tipping_point_2v2") if game == "tipping_point" else RING_RACE_2V2
    world = FastWorld(cfg, 8)
    world.reset(range(8))
    obs = FastObserver(world, spec, obs_noise=False, gps_noise=False)
    rng = np.random.default_rng(0)
    seen = 0
    for t in range(60):
        world.step(rng.uniform(-0.5, 1.5, (8, 4)), rng.uniform(-3, 3, (8, 4)))
        if t % 3:
            continue
        frames = obs.frames()
        for k in range(8):
            for i in range(4):
                ref = _reference(world, spec, k, i)
                assert np.allclose(frames[k, i], ref, atol=1e-6), (t, k, i)
                seen += int(ref[spec.ring_offset + 2 :: 3].sum())
    assert seen > 100  # rings were in view, not only empty slots


def test_noise_stays_within_the_spec_and_the_stack_is_newest_first() -> None:
    spec = ObservationSpec(n_stack=2)
    world = FastWorld(WorldConfig(**{"start_jitter_m": 0.1}), 64)
    world.reset(range(64))
    clean = FastObserver(world, spec, obs_noise=False, gps_noise=False)
    noisy = FastObserver(world, spec, rng=np.random.default_rng(1))
    first = noisy.reset()
    assert first.shape == (64, 2, spec.size)
    a, b = clean.frames(), noisy.frames()
    # Own position: GPS (about 1.5 cm) plus uniform +-position_noise_m.
    bound = (spec.position_noise_m + 0.1) / spec.length_unit_m
    assert np.abs(a[..., 1:3] - b[..., 1:3]).max() < bound
    assert np.abs(a[..., 1:3] - b[..., 1:3]).std() > 0.01
    world.step(np.full((64, 2), 0.6), np.zeros((64, 2)))
    stacked = noisy.push()
    f = spec.frame_size
    assert np.array_equal(stacked[..., f : 2 * f], first[..., :f])
    assert stacked[0, 0, 0] > first[0, 0, 0]  # the clock moved on in the newest frame


def test_the_partner_block_equals_the_per_robot_builder() -> None:
    """Observation spec 6's partner block, batched, against build_frame with sim.match's
    partner_view: where each robot's partner is, its clamp and rings, and its claim (some
    robots claim a target, some nothing); a lone robot (the 1v1 world) has an empty block."""
    from sim.match import partner_view

    spec = ObservationSpec(version=6, partner=True, n_stack=0, match_length_s=120.0)
    world = FastWorld(world_preset("tipping_point_2v2"), 6)
    world.reset(range(6))
    obs = FastObserver(world, spec, obs_noise=False, gps_noise=False)
    rng = np.random.default_rng(3)
    lo = spec.partner_offset
    claimed = 0
    for t in range(40):
        world.step(rng.uniform(-0.5, 1.5, (6, 4)), rng.uniform(-3, 3, (6, 4)))
        claims = rng.uniform(-1.5, 1.5, (6, 4, 2))
        claims[rng.random((6, 4)) < 0.4] = np.nan  # these robots claim nothing
        obs.claims[:] = claims
        if t % 4:
            continue
        frames = obs.frames()
        for k in range(6):
            v = match_view(world, k)
            by_index = [None if np.isnan(c).any() else (c[0], c[1]) for c in claims[k]]
            for i in range(4):
                r = v.robots[i]
                view = RobotView(
                    x=r.x, y=r.y, heading_deg=r.heading, alliance=r.alliance, time_s=v.time_s,
                    rings_robot_xy=np.zeros((0, 2)), partner=partner_view(v, i, by_index),
                )  # fmt: skip
                ref = build_frame(spec, view)
                assert np.allclose(frames[k, i, lo : lo + 8], ref[lo : lo + 8], atol=1e-6)
                claimed += int(ref[lo + 7])
                assert ref[lo + 2] == 1.0  # every robot of a 2v2 has its partner
    assert claimed > 20
    lone = FastWorld(WorldConfig(), 2)
    lone.reset(range(2))
    frames = FastObserver(lone, spec, obs_noise=False, gps_noise=False).frames()
    assert not frames[..., lo : lo + 8].any()


def test_the_seen_opponents_equal_the_per_robot_builder() -> None:
    """With seen_opponents the other-robot slots hold the opponents whose plates the camera
    sees (sim.visibility.plates_in_view), batched as sim.match.robot_view builds them."""
    from sim.match import robot_view

    spec = ObservationSpec(
        version=6, n_other_robots=2, seen_opponents=True, n_stack=0, match_length_s=120.0
    )
    world = FastWorld(world_preset("tipping_point_2v2"), 8)
    world.reset(range(8))
    obs = FastObserver(world, spec, obs_noise=False, gps_noise=False)
    rng = np.random.default_rng(5)
    lo, seen = len(spec.scalars), 0
    for t in range(90):
        world.step(rng.uniform(-0.5, 1.5, (8, 4)), rng.uniform(-2, 2, (8, 4)))
        if t % 3:
            continue
        frames = obs.frames()
        for k in range(8):
            v = match_view(world, k)
            for i in range(4):
                r = v.robots[i]
                view = robot_view(v, spec, i, (r.x, r.y, r.heading), np.zeros(0, np.int64))
                ref = build_frame(spec, view)
                assert np.allclose(frames[k, i, lo : lo + 6], ref[lo : lo + 6], atol=1e-6)
                seen += int(ref[lo + 2] > 0)
    assert seen > 10  # opponents were in view, not only empty slots


def test_the_role_flag_marks_the_robot_that_reaches_the_high_branch() -> None:
    """role_flag's `tall` scalar, batched, as sim.match.robot_view builds it: 1 for each
    alliance's 24-inch robot, 0 for its 15-inch one."""
    from sim.match import robot_view

    spec = ObservationSpec(version=6, role_flag=True, n_stack=0, match_length_s=120.0)
    world = FastWorld(world_preset("tipping_point_2v2"), 2)
    world.reset(range(2))
    frames = FastObserver(world, spec, obs_noise=False, gps_noise=False).frames()
    k = spec.scalar_index("tall")
    for m in range(2):
        v = match_view(world, m)
        for i, r in enumerate(v.robots):
            ref = build_frame(spec, robot_view(v, spec, i, (r.x, r.y, r.heading), np.zeros(0, int)))
            assert frames[m, i, k] == ref[k] == float(r.config.reaches_high_branch)
    assert frames[:, :, k].tolist() == [[1.0, 0.0, 1.0, 0.0]] * 2
