"""Observation spec version 6: the alliance partner in the observation, from its reports over
VEXlink (jetson.partner.PartnerInput) through the decision (jetson.decide), a skill policy's
claim, and the partner a recorded decision was given (replay)."""

from __future__ import annotations

import numpy as np
import pytest

from jetson.autonomy.observation import PartnerView, RobotView, build_frame
from jetson.autonomy.skills import SkillConfig
from jetson.autonomy.spec import PARTNER_NAMES, ObservationSpec, observation_bounds
from jetson.decide import Decider, PerceptionInput
from jetson.errors import ObservationError, SettingsError
from jetson.partner import PartnerInput
from jetson.recorder import CycleRecord, Recorder
from jetson.replay import recorded_partner
from jetson.settings import DecisionConfig
from jetson.testing import ProbePolicy
from protocol.messages import (
    Alliance,
    ClampAction,
    Command,
    GpsStatus,
    MatchPhase,
    Partner,
    PartnerFlags,
    PartnerLink,
    PartnerStatus,
    PoseFix,
    State,
    TargetKind,
)

SPEC = ObservationSpec(version=6, partner=True, n_stack=0, n_other_robots=1)
LO = SPEC.partner_offset
UNIT = SPEC.length_unit_m


def view(**kw) -> RobotView:
    base = dict(x=0.0, y=0.0, heading_deg=0.0, alliance="red", time_s=10.0)
    base.update(kw)
    return RobotView(**base)  # type: ignore[arg-type]


def state(t_ms: int = 0, **kw) -> State:
    base = dict(
        seq=t_ms // 20 + 1, time_ms=t_ms, phase=MatchPhase.AUTONOMOUS, phase_ms=t_ms,
        match_ms=t_ms, alliance=Alliance.RED, x=1.0, y=0.0, heading=90.0, gps_error=0.01,
        gps_status=GpsStatus.OK, pose_fix=PoseFix.GPS, pose_std=0.01, heading_std=0.5,
    )  # fmt: skip
    base.update(kw)
    return State(**base)


def report(match_ms: int = 0, **kw) -> Partner:
    base = dict(
        x_mm=2000, y_mm=0, heading_cdeg=0,
        flags=PartnerFlags.POSE_OK | PartnerFlags.HOLDING_GOAL | PartnerFlags.DRIVING,
        rings=4, target=TargetKind.GOAL, target_x_mm=1000, target_y_mm=-1000, match_ms=match_ms,
    )  # fmt: skip
    base.update(kw)
    return Partner(**base)


UP = PartnerStatus(link=PartnerLink.UP)


def test_the_block_sits_between_the_other_robots_and_the_goals() -> None:
    assert SPEC.frame_names()[LO : LO + 8] == list(PARTNER_NAMES)
    assert len(SPEC.scalars) + 3 == LO and SPEC.goal_offset == LO + 8
    assert SPEC.frame_size == ObservationSpec(version=6, n_stack=0, n_other_robots=1).frame_size + 8
    lines = SPEC.describe()
    assert "partner" in lines[LO] and "claimed" in lines[LO + 5]
    low, high = observation_bounds(SPEC)
    assert (low[LO + 2], high[LO + 2]) == (0.0, 1.0)  # partner_ok
    assert (low[LO + 3], high[LO + 3]) == (0.0, 1.0)  # partner_clamped
    assert (low[LO + 4], high[LO + 4]) == (0.0, 8.0)  # partner_held
    assert (low[LO + 7], high[LO + 7]) == (0.0, 1.0)  # claim_ok
    assert (low[LO], high[LO]) == (-4.0, 4.0)


def test_the_block_needs_version_6_and_older_fingerprints_stay() -> None:
    with pytest.raises(ObservationError, match="partner needs observation spec version 6"):
        ObservationSpec(version=5, partner=True)
    old = ObservationSpec(version=5, intake_flag=True)
    without_key = {k: v for k, v in old.to_dict().items() if k != "partner"}
    assert ObservationSpec.from_dict(without_key).fingerprint() == old.fingerprint()
    assert (
        SPEC.fingerprint() != ObservationSpec(version=6, n_stack=0, n_other_robots=1).fingerprint()
    )
    # The bounds of a spec without the block are as they were: every slot's ok in [0, 1].
    low, high = observation_bounds(old)
    names = old.frame_names()
    oks = [i for i, n in enumerate(names) if n.endswith("_ok")]
    assert oks == list(range(len(old.scalars) + 2, old.frame_size, 3))
    assert (low[oks] == 0).all() and (high[oks] == 1).all()


