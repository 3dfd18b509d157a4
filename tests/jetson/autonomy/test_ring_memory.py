"""The ring memory (observation spec version 2): what the robot knows beyond the camera's cone."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from jetson.autonomy.camera import MemoryCamera
from jetson.autonomy.observation import RobotView, build_frame
from jetson.autonomy.ring_memory import RingMemory
from jetson.autonomy.spec import REMEMBERED, SEEN, ObservationSpec
from jetson.errors import ObservationError

# Three prior rings for a red robot at the origin facing +y (heading 0): one straight ahead in
# view, one behind, one far to the right outside the cone.
PRIOR = ((0.0, 1.0), (0.0, -1.0), (1.5, 0.2))
SPEC = ObservationSpec(ring_memory=True, prior_rings=PRIOR, n_stack=0)


def view(rings: list[tuple[float, float]] | None = None, **kw) -> RobotView:
    base = dict(x=0.0, y=0.0, heading_deg=0.0, alliance="red", time_s=5.0)
    base.update(kw)
    xy = np.array(rings, dtype=np.float64).reshape(-1, 2) if rings else np.zeros((0, 2))
    return RobotView(rings_robot_xy=xy, **base)  # type: ignore[arg-type]


def slots(spec: ObservationSpec, v: RobotView) -> np.ndarray:
    frame = build_frame(spec, v)
    return frame[spec.ring_offset :].reshape(spec.n_rings, 3)


def test_a_prior_ring_in_view_but_not_seen_is_forgotten_the_others_remembered() -> None:
    mem = RingMemory(SPEC)
    out = mem.observe(view())
    np.testing.assert_allclose(mem.known, [(0.0, -1.0), (1.5, 0.2)])
    s = slots(SPEC, out)
    # Nearest first, both remembered (ok 0.5), in the robot frame / length unit.
    np.testing.assert_allclose(s[0], [0.0, -1.0 / SPEC.length_unit_m, REMEMBERED], rtol=1e-6)
    assert s[1, 2] == REMEMBERED and s[2, 2] == 0.0


def test_a_seen_ring_replaces_its_remembered_place_and_is_flagged_seen() -> None:
    mem = RingMemory(SPEC)
    out = mem.observe(view([(0.05, 1.02)]))
    assert len(mem.known) == 3, "the sighting moved the prior ring, it did not add one"
    s = slots(SPEC, out)
    seen = s[s[:, 2] == SEEN]
    np.testing.assert_allclose(seen[0, :2] * SPEC.length_unit_m, [0.05, 1.02], rtol=1e-6)
    assert (s[:, 2] == REMEMBERED).sum() == 2


def test_a_new_ring_is_added_and_a_ring_under_the_robot_is_forgotten() -> None:
    mem = RingMemory(SPEC)
    mem.observe(view([(0.0, 1.0), (-0.8, 1.6)]))
    assert len(mem.known) == 4
    mem.observe(view([(-0.8, 0.6)], y=1.0))  # drove onto the first ring
    assert not np.any(np.linalg.norm(mem.known - (0.0, 1.0), axis=1) < 0.1)


def test_recall_changes_nothing_and_reset_brings_back_the_layout() -> None:
    mem = RingMemory(SPEC)
    out = mem.recall(view())
    assert len(out.rings_remembered_xy) == 3 and len(mem.known) == 3
    mem.observe(view())
    assert len(mem.known) == 2
    mem.reset()
    assert len(mem.known) == 3


def test_blue_sees_the_mirrored_memory() -> None:
    red = RingMemory(SPEC).observe(view(x=0.3, y=-0.2, heading_deg=30.0))
    blue = RingMemory(SPEC).observe(view(x=-0.3, y=0.2, heading_deg=210.0, alliance="blue"))
    np.testing.assert_allclose(build_frame(SPEC, red), build_frame(SPEC, blue), atol=1e-6)


def test_without_ring_memory_nothing_changes() -> None:
    spec = ObservationSpec(n_stack=0)
    v = view([(0.0, 1.0)])
    assert RingMemory(spec).observe(v) is v


def test_spec_checks_and_json_round_trip() -> None:
    with pytest.raises(ObservationError, match="version 2"):
        ObservationSpec(version=1, ring_memory=True)
    with pytest.raises(ObservationError, match="prior_rings"):
        ObservationSpec(prior_rings=((0.0,),))  # type: ignore[arg-type]
    with pytest.raises(ObservationError, match="memory_fov_deg"):
        ObservationSpec(memory_fov_deg=0.0)
    again = ObservationSpec.from_dict(json.loads(json.dumps(SPEC.to_dict())))
    assert again == SPEC and again.fingerprint() == SPEC.fingerprint()
    moved = ObservationSpec(ring_memory=True, prior_rings=PRIOR[:2], n_stack=0)
    assert moved.fingerprint() != SPEC.fingerprint(), "the prior is part of the meaning"


def test_a_version_1_spec_keeps_its_fingerprint() -> None:
    # The shipped policy's spec, as written in its policy.json before version 2 existed.
    v1 = ObservationSpec(version=1, n_stack=2)
    assert (
        v1.fingerprint()
        == ObservationSpec.from_dict(
            {
                k: v
                for k, v in v1.to_dict().items()
                if not k.startswith(("memory", "ring_m", "prior"))
            }
        ).fingerprint()
    )
    assert ObservationSpec(version=1, n_stack=2, memory_far_m=2.0).fingerprint() == (
        v1.fingerprint()
    )


def test_the_simulator_fills_the_prior_from_the_field_and_feeds_the_memory() -> None:
    pytest.importorskip("pybullet")
    from sim.match import MatchCore, make_config

    cfg = make_config(
        world={"blue": []}, observation={"ring_memory": True}, obs_noise=False, gps_noise=False
    )
    core = MatchCore(cfg)
    assert len(core.spec.prior_rings) == 42
    obs = core.reset(np.random.default_rng(0))[0]
    s = obs[core.spec.ring_offset : core.spec.frame_size].reshape(core.spec.n_rings, 3)
    assert set(s[:, 2].tolist()) <= {SEEN, REMEMBERED} and (s[:, 2] == REMEMBERED).any()
    assert len(core.memories[0].known) <= 42
    core.close()


# The intake's reach of a 15-inch robot, as the simulator fills it (robot frame, metres).
ZONE = (-0.11, 0.11, 0.14, 0.32)


def test_forgetting_by_the_intake_keeps_a_ring_the_robot_passes_beside() -> None:
    # Both rings lie within memory_forget_m (0.25 m) of the robot's centre and below the view
    # cone: one beside the bumper, one in the intake's reach.
    prior = ((0.2, 0.0), (0.0, 0.25), (0.0, -1.0))
    near_rule = ObservationSpec(ring_memory=True, prior_rings=prior, n_stack=0)
    mem = RingMemory(near_rule)
    mem.observe(view())
    np.testing.assert_allclose(mem.known, [(0.0, -1.0)])

    intake_rule = replace(near_rule, memory_forget_intake=True, memory_intake_zone=ZONE)
    mem = RingMemory(intake_rule)
    mem.observe(view())
    np.testing.assert_allclose(mem.known, [(0.2, 0.0), (0.0, -1.0)])
    # Turned round and driven to the third ring: the intake reaches it, so it is gone; the
    # one beside the start, now behind, is still known.
    mem.observe(view(y=-0.75, heading_deg=180.0))
    np.testing.assert_allclose(mem.known, [(0.2, 0.0)])


def test_the_intake_rule_checks_its_zone_and_keeps_older_fingerprints() -> None:
    with pytest.raises(ObservationError, match="memory_intake_zone"):
        ObservationSpec(memory_intake_zone=(0.1, -0.1, 0.1, 0.3))
    with pytest.raises(ObservationError, match="memory_intake_zone"):
        ObservationSpec(memory_intake_zone=(0.1, 0.2))
    spec = replace(SPEC, memory_forget_intake=True, memory_intake_zone=ZONE)
    again = ObservationSpec.from_dict(json.loads(json.dumps(spec.to_dict())))
    assert again == spec and again.fingerprint() == spec.fingerprint()
    assert spec.fingerprint() != SPEC.fingerprint(), "the rule changes what a slot means"
    wider = replace(spec, memory_intake_zone=(-0.2, 0.2, 0.14, 0.32))
    assert wider.fingerprint() != spec.fingerprint()
    # A policy.json written before the rule existed has neither key and keeps its fingerprint.
    old = {
        k: v
        for k, v in SPEC.to_dict().items()
        if k not in ("memory_forget_intake", "memory_intake_zone")
    }
    assert ObservationSpec.from_dict(old).fingerprint() == SPEC.fingerprint()
    assert replace(spec, memory_forget_intake=False, memory_intake_zone=()) == SPEC
    with pytest.raises(ObservationError, match="memory_intake_zone"):
        RingMemory(replace(SPEC, memory_forget_intake=True))


def test_the_simulator_fills_the_intake_zone_from_the_robot() -> None:
    pytest.importorskip("pybullet")
    from sim.match import MatchCore, make_config

    observation = {"ring_memory": True, "memory_forget_intake": True}
    cfg = make_config(world={"blue": []}, observation=observation, obs_noise=False)
    core = MatchCore(cfg)
    core.reset(np.random.default_rng(0))
    (x0, x1), (y0, y1) = core.world.intake_rect(core.world.robots[0])
    np.testing.assert_allclose(core.spec.memory_intake_zone, (x0, x1, y0, y1), atol=1e-4)
    assert not core.spec.needs_prior
    assert replace(core.spec, memory_intake_zone=()).needs_prior
    core.close()


def test_rings_seen_from_an_older_pose_are_placed_from_it() -> None:
    # The frame was taken facing +y (heading 0); the robot has turned 30 degrees right since.
    # The frame shows prior ring A (0, 1) straight ahead. Prior ring C (1.5, 0.2) is now 56
    # degrees off the nose, out of the cone either way; D (0.9, 1.2) is 37 degrees right of
    # the old nose (out of the frame's 50-degree cone) but 7 degrees right of the new one.
    spec = replace(SPEC, prior_rings=((0.0, 1.0), (1.5, 0.2), (0.9, 1.2)))
    turned = view([(0.0, 1.0)], heading_deg=30.0)

    mem = RingMemory(spec)
    out = mem.observe(turned, seen_from=(0.0, 0.0, 0.0))
    assert len(mem.known) == 3, "A confirmed in place, D not looked at by that frame"
    h = np.radians(30.0)
    np.testing.assert_allclose(out.rings_robot_xy, [[-np.sin(h), np.cos(h)]], atol=1e-9)

    naive = RingMemory(spec)
    naive.observe(turned)  # the same frame placed from the newest pose: A's ghost, D lost
    assert np.any(np.linalg.norm(naive.known - (np.sin(h), np.cos(h)), axis=1) < 1e-9)
    assert not np.any(np.linalg.norm(naive.known - (0.9, 1.2), axis=1) < 0.1)


def test_a_frame_from_the_current_pose_changes_nothing() -> None:
    a, b = RingMemory(SPEC), RingMemory(SPEC)
    v = view([(0.05, 1.02), (-0.8, 1.6)], x=0.2, heading_deg=10.0)
    out_a = a.observe(v)
    out_b = b.observe(v, seen_from=(0.2, 0.0, 10.0))
    np.testing.assert_allclose(a.known, b.known)
    np.testing.assert_allclose(out_a.rings_robot_xy, out_b.rings_robot_xy, atol=1e-12)


def test_without_ring_memory_an_older_frames_rings_are_only_moved_into_the_new_pose() -> None:
    spec = ObservationSpec(n_stack=0)
    out = RingMemory(spec).observe(view([(0.0, 1.0)], heading_deg=30.0), seen_from=(0, 0, 0))
    h = np.radians(30.0)
    np.testing.assert_allclose(out.rings_robot_xy, [[-np.sin(h), np.cos(h)]], atol=1e-9)


def _sim_camera() -> tuple[object, MemoryCamera]:
    from sim.config import CameraConfig
    from sim.match import memory_camera

    cam = CameraConfig()
    return cam, memory_camera(cam, 0.0127)


def test_the_memory_camera_sees_what_the_simulated_camera_sees() -> None:
    # The memory's picture test is the Jetson-side copy of sim.visibility's: for floor rings
    # all around a robot at the origin they must agree (range aside, which the memory sets).
    from sim.visibility import camera_pose, in_frustum

    cam, mc = _sim_camera()
    rng = np.random.default_rng(0)
    xy = rng.uniform(-3.0, 3.0, (4000, 2))
    pts = np.column_stack([xy, np.full(len(xy), 0.0127)])
    truth, _, pc = in_frustum(pts, camera_pose((0.0, 0.0), 0.0, cam), cam)
    near_enough = np.linalg.norm(pc, axis=1) <= cam.max_range_m
    inside, dist = mc.locate(xy)
    np.testing.assert_array_equal(inside & near_enough, truth)
    np.testing.assert_allclose(dist, np.linalg.norm(pc, axis=1), atol=1e-9)
    assert 100 < truth.sum() < 3000  # the test covers both answers


def test_a_camera_view_memory_keeps_rings_the_picture_does_not_show() -> None:
    # The camera 0.3 m up, tilted 30 deg down, shows the floor to about 2.1 m ahead: a ring
    # 2.4 m ahead is inside the cone (so the cone memory forgets it, unseen) but above the
    # picture (so the camera memory keeps it). A ring 1.2 m ahead, unseen, is gone for both.
    _, mc = _sim_camera()
    prior = ((0.0, 1.2), (0.0, 2.4))
    cone = replace(SPEC, prior_rings=prior)
    camera = replace(cone, memory_view="camera")
    a, b = RingMemory(cone), RingMemory(camera, mc)
    a.observe(view())
    b.observe(view())
    assert len(a.known) == 0
    np.testing.assert_allclose(b.known, [(0.0, 2.4)])
    # Seen, a ring is taken in the same way by both.
    b.observe(view([(0.3, 1.0)]))
    assert len(b.known) == 2


def test_a_camera_view_memory_needs_the_camera_and_names_the_spec_setting() -> None:
    camera = replace(SPEC, memory_view="camera")
    with pytest.raises(ObservationError, match="memory_view"):
        RingMemory(camera)
    with pytest.raises(ObservationError, match="memory_view"):
        replace(SPEC, memory_view="sideways")
    # Specs saved before the setting existed keep their fingerprint; the camera view has its own.
    assert replace(SPEC, memory_view="cone").fingerprint() == SPEC.fingerprint()
    assert camera.fingerprint() != SPEC.fingerprint()
    assert ObservationSpec.from_dict(camera.to_dict()) == camera


# A 15-inch robot's body grown by a ring's radius (half width, half length), as the simulator
# fills it.
BODY = (0.2413, 0.2413)


def test_a_ring_the_body_drives_over_is_shoved_to_its_side_and_one_the_intake_reaches_is_gone():
    # A ring under the robot's left flank, one in the intake's reach, one far behind.
    prior = ((-0.15, 0.05), (0.0, 0.25), (0.0, -1.0))
    spec = ObservationSpec(
        ring_memory=True, prior_rings=prior, n_stack=0, memory_forget_intake=True,
        memory_intake_zone=ZONE, memory_push=True, memory_body=BODY,
    )  # fmt: skip
    mem = RingMemory(spec)
    mem.observe(view())
    # Out across the nearer side (the left, 0.09 m away, not the front, 0.19 m): the ring
    # keeps its y and lies against the body's left edge.
    np.testing.assert_allclose(mem.known, [(-0.2413, 0.05), (0.0, -1.0)], atol=1e-9)
    # Without the push the same ring stays under the robot, where nothing will find it.
    still = RingMemory(replace(spec, memory_push=False, memory_body=()))
    still.observe(view())
    np.testing.assert_allclose(still.known, [(-0.15, 0.05), (0.0, -1.0)], atol=1e-9)
    # The robot slides 0.1 m further left: the ring is under its flank again and goes out
    # ahead of it, 0.1 m further.
    mem.observe(view(x=-0.1))
    np.testing.assert_allclose(mem.known, [(-0.3413, 0.05), (0.0, -1.0)], atol=1e-9)


def test_the_push_rule_needs_the_intake_rule_and_its_body_and_keeps_older_fingerprints() -> None:
    intake = replace(SPEC, memory_forget_intake=True, memory_intake_zone=ZONE)
    with pytest.raises(ObservationError, match="memory_forget_intake"):
        replace(SPEC, memory_push=True, memory_body=BODY)
    with pytest.raises(ObservationError, match="memory_body"):
        replace(intake, memory_push=True, memory_body=(0.2, -0.1))
    with pytest.raises(ObservationError, match="memory_body"):
        RingMemory(replace(intake, memory_push=True))
    assert replace(intake, memory_push=True).needs_prior
    spec = replace(intake, memory_push=True, memory_body=BODY)
    again = ObservationSpec.from_dict(json.loads(json.dumps(spec.to_dict())))
    assert again == spec and again.fingerprint() == spec.fingerprint()
    assert spec.fingerprint() != intake.fingerprint(), "the rule changes what a slot means"
    old = {k: v for k, v in intake.to_dict().items() if k not in ("memory_push", "memory_body")}
    assert ObservationSpec.from_dict(old).fingerprint() == intake.fingerprint()


def test_the_simulator_fills_the_body_from_the_robot() -> None:
    pytest.importorskip("pybullet")
    from sim.match import MatchCore, make_config

    observation = {"ring_memory": True, "memory_forget_intake": True, "memory_push": True}
    cfg = make_config(world={"blue": []}, observation=observation, obs_noise=False)
    core = MatchCore(cfg)
    core.reset(np.random.default_rng(0))
    rc, rad = core.world.robots[0].config, core.world.field.ring.radius
    np.testing.assert_allclose(
        core.spec.memory_body, (rc.width_m / 2 + rad, rc.length_m / 2 + rad), atol=1e-4
    )
    assert not core.spec.needs_prior
    core.close()
