"""Observation spec version 6's goal_sight: the goal memory corrected by the goals the camera
sees (moved to where they are seen, joined by goals seen where none was remembered, forgotten
where the camera should see them and does not), on the Jetson from the goal detector's fresh
results and in the twin from sim.goal_sight."""

from __future__ import annotations

import numpy as np
import pytest

from jetson.autonomy.goal_colours import GOAL_COLOUR_CODES
from jetson.autonomy.goal_memory import GoalMemory
from jetson.autonomy.observation import RobotView
from jetson.autonomy.spec import ObservationSpec
from jetson.errors import ObservationError

YELLOW, RED, BLUE = (GOAL_COLOUR_CODES[c] for c in ("yellow", "red", "blue"))
PRIOR = ((0.0, 1.0), (1.5, 0.0), (-1.0, -1.0))  # alliance frame
SIGHT = ObservationSpec(
    version=6, goal_memory=True, goal_sight=True, prior_goals=PRIOR, goal_clamp_offset_m=0.35,
    n_stack=0,
)  # fmt: skip


def view(seen: list[tuple[float, float, int]] | None, alliance: str = "red") -> RobotView:
    """The robot at the field's centre facing +y (red's alliance frame is the field's)."""
    goals = None if seen is None else np.array(seen, dtype=np.float64).reshape(-1, 3)
    return RobotView(
        x=0.0, y=0.0, heading_deg=0.0, alliance=alliance, time_s=1.0, goals_seen_robot=goals
    )


def remembered(memory: GoalMemory) -> list[tuple[float, float]]:
    return sorted((round(float(x), 2), round(float(y), 2)) for x, y in memory.known)


def test_a_seen_goal_moves_its_memory_and_an_unseen_one_in_reach_is_forgotten() -> None:
    m = GoalMemory(SIGHT)
    # The goal ahead at (0, 1) is seen 20 cm to its right; nothing else in reach.
    m.observe(view([(0.2, 1.0, YELLOW)]))
    assert remembered(m) == [(-1.0, -1.0), (0.2, 1.0), (1.5, 0.0)]
    m.observe(view([]))  # a fresh result with no goal: the one ahead is gone
    assert remembered(m) == [(-1.0, -1.0), (1.5, 0.0)]  # out of reach: kept


def test_a_goal_seen_where_none_was_remembered_joins_and_other_colours_are_ignored() -> None:
    m = GoalMemory(SIGHT)
    m.observe(view([(0.2, 1.0, YELLOW), (-0.6, 1.2, RED), (0.6, 1.2, BLUE)]))
    assert (-0.6, 1.2) in remembered(m) and (0.6, 1.2) not in remembered(m)  # red's: ours
    blue = GoalMemory(SIGHT)  # as blue, the red goal is the other alliance's
    blue.observe(view([(-0.6, 1.2, RED)], alliance="blue"))
    assert len(blue.known) == len(PRIOR) and (0.0, 1.0) in remembered(blue)  # nothing moved:
    # the blue robot at the centre faces -y in its frame, so the goal at (0, 1) is behind it


def test_no_fresh_result_leaves_the_dead_reckoning_and_old_specs_ignore_sightings() -> None:
    m = GoalMemory(SIGHT)
    m.observe(view(None))
    assert remembered(m) == sorted(PRIOR)
    plain = GoalMemory(ObservationSpec(version=6, goal_memory=True, prior_goals=PRIOR))
    plain.observe(view([]))
    assert remembered(plain) == sorted(PRIOR)


def test_goal_sight_needs_version_6_and_the_goal_memory() -> None:
    with pytest.raises(ObservationError, match="goal_sight needs"):
        ObservationSpec(version=6, goal_sight=True)
    with pytest.raises(ObservationError, match="goal_sight needs"):
        ObservationSpec(version=5, goal_memory=True, goal_sight=True)
    with pytest.raises(ObservationError, match="goal sight"):
        ObservationSpec(version=6, goal_memory=True, goal_sight=True, goal_sight_far_m=0.1)
    plain = ObservationSpec(version=6, goal_memory=True)
    assert ObservationSpec(version=6, goal_memory=True, goal_sight=True).fingerprint() != (
        plain.fingerprint()
    )
    # Its settings hash only with it on: a spec without it keeps its fingerprint.
    tuned = ObservationSpec(version=6, goal_memory=True, goal_sight_far_m=1.5)
    assert tuned.fingerprint() == plain.fingerprint()


