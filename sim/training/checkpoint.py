"""Checkpoints: everything a run needs to resume, in one torch file.

A checkpoint holds the config, the observation spec, the agent (with its observation
normalisation), the optimiser, the reward scaler, the self-play pool with its ELO ratings, the
step counters and the random states. `load_policy_fn` turns one into a deterministic
obs -> action function for evaluation without exporting.

The file holds tensors and plain data only (dict, list, tuple, str, int, float, bool, None):
the configs, counters, ELO ratings and numpy random states are stored as plain values beside
the tensors, so it loads with `torch.load(weights_only=True)`, whose unpickler builds nothing
else. A file that needs anything more (a crafted pickle, or someone else's checkpoint) is
refused with a `CheckpointError`, never loaded with the unpickler that could run its code.
"""

from __future__ import annotations

import pickle
import re
from collections import OrderedDict
from collections.abc import Callable
from pathlib import Path
from typing import Any

import numpy as np
import torch

from jetson.autonomy.skills import SkillConfig
from jetson.autonomy.spec import ObservationSpec
from sim.errors import CheckpointError
from sim.ppo import Agent
from sim.training.config import TrainConfig, parse_config

CHECKPOINT_VERSION = 1

_SCALARS = (str, int, float, bool, type(None))


def build_agent(cfg: TrainConfig, spec: ObservationSpec) -> Agent:
    return Agent(spec.size, cfg.env_config().action_size, cfg.ppo)


def plain(value: Any, where: str = "checkpoint") -> Any:
    """`value` as tensors and plain data only: numpy scalars and arrays become Python numbers
    and lists; anything else that is not plain is a CheckpointError naming where it is."""
    if isinstance(value, torch.Tensor) or type(value) in _SCALARS:
        return value
    if isinstance(value, (str, int, float)):  # an enum or other subclass: its plain value
        return next(t for t in (bool, int, float, str) if isinstance(value, t))(value)
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, dict):
        # A module's state_dict is an OrderedDict with version _metadata: both are kept.
        out: dict[Any, Any] = OrderedDict() if isinstance(value, OrderedDict) else {}
        if hasattr(value, "_metadata"):
            out._metadata = plain(value._metadata, f"{where}._metadata")  # type: ignore[attr-defined]
        for k, v in value.items():
            if not isinstance(k, (str, int)) or isinstance(k, bool):
                raise CheckpointError(f"{where}: key {k!r} is a {type(k).__name__}, not str or int")
            out[k] = plain(v, f"{where}.{k}")
        return out
    if isinstance(value, (list, tuple)):
        items = [plain(v, f"{where}[{i}]") for i, v in enumerate(value)]
        return items if isinstance(value, list) else tuple(items)
    raise CheckpointError(
        f"{where} is a {type(value).__module__}.{type(value).__qualname__}: a checkpoint holds "
        "tensors and plain data only (dict, list, tuple, str, int, float, bool, None)"
    )


def save_checkpoint(path: Path, state: dict[str, Any]) -> Path:
    """Write atomically (a crash mid-write never leaves a half checkpoint as latest)."""
    data = plain({"version": CHECKPOINT_VERSION, **state})
    path.parent.mkdir(parents=True, exist_ok=True)
    tmp = path.with_suffix(".tmp")
    torch.save(data, tmp)
    tmp.replace(path)
    return path


def load_checkpoint(path: str | Path) -> dict[str, Any]:
    p = Path(path)
    if not p.is_file():
        raise FileNotFoundError(f"no checkpoint {p}")
    try:
        state = torch.load(p, map_location="cpu", weights_only=True)
    except pickle.UnpicklingError as exc:
        # torch's message suggests weights_only=False; ours does not.
        text = str(exc)
        found = re.search(
            r"[Uu]nsupported (?:global: )?GLOBAL \S+(?: whose module \S+ is blocked)?", text
        )
        if found is None:
            detail = re.search(r"Unsupported operand \S+|invalid load key[^\n]*", text)
            why = detail.group(0) if detail else text.splitlines()[0]
            raise CheckpointError(f"{p}: not a torch checkpoint ({why})") from None
        raise CheckpointError(
            f"{p}: refused: it holds objects other than tensors and plain data "
            f"({found.group(0)}), and building them could run code. Checkpoints `pete-sim "
            "train` writes hold only tensors and plain data; if this file came from elsewhere "
            "or from an older trainer, train again (pete-sim train) rather than load it"
        ) from None
    except (RuntimeError, EOFError, KeyError, ValueError, OSError) as exc:
        raise CheckpointError(
            f"{p}: not a torch checkpoint ({type(exc).__name__}: {exc})"
        ) from None
    if not isinstance(state, dict) or state.get("version") != CHECKPOINT_VERSION:
        raise CheckpointError(
            f"{p}: not a checkpoint of this trainer (version {CHECKPOINT_VERSION})"
        )
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
