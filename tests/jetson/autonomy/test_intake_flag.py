"""Observation spec version 5: the `fills` scalar says whether the robot's intake has a capacity,
and training can mix matches whose intakes never fill (uncapped_share)."""

from __future__ import annotations

import numpy as np
import pytest

from jetson.autonomy.observation import FrameStack, RobotView, build_frame
from jetson.autonomy.ring_memory import RingMemory
from jetson.autonomy.spec import ObservationSpec, observation_bounds
from jetson.errors import ObservationError

FLAG = ObservationSpec(version=5, intake_flag=True, goal_memory=True, prior_goals=((0.0, 1.0),))


def view(**kw) -> RobotView:
    base = dict(x=0.0, y=0.0, heading_deg=0.0, alliance="red", time_s=10.0, rings_held=3)
    base.update(kw)
    return RobotView(**base)  # type: ignore[arg-type]


def test_the_fills_scalar_follows_clamped_and_reads_the_view() -> None:
    assert FLAG.scalars[-2:] == ("clamped", "fills")
    i = FLAG.scalar_index("fills")
    assert i == 7 and FLAG.goal_offset == 8
    capped = build_frame(FLAG, view(goal_clamped=True))
    never = build_frame(FLAG, view(goal_clamped=True, intake_fills=False))
    assert capped[i] == 1.0 and never[i] == 0.0
    assert capped[FLAG.scalar_index("clamped")] == never[FLAG.scalar_index("clamped")] == 1.0
    assert np.array_equal(np.delete(capped, i), np.delete(never, i)), "only the flag differs"
    assert "intake" in FLAG.describe()[i]
    low, high = observation_bounds(FLAG)
    assert (low[i], high[i]) == (0.0, 1.0)
    stack = FrameStack(FLAG)
    assert stack.reset(never).shape == (FLAG.size,)


def test_the_flag_needs_version_5_and_leaves_older_fingerprints_alone() -> None:
    with pytest.raises(ObservationError, match="intake_flag needs observation spec version 5"):
        ObservationSpec(version=4, intake_flag=True)
    with pytest.raises(ObservationError, match="no 'fills' scalar"):
        ObservationSpec(version=4).scalar_index("fills")
    # A version-4 policy's spec, read back from its policy.json (no intake_flag key), hashes as
    # it did before the flag existed: the field is left out of the hash while it is off.
    old = ObservationSpec(version=4)
    assert (
        old.fingerprint()
        == ObservationSpec.from_dict(
            {k: v for k, v in old.to_dict().items() if k != "intake_flag"}
        ).fingerprint()
    )
    assert ObservationSpec(version=5).fingerprint() != FLAG.fingerprint()
    assert ObservationSpec(version=5, intake_flag=True).size == ObservationSpec(version=5).size + 11


def test_the_route_plans_a_full_intake_when_the_intake_never_fills() -> None:
    rings = tuple((0.0, 0.3 * k) for k in range(1, 12))
    spec = ObservationSpec(
        version=5, ring_memory=True, prior_rings=rings, route_slots=3, route_candidates=6
    )
    far = np.array([[0.0, 0.3 * k] for k in range(1, 12)])

    def route(fills: bool) -> int:
        memory = RingMemory(spec)
        v = memory.observe(view(rings_held=9, intake_fills=fills, rings_robot_xy=far[:2]))
        return len(v.route_robot_xy)

    # A 10-ring intake holding 9 has room for one stop; one that never fills plans three.
    assert route(True) == 1
    assert route(False) == 3


def test_uncapped_share_gives_matches_whose_intakes_never_fill() -> None:
    pytest.importorskip("pybullet")
    from sim.errors import ConfigError
    from sim.match import MatchCore, make_config

    with pytest.raises(ConfigError, match="uncapped_share"):
        make_config(uncapped_share=1.5)
    obs_cfg = {"version": 5, "intake_flag": True, "goal_memory": True}
    core = MatchCore(make_config(uncapped_share=0.5, observation=obs_cfg))
    i = core.spec.scalar_index("fills")
    seen = []
    for seed in range(12):
        obs = core.reset(np.random.default_rng(seed))
        caps = {r.config.ring_capacity for r in core.world.robots}
        assert caps in ({10}, {None}), "every robot's intake alike within a match"
        flag = {float(o[i]) for o in obs}
        assert flag == ({1.0} if caps == {10} else {0.0})
        seen.append(caps == {None})
    assert 2 <= sum(seen) <= 10, "about half the matches"
    core.close()
    plain = MatchCore(make_config(observation=obs_cfg))
    for seed in range(4):
        obs = plain.reset(np.random.default_rng(seed))
        assert all(o[i] == 1.0 for o in obs)
        assert all(r.config.ring_capacity == 10 for r in plain.world.robots)
    plain.close()


def test_uncapped_matches_take_their_own_reward() -> None:
    pytest.importorskip("pybullet")
    from sim.errors import ConfigError
    from sim.match import MatchCore, make_config
    from sim.world.state import DriveCommand

    with pytest.raises(ConfigError, match=r"\[env.uncapped_reward\]: unknown keys \['sore'\]"):
        make_config(uncapped_reward={"sore": 0.0})
    cfg = make_config(uncapped_share=0.5, reward={"ring": 2.0}, uncapped_reward={"ring": 0.0})
    assert cfg.match_reward(False).ring == 2.0 and cfg.match_reward(True).ring == 0.0
    core = MatchCore(cfg)
    paid = {True: 0.0, False: 0.0}
    seen = set()
    for seed in range(10):
        core.reset(np.random.default_rng(seed))
        uncapped = core.world.robots[0].config.ring_capacity is None
        assert core.reward.ring == (0.0 if uncapped else 2.0)
        seen.add(uncapped)
        for _ in range(30):  # straight ahead from the start: into the rings there
            results, _, _ = core.step([DriveCommand(1.0, 0.0) for _ in core.world.robots])
            paid[uncapped] += sum(r.components["rings"] for r in results)
    assert seen == {True, False}
    assert paid[False] > 0 and paid[True] == 0.0, "the step pays the match's own reward"
    core.close()
