"""Export: policy.onnx + policy.json, run by onnxruntime alone, equal to PyTorch within 1e-5."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from sim.match import make_config
from sim.observation import ObservationSpec
from sim.policy import OnnxPolicy, PolicyError
from sim.ppo import Agent, PPOConfig
from sim.training.export import export_policy

SPEC = ObservationSpec(n_stack=2)


def _trained_looking_agent() -> Agent:
    """An agent whose normaliser and weights are far from their initial values."""
    torch.manual_seed(0)
    agent = Agent(SPEC.size, 2, PPOConfig(hidden=(64, 64), activation="tanh"))
    rng = np.random.default_rng(0)
    agent.obs_norm.update(rng.normal(0.5, 2.0, size=(500, SPEC.size)).astype(np.float32))
    with torch.no_grad():
        for p in agent.actor_mean.parameters():
            p.add_(torch.randn_like(p) * 0.3)
    return agent


def test_onnxruntime_and_pytorch_agree(tmp_path: Path) -> None:
    agent = _trained_looking_agent()
    env = make_config(observation={"n_stack": 2})
    onnx_path, meta_path = export_policy(agent, SPEC, env, tmp_path, {"steps": 123})
    assert onnx_path.name == "policy.onnx" and meta_path.name == "policy.json"
    policy = OnnxPolicy(onnx_path)
    rng = np.random.default_rng(1)
    obs = rng.normal(0.0, 3.0, size=(64, SPEC.size)).astype(np.float32)
    with torch.no_grad():
        expected = agent.deterministic(torch.as_tensor(obs)).numpy()
    got = policy(obs)
    np.testing.assert_allclose(got, expected, atol=1e-5, rtol=0)
    assert np.abs(got).max() <= 1.0 and np.abs(expected).max() > 0.5, "a non-trivial check"
    np.testing.assert_allclose(policy(obs[3]), expected[3], atol=1e-5, rtol=0)
    lin, ang = policy.command(obs[3])
    assert lin == pytest.approx(expected[3][0] * 0.904, abs=1e-4)
    assert ang == pytest.approx(expected[3][1] * 4.8, abs=1e-4)


def test_metadata_says_what_the_network_expects(tmp_path: Path) -> None:
    agent = _trained_looking_agent()
    env = make_config(observation={"n_stack": 2})
    onnx_path, meta_path = export_policy(agent, SPEC, env, tmp_path / "p.onnx")
    meta = json.loads(meta_path.read_text())
    assert meta["observation"] == SPEC.to_dict()
    assert meta["observation_fingerprint"] == SPEC.fingerprint()
    assert meta["input"] == {"name": "obs", "size": SPEC.size, "dtype": "float32"}
    assert meta["actions"]["names"] == ["linear", "angular"]
    assert meta["actions"]["scale"] == [0.904, 4.8]
    norm = meta["normalisation"]
    assert norm["in_graph"] and len(norm["mean"]) == SPEC.size
    np.testing.assert_allclose(norm["mean"], agent.obs_norm.mean.numpy(), atol=1e-6)
    assert onnx_path.stat().st_size < 200_000, "kilobytes"


def test_policy_refuses_what_it_cannot_run(tmp_path: Path) -> None:
    agent = _trained_looking_agent()
    env = make_config(observation={"n_stack": 2})
    onnx_path, meta_path = export_policy(agent, SPEC, env, tmp_path)
    with pytest.raises(PolicyError, match="another observation"):
        OnnxPolicy(onnx_path, expected_spec=ObservationSpec())  # the robot builds n_stack 10
    policy = OnnxPolicy(onnx_path, expected_spec=SPEC)
    with pytest.raises(PolicyError, match=f"{SPEC.size} values"):
        policy(np.zeros(10, np.float32))
    with pytest.raises(PolicyError, match="NaN"):
        policy(np.full(SPEC.size, np.nan, np.float32))
    meta = json.loads(meta_path.read_text())
    meta["observation"]["n_rings"] = 5
    meta_path.write_text(json.dumps(meta))
    with pytest.raises(PolicyError, match="fingerprint"):
        OnnxPolicy(onnx_path)
    meta_path.unlink()
    with pytest.raises(PolicyError, match="metadata"):
        OnnxPolicy(onnx_path)


def test_the_jetson_side_needs_no_torch() -> None:
    import subprocess
    import sys

    code = (
        "import sys; sys.modules['torch'] = None\n"
        "import sim.policy, sim.observation\n"
        "assert 'pybullet' not in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)
