"""The adapter for the original team's ONNX policy: exactly their documented 25 inputs.

Layout (REFERENCE section 1, the anchor README): time / 105; robot x, z (metres); 0, 0; the 10
nearest visible rings as (x right, z forward) in the robot frame in units of the 0.381 m cube,
nearest first, (0, 0) for missing ones. The ONNX file itself is not in the repository: the test
that runs it is skipped where it is absent.
"""

from __future__ import annotations

import math
import os
from pathlib import Path

import numpy as np
import pytest

from sim.baselines.original import (
    CUBE_M,
    SPEED_MPS,
    TURN_RAD_S,
    looks_like_original,
    observe,
    original_observation,
)
from sim.errors import OriginalPolicyError
from sim.match import MatchCore, make_config
from sim.world import sensors

ORIGINAL = Path(
    os.environ.get("PETE_ORIGINAL_POLICY", "/work/shared/anchors/blrsai-policy/4-29-22-1.0.onnx")
)


def test_scaling_constants_are_the_documented_ones() -> None:
    assert CUBE_M == 0.381
    assert SPEED_MPS == 0.61
    assert math.degrees(TURN_RAD_S) == pytest.approx(276.86)


def test_pure_layout_order_padding_and_truncation() -> None:
    # 12 rings (robot frame, metres): only the 10 nearest are kept, nearest first.
    rings = np.array([[0.0, float(d)] for d in (3.0, 0.5, 2.0, 1.0, 4.0, 1.5, 2.5, 0.8,
                                                 3.5, 1.2, 5.0, 0.9)])  # fmt: skip
    obs = original_observation(52.5, -1.0, 0.25, rings, "red")
    assert obs.shape == (25,) and obs.dtype == np.float32
    assert obs[0] == pytest.approx(0.5)
    assert obs[1:5].tolist() == pytest.approx([-1.0, 0.25, 0.0, 0.0])
    expected = sorted(d for d in rings[:, 1])[:10]
    assert obs[5::2].tolist() == pytest.approx([0.0] * 10)
    assert obs[6::2].tolist() == pytest.approx([d / 0.381 for d in expected])
    # Fewer rings than slots: the rest are (0, 0).
    two = original_observation(0.0, 0.0, 0.0, np.array([[0.381, 0.762], [-0.381, 0.0]]))
    assert two[5:9].tolist() == pytest.approx([-1.0, 0.0, 1.0, 2.0])
    assert not two[9:].any()
    # Blue sees the field rotated 180 degrees.
    blue = original_observation(0.0, 1.0, -0.5, np.zeros((0, 2)), "blue")
    assert blue[1:3].tolist() == pytest.approx([-1.0, 0.5])


def _scene(alliance: str) -> tuple[MatchCore, int]:
    cfg = make_config(gps_noise=False, obs_noise=False)
    world_cfg = cfg.world
    from dataclasses import replace

    other = "blue" if alliance == "red" else "red"
    core = MatchCore(cfg, replace(world_cfg, **{other: ()}))
    core.reset(np.random.default_rng(0))
    return core, 0


@pytest.mark.parametrize("alliance", ["red", "blue"])
def test_world_state_gives_the_documented_inputs(alliance: str) -> None:
    core, i = _scene(alliance)
    w = core.world
    try:
        # Robot at (-1.2, -0.5) facing +x (heading 90); its right is field -y.
        sign = 1.0 if alliance == "red" else -1.0
        w.place_robot(i, sign * -1.2, sign * -0.5, 90.0 if alliance == "red" else 270.0)
        # Rings at robot-frame (right, forward) = (0, 1.2), (0.3, 1.0), (-0.4, 1.5) metres.
        local = np.array([[0.0, 1.2], [0.3, 1.0], [-0.4, 1.5]])
        field = np.array([[-1.2 + f, -0.5 - r] for r, f in local]) * sign
        w.set_floor_rings(field)
        for _ in range(12):  # one second of standing still: time 1 s
            core.step([core.command(i, [0.0, 0.0])])
        assert sorted(sensors.visible_rings(w, i).tolist()) == [0, 1, 2], "all three in view"
        obs = observe(core, i)
        expected = np.zeros(25, dtype=np.float32)
        expected[0] = 1.0 / 105.0
        expected[1:3] = (-1.2, -0.5)  # the alliance frame: the same numbers for both sides
        order = np.argsort(np.hypot(local[:, 0], local[:, 1]))  # (0.3,1.0), (0,1.2), (-0.4,1.5)
        expected[5:11] = (local[order] / 0.381).ravel()
        np.testing.assert_allclose(obs, expected, atol=1e-5)
    finally:
        core.close()


def test_not_an_original_file_is_refused(tmp_path: Path) -> None:
    from sim.baselines.original import OriginalPolicy

    bad = tmp_path / "x.onnx"
    bad.write_bytes(b"not onnx")
    with pytest.raises(OriginalPolicyError, match="onnxruntime cannot load"):
        OriginalPolicy(bad)
    with pytest.raises(OriginalPolicyError, match="no file"):
        OriginalPolicy(tmp_path / "missing.onnx")
    assert not looks_like_original(bad)


@pytest.mark.skipif(not ORIGINAL.is_file(), reason="the original policy file is not here")
def test_the_original_file_runs_and_drives() -> None:
    from sim.baselines.original import OriginalPlayer

    assert looks_like_original(ORIGINAL)
    player = OriginalPlayer(ORIGINAL)
    a = player.policy(np.zeros(25, np.float32))
    assert a.shape == (2,) and np.all(np.abs(a) <= 1.0)
    core, i = _scene("red")
    try:
        cmd = player.act(core, i, np.zeros(1))
        assert abs(cmd.linear) <= SPEED_MPS and abs(cmd.angular) <= TURN_RAD_S
    finally:
        core.close()
