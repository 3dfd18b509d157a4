"""The trainer's opponent action (sim.training.trainer.opponent_action) is Agent.act's: the same
action and the same draw from the generator, for default.toml's skill policy and a drive
policy, on trained-looking weights and observation statistics."""

from __future__ import annotations

import numpy as np
import pytest
import torch

from sim.training.checkpoint import build_agent
from sim.training.config import load_config
from sim.training.trainer import observation_spec, opponent_action


@pytest.mark.parametrize("name", ["default", "capped"])
def test_an_opponent_action_is_agent_acts_action(name: str) -> None:
    cfg = load_config(name)
    spec = observation_spec(cfg)
    torch.manual_seed(0)
    agent = build_agent(cfg, spec)
    with torch.no_grad():
        for p in agent.parameters():
            p.add_(0.1 * torch.randn_like(p))
    agent.obs_norm.update(np.random.default_rng(0).normal(1.0, 2.0, (64, spec.size)))
    for rows in (1, 12, 16):
        obs = torch.randn(rows, spec.size)
        acting, sampling = torch.Generator().manual_seed(rows), torch.Generator().manual_seed(rows)
        for _ in range(3):
            want, _, _ = agent.act(obs, acting)
            got = opponent_action(agent, obs, sampling)
            assert torch.equal(got, want)
        assert torch.equal(acting.get_state(), sampling.get_state())
