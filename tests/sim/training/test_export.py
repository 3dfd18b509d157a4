"""Export: policy.onnx + policy.json, run by onnxruntime alone, equal to PyTorch within 1e-5."""

from __future__ import annotations

import json
from pathlib import Path

import numpy as np
import pytest
import torch

from jetson.autonomy.policy import OnnxPolicy
from jetson.autonomy.spec import ObservationSpec
from jetson.errors import PolicyError
from sim.match import make_config
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
        "import jetson.autonomy.policy, jetson.autonomy.spec\n"
        "assert 'pybullet' not in sys.modules\n"
    )
    subprocess.run([sys.executable, "-c", code], check=True)


def test_a_skill_policy_exports_its_controller_and_both_readers_load_it(tmp_path: Path) -> None:
    from jetson.autonomy.policy import OnnxPolicy as JetsonPolicy

    spec = ObservationSpec(n_stack=1, goal_memory=True, goal_clamp_offset_m=0.35)
    env = make_config(
        observation={"n_stack": 1, "goal_memory": True},
        skills={"ring_options": 3, "goal_options": 1},
    )
    torch.manual_seed(0)
    agent = Agent(spec.size, env.action_size, PPOConfig(hidden=(16,)))
    onnx_path, meta_path = export_policy(agent, spec, env, tmp_path)
    meta = json.loads(meta_path.read_text())
    assert meta["actions"]["names"] == ["ring0", "ring1", "ring2", "goal0", "platform"]
    skills = meta["actions"]["skills"]
    # The controller's settings come from the field and the robot, saved for the Jetson.
    assert skills["max_linear_mps"] == 0.904 and skills["max_angular_rad_s"] == 4.8
    assert skills["platform_box"][0] == pytest.approx(-1.524, abs=1e-3)
    sim_side, jetson_side = OnnxPolicy(onnx_path), JetsonPolicy(onnx_path)
    assert sim_side.skills == jetson_side.skills and sim_side.skills is not None
    assert sim_side.skills.n_options == 5
    obs = np.zeros(spec.size, dtype=np.float32)
    np.testing.assert_array_equal(sim_side(obs), jetson_side(obs))
    # Names that do not match the skills are refused.
    meta["actions"]["names"][0] = "linear"
    meta_path.write_text(json.dumps(meta))
    with pytest.raises(Exception, match="skill names"):
        JetsonPolicy(onnx_path)
