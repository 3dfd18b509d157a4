"""The batched memories against the robot's own (jetson.autonomy.ring_memory.RingMemory and
goal_memory.GoalMemory, one per robot, fed the same sightings, clamp and GPS poses): the frames
built from them equal, value for value, ring, route and goal slots, through forgetting, merging,
the route's target switches and goals clamped and put down."""

from __future__ import annotations

from dataclasses import replace

import numpy as np
import pytest

from jetson.autonomy.geometry import field_to_robot
from jetson.autonomy.goal_memory import GoalMemory
from jetson.autonomy.observation import RobotView, build_frame
from jetson.autonomy.ring_memory import RingMemory
from jetson.autonomy.spec import REMEMBERED, ObservationSpec
from sim.config import WorldConfig
from sim.errors import ConfigError
from sim.fast.observe import FastObserver
from sim.fast.view import match_view
from sim.fast.world import FastWorld
from sim.match import memory_camera
from sim.world import sensors
from tests.sim.fast.worlds import RING_RACE_2V2


def _prior(world: FastWorld) -> tuple[tuple[float, float], ...]:
    return tuple((float(x), float(y)) for x, y in np.round(world.field.ring_positions, 4))


def _view(world: FastWorld, k: int, i: int, pose: np.ndarray) -> RobotView:
    """What MatchCore.view gives robot i of match k: the rings seen in its true frame, the GPS
    pose `pose[k, i]`."""
    v = match_view(world, k)
    r = v.robots[i]
    rings = sensors.visible_rings(v, i)
    seen = sensors.rings_in_robot_frame(v, i, rings) if len(rings) else np.zeros((0, 2))
    pts = np.array([(o.x, o.y) for o in v.robots if o.index != i]).reshape(-1, 2)
    return RobotView(
        x=float(pose[k, i, 0]),
        y=float(pose[k, i, 1]),
        heading_deg=float(pose[k, i, 2]),
        alliance=r.alliance,
        time_s=v.time_s,
        rings_robot_xy=seen,
        rings_held=r.held,
        others_robot_xy=field_to_robot(pts, r.xy, r.heading),
        goal_clamped=r.carried_goal is not None,
        intake_fills=r.config.ring_capacity is not None,
    )


