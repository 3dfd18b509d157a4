"""The goal memory (observation spec version 3): where the goals the robot could score with are,
by dead reckoning from the layout and the Brain's clamp switch."""

from __future__ import annotations

import json

import numpy as np
import pytest

from jetson.autonomy.goal_memory import GoalMemory
from jetson.autonomy.observation import RobotView, build_frame
from jetson.autonomy.spec import ObservationSpec
from jetson.errors import ObservationError

# Two goals for a red robot at the origin facing +y (heading 0): one right behind its back (where
# the clamp takes a goal), one far ahead.
OFFSET = 0.36
PRIOR = ((0.0, -OFFSET), (0.0, 2.0))
SPEC = ObservationSpec(goal_memory=True, prior_goals=PRIOR, goal_clamp_offset_m=OFFSET, n_stack=0)


def view(**kw) -> RobotView:
    base = dict(x=0.0, y=0.0, heading_deg=0.0, alliance="red", time_s=5.0)
    base.update(kw)
    return RobotView(**base)  # type: ignore[arg-type]


def goal_slots(spec: ObservationSpec, v: RobotView) -> np.ndarray:
    frame = build_frame(spec, v)
    return frame[spec.goal_offset : spec.ring_offset].reshape(spec.n_goals, 3)


def test_layout_of_a_version_3_frame() -> None:
    names = SPEC.frame_names()
    assert names[:7] == ["time", "x", "y", "cos_h", "sin_h", "held", "clamped"]
    assert names[SPEC.goal_offset : SPEC.goal_offset + 3] == ["goal0_x", "goal0_y", "goal0_ok"]
    assert names[SPEC.ring_offset] == "ring0_x"
    assert SPEC.frame_size == 7 + 3 * 3 + 3 * 10
    assert not SPEC.needs_prior
    assert ObservationSpec(goal_memory=True).needs_prior, "no layout and no clamp offset yet"
    assert all("goal" in line or "clamp" in line for line in SPEC.describe()[6:16])


def test_the_clamped_flag_and_the_goals_reach_the_frame() -> None:
    mem = GoalMemory(SPEC)
    out = mem.observe(view())
    s = goal_slots(SPEC, out)
    # Nearest first, robot frame / length unit, ok 1; the third slot empty.
    np.testing.assert_allclose(s[0], [0.0, -OFFSET / SPEC.length_unit_m, 1.0], rtol=1e-6)
    np.testing.assert_allclose(s[1], [0.0, 2.0 / SPEC.length_unit_m, 1.0], rtol=1e-6)
    assert s[2].tolist() == [0.0, 0.0, 0.0]
    assert build_frame(SPEC, out)[6] == 0.0
    assert build_frame(SPEC, mem.observe(view(goal_clamped=True)))[6] == 1.0


def test_clamping_takes_the_goal_behind_and_releasing_leaves_it_at_the_clamp_point() -> None:
    mem = GoalMemory(SPEC)
    mem.observe(view())
    out = mem.observe(view(goal_clamped=True))
    np.testing.assert_allclose(mem.known, [(0.0, 2.0)])
    assert goal_slots(SPEC, out)[1, 2] == 0.0, "the held goal is not a slot"
    # Drive 1 m to the right holding it, turn to face -x (heading 270), let go: the goal stays
    # at the clamp point, OFFSET behind the back (+x of the robot).
    mem.observe(view(x=1.0, goal_clamped=True))
    mem.observe(view(x=1.0, heading_deg=270.0, goal_clamped=True))
    mem.observe(view(x=1.0, heading_deg=270.0, goal_clamped=False))
    np.testing.assert_allclose(mem.known, [(0.0, 2.0), (1.0 + OFFSET, 0.0)], atol=1e-9)


def test_a_goal_whose_place_the_robot_drives_over_is_forgotten() -> None:
    mem = GoalMemory(SPEC)
    mem.observe(view(y=1.9))
    np.testing.assert_allclose(mem.known, [(0.0, -OFFSET)])
    mem.reset()
    assert len(mem.known) == 2 and not mem.holding


def test_blue_sees_the_mirrored_memory() -> None:
    red = goal_slots(SPEC, GoalMemory(SPEC).observe(view(x=0.5, y=-0.2, heading_deg=30.0)))
    blue_view = view(x=-0.5, y=0.2, heading_deg=210.0, alliance="blue")
    blue = goal_slots(SPEC, GoalMemory(SPEC).observe(blue_view))
    np.testing.assert_allclose(red, blue, atol=1e-6)


def test_spec_checks_and_the_older_fingerprints() -> None:
    with pytest.raises(ObservationError, match="version 3"):
        ObservationSpec(version=2, goal_memory=True)
    with pytest.raises(ObservationError, match="prior_goals"):
        ObservationSpec(goal_memory=True, prior_goals=((0.0, float("nan")),))
    with pytest.raises(ObservationError, match="n_goals"):
        ObservationSpec(goal_memory=True, n_goals=-1)
    again = ObservationSpec.from_dict(json.loads(json.dumps(SPEC.to_dict())))
    assert again == SPEC and again.fingerprint() == SPEC.fingerprint()
    # A spec without the goal memory hashes as before it existed: the goal fields are left out.
    v2 = ObservationSpec(version=2, ring_memory=True, prior_rings=((0.0, 1.0),), n_stack=2)
    assert v2.fingerprint() == ObservationSpec(**{**v2.to_dict(), "n_goals": 5}).fingerprint()
    assert SPEC.fingerprint() != ObservationSpec(**{**SPEC.to_dict(), "n_goals": 2}).fingerprint()