def test_build_frame_fills_the_block_and_leaves_it_empty_without_a_partner() -> None:
    p = PartnerView(xy=(0.5, 1.0), clamped=True, rings=4, claim_xy=(-1.0, 2.0))
    f = build_frame(SPEC, view(partner=p))
    block = f[LO : LO + 8]
    expect = [0.5 / UNIT, 1.0 / UNIT, 1.0, 1.0, 0.4, -1.0 / UNIT, 2.0 / UNIT, 1.0]
    assert np.allclose(block, expect)
    assert not build_frame(SPEC, view())[LO : LO + 8].any()
    unposed = build_frame(SPEC, view(partner=PartnerView(None, False, 2, None)))[LO : LO + 8]
    assert np.allclose(unposed, [0, 0, 0, 0, 0.2, 0, 0, 0])
    # Noise only with a generator: reported positions move by at most position_noise_m.
    noisy = build_frame(SPEC, view(partner=p), np.random.default_rng(0))[LO : LO + 8]
    moved = np.abs(noisy - block) * UNIT
    assert 0 < moved[[0, 1, 5, 6]].max() <= SPEC.position_noise_m + 1e-6
    assert np.array_equal(noisy[[2, 3, 4, 7]], block[[2, 3, 4, 7]])
    with pytest.raises(ObservationError, match="finite"):
        build_frame(SPEC, view(partner=PartnerView((np.nan, 0.0), False, 0, None)))


def test_a_report_is_read_only_while_the_link_is_up_and_turned_into_the_robot_frame() -> None:
    assert PartnerInput.of(report(), None, 0) is None
    assert PartnerInput.of(None, UP, 0) is None
    lost = PartnerStatus(link=PartnerLink.LOST, age_ms=100)
    assert PartnerInput.of(report(), lost, 0) is None
    got = PartnerInput.of(report(match_ms=1000), UP, 1250)
    assert got is not None and got.age_s == pytest.approx(0.25)
    # A report stamped after our clock: as old as the Brain says.
    ahead = PartnerInput.of(report(match_ms=2000), PartnerStatus(PartnerLink.UP, 80), 1000)
    assert ahead is not None and ahead.age_s == pytest.approx(0.08)
    # We stand at (1, 0) facing +x: the partner at (2, 0) is 1 m ahead, its claim at (1, -1) is
    # 1 m to our right.
    v = got.view(1.0, 0.0, 90.0)
    assert v.xy == pytest.approx((0.0, 1.0)) and v.claim_xy == pytest.approx((1.0, 0.0))
    assert v.clamped and v.rings == 4
    bare = PartnerInput(
        report(flags=PartnerFlags(0), rings=255, target=TargetKind.NOTHING), 0.0
    ).view(1.0, 0.0, 90.0)
    assert bare == PartnerView(None, False, 0, None)


def test_the_decision_reads_a_fresh_partner_and_plays_alone_without_one() -> None:
    policy = ProbePolicy(SPEC)
    policy.keep_observations = True
    d = Decider(policy, DecisionConfig(partner_max_age_s=0.5))
    d.decide(state(0), None, PartnerInput(report(), 0.1))
    d.decide(state(100), None, PartnerInput(report(), 0.6))  # too old: alone
    d.decide(state(200), None, None)  # the link down
    first, stale, alone = (o[LO : LO + 8] for o in policy.observations)
    assert first[2] == 1.0 and first[1] == pytest.approx(1.0 / UNIT, abs=1e-6)
    assert first[7] == 1.0 and first[5] == pytest.approx(1.0 / UNIT, abs=1e-6)
    assert not stale.any() and not alone.any()
    # A policy without the block never reads the partner: its observation is unchanged.
    plain = ProbePolicy(ObservationSpec(version=6, n_stack=0))
    plain.keep_observations = True
    a = Decider(plain)
    a.decide(state(0), None, PartnerInput(report(), 0.1))
    b_policy = ProbePolicy(ObservationSpec(version=6, n_stack=0))
    b_policy.keep_observations = True
    Decider(b_policy).decide(state(0), None, None)
    assert np.array_equal(plain.observations[0], b_policy.observations[0])