def test_the_twin_corrects_its_goal_memory_by_what_its_camera_sees() -> None:
    """MatchCore: a goal moved off its starting place is seen where it is and the memory
    follows (the fast backend's batched memory: tests/sim/fast/test_memory.py)."""
    from sim.config import world_preset
    from sim.fast.observe import unsupported_spec
    from sim.match import MatchCore, make_config
    from sim.world.state import DriveCommand

    obs = {"version": 6, "goal_memory": True, "goal_sight": True, "match_length_s": 120.0}
    env = make_config({"world": world_preset("tipping_point_1v1"), "observation": obs})
    core = MatchCore(env)
    try:
        core.reset(np.random.default_rng(0))
        w = core.world
        r = w.robots[0]
        # The neutral goal nearest red's robot, pushed 0.5 m from where the memory has it; the
        # robot 1 m before its new place, facing it (+x), the old place in view too.
        memory = core.goal_memories[0]
        g = min(
            (g for g in w.goals if g.spec.alliance is None),
            key=lambda g: np.hypot(g.x - r.x, g.y - r.y),
        )
        old = (g.x, g.y)
        assert any(np.hypot(k[0] - old[0], k[1] - old[1]) < 0.05 for k in memory.known)
        w.place_goal(g.index, g.x, g.y + 0.5)
        new = (g.x, g.y)
        w.place_robot(0, new[0] - 1.0, new[1], 90.0)
        for _ in range(3):  # the GPS's latency: its reading catches up with the new place
            core.step([DriveCommand(), DriveCommand()])
        core.frame(0)
        near = [float(np.hypot(k[0] - new[0], k[1] - new[1])) for k in memory.known]
        assert min(near) < 0.1  # where the camera sees it (training fidelity: exact)
        assert not any(np.hypot(k[0] - old[0], k[1] - old[1]) < 0.3 for k in memory.known)
    finally:
        core.close()
    assert unsupported_spec(core.spec) == []  # the fast backend batches it too


def test_the_decision_corrects_the_memory_from_fresh_camera_results_only() -> None:
    from jetson.decide import Decider, PerceptionInput
    from jetson.testing import ProbePolicy
    from protocol.messages import Alliance, GpsStatus, MatchPhase, PoseFix, State

    def state(t_ms: int) -> State:
        return State(
            seq=t_ms // 20 + 1, time_ms=t_ms, phase=MatchPhase.AUTONOMOUS, phase_ms=t_ms,
            alliance=Alliance.RED, x=0.0, y=0.0, heading=0.0, gps_error=0.01,
            gps_status=GpsStatus.OK, pose_fix=PoseFix.GPS, pose_std=0.01, heading_std=0.5,
        )  # fmt: skip

    d = Decider(ProbePolicy(SIGHT))
    goals = np.array([[0.2, 1.0, YELLOW]])
    stale = PerceptionInput(1, 1.0, np.zeros((0, 2)), goals_robot=np.zeros((0, 3)))
    d.decide(state(0), stale)  # an old result: no correction, the prior stands
    assert remembered(d.goal_memory) == sorted(PRIOR)
    d.decide(state(100), PerceptionInput(2, 0.05, np.zeros((0, 2)), goals_robot=goals))
    assert (0.2, 1.0) in remembered(d.goal_memory) and (0.0, 1.0) not in remembered(d.goal_memory)


def test_a_policy_that_reads_goals_turns_the_goal_detector_on() -> None:
    from jetson.decide import Decider
    from jetson.service import policy_reads_goals
    from jetson.settings import Settings
    from jetson.testing import ProbePolicy

    plain = Settings()
    assert plain.decision.player == "policy" and not plain.detects_goals()
    assert policy_reads_goals(Decider(ProbePolicy(SIGHT)))
    assert plain.detects_goals(policy_reads_goals=True)
    off = Settings.from_dict({"camera": {"goals": False}})
    assert not off.detects_goals(policy_reads_goals=True)  # [camera] goals says so
    assert not policy_reads_goals(Decider(ProbePolicy(ObservationSpec(version=6))))