def test_the_simulator_fills_the_layout_reports_the_clamp_and_rewards_it() -> None:
    pytest.importorskip("pybullet")
    from jetson.autonomy.geometry import heading_vector
    from sim.match import MatchCore, make_config
    from sim.world.state import DriveCommand

    cfg = make_config(
        world={"blue": []},
        observation={"goal_memory": True, "n_stack": 0},
        reward={"clamp": 2.0, "goal_approach": 1.0},
        obs_noise=False,
        gps_noise=False,
    )
    core = MatchCore(cfg)
    # Red's two goals and the three neutral ones; the 15 in robot's clamp offset.
    assert len(core.spec.prior_goals) == 5
    assert core.spec.goal_clamp_offset_m == pytest.approx(0.381 / 2 + 0.1651 + 0.005, abs=2e-3)
    core.reset(np.random.default_rng(0))
    # Put red's north goal 4 cm behind where the clamp holds one, then reverse onto it.
    w = core.world
    r = w.robots[0]
    back = np.array(w.clamp_point(r, w.goals[0])) - 0.04 * heading_vector(r.heading)
    w.place_goal(0, float(back[0]), float(back[1]))
    total = dict.fromkeys(("clamp", "goal_approach"), 0.0)
    clamped_obs = 0.0
    for _ in range(12):
        results, _, _ = core.step([DriveCommand(-0.2, 0.0, True, None)])
        for k in total:
            total[k] += results[0].components[k]
        clamped_obs = results[0].observation[6]
    assert r.carried_goal == 0
    assert total["clamp"] == 2.0, "the clamp bonus is paid once"
    assert total["goal_approach"] > 0, "backing onto the goal is shaped"
    assert clamped_obs == 1.0
    # The held goal left the memory; four remembered goals remain, in the slots nearest first.
    assert len(core.goal_memories[0].known) == 4
    core.close()


def test_goal_start_share_puts_the_robots_back_to_one_of_its_goals() -> None:
    pytest.importorskip("pybullet")
    from sim.errors import ConfigError
    from sim.match import MatchCore, make_config

    with pytest.raises(ConfigError, match="goal_start_share"):
        make_config(goal_start_share=1.5)
    core = MatchCore(make_config(goal_start_share=1.0, obs_noise=False, gps_noise=False))
    starts = []
    for seed in range(6):
        core.reset(np.random.default_rng(seed))
        w = core.world
        for r in w.robots:
            gaps = [
                np.hypot(r.x - g.x, r.y - g.y) - w.clamp_offset(r, g)
                for g in w.goals
                if g.spec.alliance == r.alliance
            ]
            starts.append((r.x, r.y))
            assert 0.049 <= min(gaps) <= 0.501, "5-50 cm further than where the clamp holds one"
    assert len({round(x, 3) for x, _ in starts}) > 6, "starts differ from match to match"
    core.close()


def test_midgame_start_share_starts_part_way_into_a_match() -> None:
    pytest.importorskip("pybullet")
    from sim.errors import ConfigError
    from sim.match import MatchCore, make_config
    from sim.world.state import RING_FLOOR, RING_HELD, DriveCommand

    with pytest.raises(ConfigError, match="midgame_start_share"):
        make_config(midgame_start_share=-0.1)
    fresh = MatchCore(make_config(obs_noise=False, gps_noise=False))
    fresh.reset(np.random.default_rng(0))
    full = int((fresh.world.ring_state == RING_FLOOR).sum())
    fresh.close()
    core = MatchCore(make_config(midgame_start_share=1.0, obs_noise=False, gps_noise=False))
    held_seen = []
    for seed in range(6):
        core.reset(np.random.default_rng(seed))
        w = core.world
        floor = int((w.ring_state == RING_FLOOR).sum())
        assert 0.4 * full - 1 <= floor <= 0.8 * full + 1, "20-60 % of the floor rings gone"
        for r in w.robots:
            mine = (w.ring_state == RING_HELD) & (w.ring_owner == r.index)
            assert r.held == r.collected == int(mine.sum()) <= r.config.ring_capacity
            held_seen.append(r.held)
            gaps = [
                np.hypot(r.x - g.x, r.y - g.y) - w.clamp_offset(r, g)
                for g in w.goals
                if g.spec.alliance == r.alliance
            ]
            assert 0.049 <= min(gaps) <= 0.501, "its back to one of its goals"
        results, _, _ = core.step([DriveCommand(0.0, 0.0) for _ in w.robots])
        assert all(x.components["rings"] == 0.0 for x in results), (
            "the rings it starts with pay nothing"
        )
    assert len(set(held_seen)) > 3, "intakes from empty to full"
    core.close()