def test_a_skill_policy_claims_its_skills_target_in_the_field_frame() -> None:
    class SkillPolicy(ProbePolicy):
        action_names = ("ring0", "ring1", "platform")
        action_scale = (1.0, 1.0, 1.0)
        pick = 1

        def __call__(self, obs):
            a = np.full(3, -1.0, dtype=np.float32)
            a[self.pick] = 1.0
            return a

    policy = SkillPolicy(ObservationSpec(version=6, n_stack=0))
    policy.skills = SkillConfig(
        ring_options=2, goal_options=0, platform=True, platform_box=(0.0, -1.2, 0.6, 0.6)
    )
    d = Decider(policy)
    assert d.claim(state(0)).target == TargetKind.NOTHING  # before it drives
    # We stand at (1, 0) facing +x; the second-nearest ring is 1.2 m ahead and 0.5 m right.
    seen = PerceptionInput(1, 0.05, np.array([[0.0, 0.8], [0.5, 1.2]]))
    assert d.decide(state(0), seen).drove
    c = d.claim(state(0))
    assert c.target == TargetKind.RING and c.xy == pytest.approx((2.2, -0.5))
    policy.pick = 2
    d.decide(state(100), seen)
    c = d.claim(state(100))
    assert c.target == TargetKind.PLATFORM and c.xy == pytest.approx((0.0, -1.2), abs=1e-6)
    d.decide(state(200, phase=MatchPhase.DISABLED), seen)  # a stop claims nothing
    assert d.claim(state(200)).target == TargetKind.NOTHING


def test_a_skill_policy_dragged_by_its_goal_opens_the_clamp() -> None:
    """release_dragged_s through the decision: the Brain reports the clamp closed while the
    GPS carries the robot sideways as it drives ahead; the decision asks the clamp to open."""

    class RingPolicy(ProbePolicy):
        action_names = ("ring0", "goal0", "platform")
        action_scale = (1.0, 1.0, 1.0)

        def __call__(self, obs):
            return np.array([1.0, -1.0, -1.0], dtype=np.float32)

    policy = RingPolicy(ObservationSpec(version=6, n_stack=0, goal_memory=True))
    policy.skills = SkillConfig(ring_options=1, goal_options=1, release_dragged_s=1.0)
    d = Decider(policy)
    seen = PerceptionInput(1, 0.05, np.array([[0.0, 1.5]]))  # a ring ahead: drive at it
    clamps = []
    for k in range(30):  # 0.5 m/s sideways (+y; the robot faces +x) for 2.5 s, clamped
        s = state(1000 + 83 * k, y=0.04 * k, goal_clamped=1, match_ms=20000 + 83 * k)
        clamps.append(d.decide(s, seen).clamp)
    assert clamps[0] == ClampAction.LEAVE and clamps[-1] == ClampAction.RELEASE


def test_the_partner_a_decision_was_given_is_recorded_for_replay(tmp_path) -> None:
    given = PartnerInput(report(match_ms=900), 0.1)
    cmd = Command(seq=1, linear=0.1, angular=0.0, intake=True, valid_ms=250)
    rec = Recorder._cycle_dict(
        CycleRecord(1.0, state(1000), None, None, cmd, "policy", "-", 0, None, 1.0, 0.5, given)
    )
    assert recorded_partner(rec) == given
    alone = Recorder._cycle_dict(
        CycleRecord(1.0, state(1000), None, None, cmd, "policy", "-", 0, None, 1.0, 0.5)
    )
    assert "partner" not in alone and recorded_partner(alone) is None


def test_partner_max_age_is_checked() -> None:
    for bad in (0.0, -1.0, 6.0, True, "0.5"):
        with pytest.raises(SettingsError, match="partner_max_age_s"):
            DecisionConfig(partner_max_age_s=bad)  # type: ignore[arg-type]


def test_a_malformed_recorded_partner_is_a_replay_error() -> None:
    from jetson.errors import ReplayError

    with pytest.raises(ReplayError, match="partner report is malformed"):
        recorded_partner({"partner": {"x_mm": "far"}, "partner_age": 0.1})
    good = Recorder._cycle_dict(
        CycleRecord(
            1.0, state(1000), None, None, Command(seq=1), "policy", "-", 0, None, 1.0, 0.5,
            PartnerInput(report(), 0.1),
        )
    )  # fmt: skip
    del good["partner_age"]
    with pytest.raises(ReplayError, match="partner report is malformed"):
        recorded_partner(good)


def test_garbage_in_a_report_is_no_place_and_no_rings() -> None:
    far = PartnerInput(report(x_mm=30000, target_x_mm=-30000, rings=200), 0.0)
    v = far.view(1.0, 0.0, 90.0)
    assert v.xy is None and v.claim_xy is None and v.rings == 0 and v.clamped
    # Clocks that stand still (no field control) still age a report by what the Brain says.
    still = PartnerInput.of(report(match_ms=0), PartnerStatus(PartnerLink.UP, 700), 0)
    assert still is not None and still.age_s == pytest.approx(0.7)
    # A sender whose pose is not a number says it has none.
    from jetson.partner import partner_report

    sent = partner_report(state(0, x=float("nan")), True, PartnerLink.UP)
    assert PartnerFlags.POSE_OK not in sent.flags
