"""Export a trained Agent to policy.onnx plus policy.json, what jetson.autonomy.policy reads.

The graph is the deterministic policy with the observation normalisation folded in:

    action = clip(actor_mean(clip((obs - mean) * inv_std, -c, c)), -1, 1)

so the robot feeds raw observations. policy.json repeats the normalisation (for inspection and
for runtimes without ONNX), and carries the observation spec with its fingerprint and the action
scaling.
"""

from __future__ import annotations

import importlib.metadata
import json
import warnings
from dataclasses import asdict, replace
from pathlib import Path
from typing import Any

import torch
from torch import nn

from jetson.autonomy.policy import FORMAT, FORMAT_VERSION, metadata_path, sha256
from jetson.autonomy.spec import ObservationSpec
from sim.match import EnvConfig
from sim.ppo import Agent

INPUT_NAME = "obs"
OUTPUT_NAME = "action"
OPSET = 17


class DeterministicPolicy(nn.Module):
    def __init__(self, agent: Agent) -> None:
        super().__init__()
        self.obs_norm = agent.obs_norm
        self.actor_mean = agent.actor_mean

    def forward(self, obs: torch.Tensor) -> torch.Tensor:
        return torch.clamp(self.actor_mean(self.obs_norm(obs)), -1.0, 1.0)


def versions() -> dict[str, str]:
    out = {}
    for name in ("pacman-pete", "torch", "numpy", "pybullet", "gymnasium", "onnx", "onnxruntime"):
        try:
            out[name] = importlib.metadata.version(name)
        except importlib.metadata.PackageNotFoundError:
            out[name] = "not installed"
    return out


def action_scale(env: EnvConfig) -> dict[str, Any]:
    """How [-1, 1] actions become commands for the learning robot (the world's first robot)."""
    robot = env.world.robots[(env.world.red or env.world.blue)[0]]
    if env.skills is not None:
        from sim.field import load_field
        from sim.match import skill_settings

        skills = replace(env.skills, **skill_settings(load_field(env.world.field), "red", robot))
        n = skills.n_options
        return {
            "names": skills.option_names(),
            "scale": [1.0] * n,
            "units": ["score: the highest option is driven (jetson/autonomy/skills.py)"] * n,
            "range": [-1.0, 1.0],
            "skills": asdict(skills),
        }
    names = ["linear", "angular"]
    scale = [robot.max_linear_mps, robot.max_angular_rad_s]
    units = ["m/s forward", "rad/s clockwise (heading increasing)"]
    if env.action_intake:
        names.append("intake")
        scale.append(1.0)
        units.append("on when > 0")
    if env.action_clamp:
        names.append("clamp")
        scale.append(1.0)
        units.append("grab when > 0, release when < 0")
    return {"names": names, "scale": scale, "units": units, "range": [-1.0, 1.0]}


def export_policy(
    agent: Agent,
    spec: ObservationSpec,
    env: EnvConfig,
    out: str | Path,
    training: dict[str, Any] | None = None,
) -> tuple[Path, Path]:
    """Write `out` (an .onnx path, or a folder that gets policy.onnx) and its .json."""
    path = Path(out)
    if path.suffix != ".onnx":
        path = path / "policy.onnx"
    path.parent.mkdir(parents=True, exist_ok=True)
    if agent.obs_size != spec.size:
        raise ValueError(f"agent takes {agent.obs_size} inputs but the spec has {spec.size}")
    module = DeterministicPolicy(agent).eval()
    dummy = torch.zeros(1, spec.size)
    # dynamo=False: the TorchScript exporter needs no onnxscript; its deprecation notice is noise.
    with torch.no_grad(), warnings.catch_warnings():
        warnings.simplefilter("ignore", DeprecationWarning)
        torch.onnx.export(
            module,
            (dummy,),
            str(path),
            input_names=[INPUT_NAME],
            output_names=[OUTPUT_NAME],
            dynamic_axes={INPUT_NAME: {0: "batch"}, OUTPUT_NAME: {0: "batch"}},
            opset_version=OPSET,
            dynamo=False,
        )
    norm = agent.obs_norm
    meta = {
        "format": FORMAT,
        "format_version": FORMAT_VERSION,
        "onnx": path.name,
        "onnx_sha256": sha256(path),
        "input": {"name": INPUT_NAME, "size": spec.size, "dtype": "float32"},
        "output": {"name": OUTPUT_NAME, "size": agent.action_size, "dtype": "float32"},
        "observation": spec.to_dict(),
        "observation_fingerprint": spec.fingerprint(),
        "normalisation": {
            "in_graph": True,
            "enabled": norm.enabled,
            "clip": norm.clip,
            "mean": [round(float(v), 7) for v in norm.mean],
            "inv_std": [round(float(v), 7) for v in norm.inv_std],
        },
        "actions": action_scale(env),
        "network": {
            "hidden": [m.out_features for m in agent.actor_mean if isinstance(m, nn.Linear)][:-1],
            "activation": type(agent.actor_mean[1]).__name__,
        },
        "training": dict(training or {}),
        "versions": versions(),
    }
    meta_file = metadata_path(path)
    meta_file.write_text(json.dumps(meta, indent=1) + "\n")
    return path, meta_file
