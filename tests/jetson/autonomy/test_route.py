"""The tour over known rings (jetson/autonomy/route.py) and the observation's route slots built
from it."""

from __future__ import annotations

import json
from dataclasses import replace

import numpy as np
import pytest

from jetson.autonomy.observation import RobotView, build_frame
from jetson.autonomy.ring_memory import RingMemory
from jetson.autonomy.route import TourConfig, leg_costs, tour
from jetson.autonomy.spec import REMEMBERED, SEEN, ObservationSpec
from jetson.errors import ObservationError


def test_a_turn_costs_distance() -> None:
    pts = np.array([(0.0, 1.0), (0.0, -1.0)])
    cost = leg_costs((0.0, 0.0), 0.0, pts, 0.15)
    np.testing.assert_allclose(cost, [1.0, 1.0 + 0.15 * np.pi])


def test_the_tour_takes_a_row_in_order_before_a_ring_off_to_the_side() -> None:
    # Robot at the origin facing +y: a row straight ahead and one ring to the right that is
    # nearer than the row's second ring but off the way.
    pts = np.array([(0.0, 2.0), (0.0, 1.0), (0.9, 0.3), (0.0, 3.0)])
    order = tour((0.0, 0.0), 0.0, pts, stops=3)
    assert order == [1, 0, 3]
    assert tour((0.0, 0.0), 0.0, pts, stops=1) == [1]
    assert tour((0.0, 0.0), 0.0, np.zeros((0, 2)), stops=3) == []
    # Facing the lone ring, the tour starts there and takes the row after it.
    assert tour((0.0, 0.0), 70.0, pts, stops=1) == [2]
    assert tour((0.0, 0.0), 70.0, pts, stops=3) == [2, 1, 0]


def test_the_current_target_is_kept_unless_another_tour_is_clearly_cheaper() -> None:
    # Two rings at nearly the same cost, left and right.
    pts = np.array([(-0.5, 1.0), (0.52, 1.0)])
    assert tour((0.0, 0.0), 0.0, pts, stops=1)[0] == 0
    assert tour((0.0, 0.0), 0.0, pts, stops=1, current=1)[0] == 1
    strict = TourConfig(switch_margin_m=0.0)
    assert tour((0.0, 0.0), 0.0, pts, stops=1, config=strict, current=1)[0] == 0
    with pytest.raises(ValueError, match="candidates"):
        TourConfig(candidates=0)


def route_spec(**kw: object) -> ObservationSpec:
    # Ring B to the robot's left is the nearest; A and C lie ahead in a row.
    prior = ((0.0, 0.8), (-0.75, 0.0), (0.0, 1.6))
    base: dict[str, object] = dict(ring_memory=True, prior_rings=prior, n_stack=0, route_slots=2)
    base.update(kw)
    return ObservationSpec(**base)  # type: ignore[arg-type]


def test_route_slots_hold_the_tour_in_order_and_ring_slots_stay_nearest_first() -> None:
    # Two rings of room: a two-stop tour, A then C (from B it would cost a turn and a detour).
    spec = route_spec()
    mem = RingMemory(spec)
    view = RobotView(
        x=0.0,
        y=0.0,
        heading_deg=0.0,
        alliance="red",
        time_s=5.0,
        rings_robot_xy=np.array([(0.0, 0.8), (0.0, 1.6)]),
        rings_held=8,
    )
    frame = build_frame(spec, mem.observe(view))
    u = spec.length_unit_m
    route = frame[spec.route_offset : spec.ring_offset].reshape(2, 3)
    np.testing.assert_allclose(route, [[0.0, 0.8 / u, 1.0], [0.0, 1.6 / u, 1.0]], rtol=1e-6)
    rings = frame[spec.ring_offset :].reshape(spec.n_rings, 3)
    np.testing.assert_allclose(rings[0], [-0.75 / u, 0.0, REMEMBERED], rtol=1e-6)
    assert rings[1, 2] == SEEN and rings[3, 2] == 0.0
    np.testing.assert_allclose(mem.target, (0.0, 0.8))
    # A blue robot in the mirrored place sees the same route.
    blue = RingMemory(spec).observe(replace(view, heading_deg=180.0, alliance="blue"))
    np.testing.assert_allclose(build_frame(spec, blue), frame, atol=1e-6)
    mem.reset()
    assert mem.target is None


def test_a_full_intake_plans_one_stop_and_an_empty_memory_leaves_the_slots_empty() -> None:
    spec = route_spec(prior_rings=((0.0, -0.7), (0.5, -0.7)))
    mem = RingMemory(spec)
    view = RobotView(x=0.0, y=0.0, heading_deg=0.0, alliance="red", time_s=5.0, rings_held=10)
    out = mem.recall(view)
    assert len(out.route_robot_xy) == 1
    mem.known = np.zeros((0, 2))
    frame = build_frame(spec, mem.recall(view))
    assert not frame[spec.route_offset : spec.ring_offset].any()


def test_route_spec_checks_and_fingerprints() -> None:
    with pytest.raises(ObservationError, match="version 4"):
        ObservationSpec(version=3, ring_memory=True, route_slots=2)
    with pytest.raises(ObservationError, match="ring_memory"):
        ObservationSpec(route_slots=2)
    with pytest.raises(ObservationError, match="route_candidates"):
        route_spec(route_candidates=0)
    spec = route_spec()
    again = ObservationSpec.from_dict(json.loads(json.dumps(spec.to_dict())))
    assert again == spec and again.fingerprint() == spec.fingerprint()
    assert route_spec(route_turn_cost_m_per_rad=0.3).fingerprint() != spec.fingerprint()
    plain = route_spec(route_slots=0)
    assert plain.fingerprint() == route_spec(route_slots=0, route_candidates=3).fingerprint()
    assert spec.frame_size == plain.frame_size + 6
    names = spec.frame_names()
    assert names[spec.route_offset : spec.ring_offset] == [
        "route0_x",
        "route0_y",
        "route0_ok",
        "route1_x",
        "route1_y",
        "route1_ok",
    ]
