"""The policy's input: layout, normalisation, symmetry, noise, stacking, versioning."""

from __future__ import annotations

import json
import subprocess
import sys

import numpy as np
import pytest

from jetson.autonomy.observation import FrameStack, RobotView, build_frame
from jetson.autonomy.spec import ObservationSpec, observation_bounds
from jetson.errors import ObservationError

SPEC = ObservationSpec()
UNIT = SPEC.length_unit_m


def view(**kw) -> RobotView:
    base = dict(x=0.5, y=-1.0, heading_deg=90.0, alliance="red", time_s=21.0)
    base.update(kw)
    return RobotView(**base)  # type: ignore[arg-type]


def test_default_layout_sizes() -> None:
    assert SPEC.frame_size == 6 + 3 * 10
    assert SPEC.n_frames == 11
    assert SPEC.size == 36 * 11
    assert len(SPEC.describe()) == SPEC.size
    assert SPEC.describe()[0].startswith("   0  [now] time")
    assert "[t-10]" in SPEC.describe()[-1]


def test_scalars_are_normalised() -> None:
    f = build_frame(SPEC, view(rings_held=4))
    assert f.dtype == np.float32
    assert f[0] == pytest.approx(21.0 / 105.0)
    assert f[1] == pytest.approx(0.5 / UNIT) and f[2] == pytest.approx(-1.0 / UNIT)
    # Heading 90 (facing +x): cos 0, sin 1.
    assert f[3] == pytest.approx(0.0, abs=1e-7) and f[4] == pytest.approx(1.0)
    assert f[5] == pytest.approx(0.4)
    assert build_frame(SPEC, view(time_s=500.0))[0] == 1.0


def test_rings_sorted_nearest_first_with_valid_flags_and_no_padding_noise() -> None:
    rings = np.array([[0.0, 2.0], [0.1, 0.5], [-1.0, 1.0]])
    rng = np.random.default_rng(0)
    f = build_frame(SPEC, view(rings_robot_xy=rings))
    slots = f[SPEC.ring_offset :].reshape(10, 3)
    assert np.allclose(slots[0], [0.1 / UNIT, 0.5 / UNIT, 1.0])
    assert np.allclose(slots[1], [-1.0 / UNIT, 1.0 / UNIT, 1.0])
    assert np.allclose(slots[2], [0.0, 2.0 / UNIT, 1.0])
    assert np.all(slots[3:] == 0.0)
    noisy = build_frame(SPEC, view(rings_robot_xy=rings), rng)
    nslots = noisy[SPEC.ring_offset :].reshape(10, 3)
    assert np.all(nslots[3:] == 0.0), "empty slots must never get noise"
    assert np.all(nslots[:3, 2] == 1.0), "flags must never get noise"
    nonzero = slots[:3, :2] != 0
    rel = nslots[:3, :2][nonzero] / slots[:3, :2][nonzero]
    assert np.all(np.abs(rel - 1.0) <= SPEC.relative_noise + 1e-6)
    assert np.all(nslots[:3, :2][~nonzero] == 0.0)
    assert abs(noisy[1] - f[1]) <= SPEC.position_noise_m / UNIT + 1e-6


def test_only_the_nearest_k_rings_are_kept() -> None:
    rings = np.array([[0.0, d] for d in np.linspace(3.0, 0.3, 15)])
    f = build_frame(SPEC, view(rings_robot_xy=rings))
    ys = f[SPEC.ring_offset :].reshape(10, 3)[:, 1] * UNIT
    assert np.allclose(ys, np.sort(rings[:, 1])[:10])


def test_alliance_symmetry_of_the_frame() -> None:
    """A blue robot at the mirrored pose sees exactly what the red one sees."""
    rings = np.array([[0.2, 0.7], [-0.4, 1.1]])
    red = build_frame(SPEC, view(x=-1.2, y=0.4, heading_deg=70.0, rings_robot_xy=rings))
    blue = build_frame(
        SPEC, view(x=1.2, y=-0.4, heading_deg=250.0, alliance="blue", rings_robot_xy=rings)
    )
    assert np.allclose(red, blue, atol=1e-6)


def test_other_robot_slots() -> None:
    spec = ObservationSpec(n_other_robots=2)
    f = build_frame(spec, view(others_robot_xy=np.array([[1.0, 1.0], [0.0, 0.5]])))
    robots = f[6 : 6 + 6].reshape(2, 3)
    assert np.allclose(robots[0], [0.0, 0.5 / UNIT, 1.0])
    assert spec.ring_offset == 12


