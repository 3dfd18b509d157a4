"""Checkpoints: everything a run needs to resume, in one torch file.

A checkpoint holds the config, the observation spec, the agent (with its observation
normalisation), the optimiser, the reward scaler, the self-play pool with its ELO ratings, the
step counters and the random states. `load_policy_fn` turns one into a deterministic
obs -> action function for evaluation without exporting.
"""

from __future__ import annotations

from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch

from jetson.autonomy.skills import SkillConfig
from jetson.autonomy.spec import ObservationSpec
from sim.ppo import Agent
from sim.training.config import TrainConfig, parse_config

CHECKPOINT_VERSION = 1


def build_agent(cfg: TrainConfig, spec: ObservationSpec) -> Agent:
    return Agent(spec.size, cfg.env_config().action_size, cfg.ppo)


def save_checkpoint(path: Path, state: dict[str, Any]) -> Path:
    """Write atomically (a crash mid-write never leaves a half checkpoint as latest)."""
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    torch.save({"version": CHECKPOINT_VERSION, **state}, tmp)
    tmp.replace(path)
    return path


def load_checkpoint(path: str | Path) -> dict[str, Any]:
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"no checkpoint {p}")
    # Our own files: they hold numpy random states and plain dicts besides tensors.
    state = torch.load(p, map_location="cpu", weights_only=False)
    if not isinstance(state, dict) or state.get("version") != CHECKPOINT_VERSION:
        raise ValueError(f"{p}: not a checkpoint of this trainer (version {CHECKPOINT_VERSION})")
    return state


def agent_from_checkpoint(state: dict[str, Any]) -> tuple[Agent, ObservationSpec, TrainConfig]:
    cfg = parse_config(state["config"], "checkpoint config")
    spec = ObservationSpec.from_dict(state["spec"])
    agent = build_agent(cfg, spec)
    agent.load_state_dict(state["agent"])
    agent.obs_norm.rms.load_state_dict(state["obs_rms"])
    agent.eval()
    return agent, spec, cfg


def load_policy_fn(
    path: str | Path,
) -> tuple[Callable[[np.ndarray], np.ndarray], ObservationSpec, SkillConfig | None]:
    agent, spec, cfg = agent_from_checkpoint(load_checkpoint(path))

    @torch.no_grad()
    def fn(obs: np.ndarray) -> np.ndarray:
        x = torch.as_tensor(np.asarray(obs, dtype=np.float32))
        return agent.deterministic(x[None] if x.ndim == 1 else x).numpy().reshape(-1)

    return fn, spec, cfg.env_config().skills
