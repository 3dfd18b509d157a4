"""An untrained policy of the learned alliance's config (sim/configs/alliance.toml) for tests that
need one to run (the benchmark, the full stack): its observation spec and skills, random weights."""

from __future__ import annotations

from pathlib import Path


def untrained_alliance_policy(folder: Path, seed: int = 0) -> Path:
    """policy.onnx (and policy.json) in `folder`, as training with alliance.toml exports it."""
    import torch

    from sim.fast.matches import FastMatches
    from sim.ppo import Agent, PPOConfig
    from sim.training.config import load_config
    from sim.training.export import export_policy
    from sim.training.rollout import RolloutConfig

    env = load_config("alliance").env_config()
    spec = FastMatches(env, RolloutConfig(workers=0, envs_per_worker=2), seed=0).spec
    torch.manual_seed(seed)
    agent = Agent(spec.size, env.action_size, PPOConfig(hidden=(16,)))
    onnx_path, _ = export_policy(agent, spec, env, folder)
    return onnx_path