def test_frame_stack_newest_first() -> None:
    stack = FrameStack(ObservationSpec(n_stack=2))
    spec = stack.spec
    f0 = build_frame(spec, view(time_s=0.0))
    f1 = build_frame(spec, view(time_s=1.0))
    f2 = build_frame(spec, view(time_s=2.0))
    f3 = build_frame(spec, view(time_s=3.0))
    obs = stack.reset(f0)
    assert obs.shape == (spec.size,) and np.allclose(obs.reshape(3, -1), f0)
    stack.push(f1)
    stack.push(f2)
    obs = stack.push(f3).reshape(3, -1)
    assert np.allclose(obs[0], f3) and np.allclose(obs[1], f2) and np.allclose(obs[2], f1)
    with pytest.raises(ObservationError, match="shape"):
        stack.push(np.zeros(3, dtype=np.float32))


def test_bad_inputs_are_named() -> None:
    with pytest.raises(ObservationError, match="rings_robot_xy"):
        build_frame(SPEC, view(rings_robot_xy=np.zeros((3, 3))))
    with pytest.raises(ObservationError, match="finite"):
        build_frame(SPEC, view(x=float("nan")))
    with pytest.raises(ObservationError, match="NaN"):
        build_frame(SPEC, view(rings_robot_xy=np.array([[np.nan, 1.0]])))
    with pytest.raises(ObservationError, match="alliance"):
        build_frame(SPEC, view(alliance="green"))
    with pytest.raises(ObservationError, match="n_rings"):
        ObservationSpec(n_rings=0)
    with pytest.raises(ObservationError, match="version"):
        ObservationSpec(version=99)


def test_spec_round_trips_through_json_and_fingerprints_layout_only() -> None:
    spec = ObservationSpec(n_rings=8, n_stack=4)
    again = ObservationSpec.from_dict(json.loads(json.dumps(spec.to_dict())))
    assert again == spec
    assert again.fingerprint() == spec.fingerprint()
    assert ObservationSpec(relative_noise=0.0).fingerprint() == SPEC.fingerprint()
    assert ObservationSpec(n_rings=9).fingerprint() != SPEC.fingerprint()
    with pytest.raises(ObservationError, match="unknown"):
        ObservationSpec.from_dict({"version": 1, "colour": "red"})
    with pytest.raises(ObservationError, match="no version"):
        ObservationSpec.from_dict({"n_rings": 3})


def test_bounds_hold_the_frames() -> None:
    low, high = observation_bounds(SPEC)
    rng = np.random.default_rng(1)
    stack = FrameStack(SPEC)
    for _ in range(50):
        rings = rng.uniform(-2.5, 2.5, (rng.integers(0, 20), 2))
        v = view(
            x=rng.uniform(-1.8, 1.8),
            y=rng.uniform(-1.8, 1.8),
            heading_deg=rng.uniform(0, 360),
            time_s=rng.uniform(0, 105),
            rings_robot_xy=rings,
            rings_held=int(rng.integers(0, 11)),
        )
        obs = stack.push(build_frame(SPEC, v, rng))
        assert np.all(obs >= low) and np.all(obs <= high)


def test_imports_without_pybullet_or_gymnasium() -> None:
    """The Jetson imports jetson.autonomy.spec with neither PyBullet nor Gymnasium installed."""
    code = (
        "import sys\n"
        "for name in ('pybullet', 'pybullet_data', 'gymnasium', 'pettingzoo', 'PIL'):\n"
        "    sys.modules[name] = None\n"
        "import jetson.autonomy.observation as o, sim.config, sim.field, sim.visibility\n"
        "import numpy as np\n"
        "spec = o.ObservationSpec()\n"
        "v = o.RobotView(0.0, 0.0, 0.0, 'red', 1.0, np.zeros((0, 2)))\n"
        "assert o.build_frame(spec, v).shape == (spec.frame_size,)\n"
        "assert 'pybullet' not in [m for m in sys.modules if sys.modules[m] is not None]\n"
        "print('ok')\n"
    )
    out = subprocess.run(
        [sys.executable, "-c", code], capture_output=True, text=True, timeout=60, check=False
    )
    assert out.returncode == 0, out.stderr
    assert out.stdout.strip() == "ok"