@pytest.mark.parametrize("memory_view", ["cone", "camera"])
def test_frames_with_the_memory_equal_ringmemory_value_for_value(memory_view: str) -> None:
    n = 4
    world = FastWorld(RING_RACE_2V2, n)
    world.reset(range(n))
    goals = [g.position for g in world.field.goals if g.alliance in (None, "red")]
    spec = ObservationSpec(
        version=5,
        n_stack=0,
        n_other_robots=1,
        ring_memory=True,
        route_slots=2,
        prior_rings=_prior(world),
        memory_view=memory_view,
        goal_memory=True,
        prior_goals=tuple((float(x), float(y)) for x, y in np.round(goals, 4)),
        goal_clamp_offset_m=round(abs(float(world.clamp_offsets[0, 0])), 4),
    )
    obs = FastObserver(world, spec, obs_noise=False, gps_noise=True, rng=np.random.default_rng(3))
    z = world.field.ring.thickness / 2
    memories = [
        [RingMemory(spec, memory_camera(rc.camera, z)) for rc in world.robot_configs]
        for _ in range(n)
    ]
    goal_memories = [[GoalMemory(spec) for _ in range(4)] for _ in range(n)]
    rng = np.random.default_rng(0)
    remembered = switched = clamps = toggles = 0
    targets = {}
    for t in range(150):
        if t:
            # Drive mostly backwards now and then, the clamp open at times: goals are clamped,
            # carried and put down again.
            back = -1.0 if (t // 25) % 2 else 1.0
            linear = back * rng.uniform(-0.3, 1.0, (n, 4))
            clamp = np.where(rng.random((n, 4)) < 0.05, 0, -1)  # release now and then, else auto
            world.step(linear, rng.uniform(-2.0, 2.0, (n, 4)), clamp=clamp)
            clamps += int((world.carried >= 0).sum())
        pose = obs.pose()  # the GPS with its noise: both memories place rings from it
        frames = obs.frames(obs.visible(), pose)
        for k in range(n):
            for i in range(4):
                view = memories[k][i].observe(_view(world, k, i, pose))
                was = goal_memories[k][i].holding
                ref = build_frame(spec, goal_memories[k][i].observe(view))
                toggles += was != goal_memories[k][i].holding
                assert np.allclose(frames[k, i], ref, atol=1e-6), (t, k, i)
                remembered += int((ref[spec.ring_offset + 2 :: 3] == REMEMBERED).sum())
                target = memories[k][i].target
                if target is not None:
                    old = targets.get((k, i))
                    switched += old is not None and not np.array_equal(old, target)
                    targets[(k, i)] = target.copy()
    assert obs.memory is not None and not obs.memory.overflow.any()
    # Goals were clamped (leaving the goal slots) and put down (coming back) several times.
    assert clamps > 50 and toggles >= 4, (clamps, toggles)
    assert remembered > 1000  # the memory, not only what is in view, filled the slots
    assert switched > 20  # the route moved on from ring to ring


def test_a_reset_match_starts_from_the_prior_and_other_matches_keep_theirs() -> None:
    world = FastWorld(RING_RACE_2V2, 2)
    world.reset(range(2))
    spec = ObservationSpec(version=5, n_stack=1, ring_memory=True, prior_rings=_prior(world))
    obs = FastObserver(world, spec, obs_noise=False, gps_noise=False)
    obs.reset()
    memory = obs.memory
    assert memory is not None
    for _ in range(40):  # drive forward: rings are taken and seen, the memories change
        world.step(np.full((2, 4), 0.8), np.zeros((2, 4)))
        obs.push()
    changed = memory.known[1, 0, : memory.count[1, 0]].copy()
    assert not np.array_equal(changed[: len(spec.prior_rings)], np.array(spec.prior_rings))
    world.reset_matches(np.array([0]), [np.random.default_rng(5)])
    obs.reset(np.array([0]))
    # Match 0 starts anew from the prior and one look; match 1's memory is as it was.
    assert np.array_equal(memory.known[1, 0, : memory.count[1, 0]], changed)
    assert memory.count[0, 0] >= len(spec.prior_rings) - 4


def test_memory_features_not_batched_are_refused_by_name() -> None:
    world = FastWorld(WorldConfig(), 1)
    prior = _prior(world)
    with pytest.raises(ConfigError, match="goal_clamp_offset_m"):
        FastObserver(world, ObservationSpec(version=3, goal_memory=True))  # no prior given
    spec = ObservationSpec(
        version=5,
        ring_memory=True,
        prior_rings=prior,
        memory_forget_intake=True,
        memory_intake_zone=(-0.1, 0.1, 0.1, 0.3),
    )
    with pytest.raises(ConfigError, match="memory_forget_intake"):
        FastObserver(world, spec)


def test_goal_memories_corrected_by_sight_equal_goalmemory_value_for_value() -> None:
    """spec.goal_sight: the batched goal memory fed the goals each camera sees
    (FastObserver.goals_in_view) equals GoalMemory fed sim.goal_sight's report, through goals
    pushed, clamped and put down."""
    from sim.goal_sight import visible_goals

    n = 4
    world = FastWorld(RING_RACE_2V2, n)
    world.reset(range(n))
    goals = [g.position for g in world.field.goals if g.alliance in (None, "red")]
    spec = ObservationSpec(
        version=6, n_stack=0, n_other_robots=1, goal_memory=True, goal_sight=True,
        prior_goals=tuple((float(x), float(y)) for x, y in np.round(goals, 4)),
        goal_clamp_offset_m=round(abs(float(world.clamp_offsets[0, 0])), 4),
    )  # fmt: skip
    obs = FastObserver(world, spec, obs_noise=False, gps_noise=True, rng=np.random.default_rng(3))
    memories = [[GoalMemory(spec) for _ in range(4)] for _ in range(n)]
    plain = replace(spec, goal_sight=False)  # dead reckoning alone, to tell what sight changed
    reckoned = [[GoalMemory(plain) for _ in range(4)] for _ in range(n)]
    rng = np.random.default_rng(1)
    seen = corrected = 0
    for t in range(150):
        if t:
            back = -1.0 if (t // 25) % 2 else 1.0
            linear = back * rng.uniform(-0.3, 1.0, (n, 4))
            clamp = np.where(rng.random((n, 4)) < 0.05, 0, -1)
            world.step(linear, rng.uniform(-2.0, 2.0, (n, 4)), clamp=clamp)
        pose = obs.pose()
        in_view = obs.goals_in_view()
        frames = obs.frames(obs.visible(), pose)
        for k in range(n):
            v = match_view(world, k)
            for i in range(4):
                view = _view(world, k, i, pose)
                view.goals_seen_robot = visible_goals(v, i)
                assert in_view[k, i].sum() == len(view.goals_seen_robot), (t, k, i)
                seen += len(view.goals_seen_robot)
                ref = build_frame(spec, memories[k][i].observe(view))
                assert np.allclose(frames[k, i], ref, atol=1e-6), (t, k, i)
                alone = reckoned[k][i]
                alone.observe(view)
                got = memories[k][i].known
                corrected += got.shape != alone.known.shape or not np.allclose(got, alone.known)
    assert seen > 300 and corrected > 100, (seen, corrected)
