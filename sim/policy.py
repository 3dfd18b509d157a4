"""Running an exported policy with onnxruntime alone: what the Jetson does (it has no torch).

    policy = OnnxPolicy("models/policy/policy.onnx")   # reads policy.json beside it
    action = policy(obs)                              # [linear, angular] in [-1, 1]
    linear_mps, angular_rad_s = policy.command(obs)   # scaled to the robot; angular clockwise

The metadata (policy.json, written by sim.training.export) says what the network expects: the
observation spec (sim.observation, checked against its fingerprint), the normalisation already
inside the graph, and how to scale the action. A policy whose spec does not match the robot's is
refused with the difference named, never run on the wrong inputs.

Imports: numpy, onnxruntime and sim.observation (numpy only).
"""

from __future__ import annotations

import hashlib
import json
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from sim.observation import ObservationError, ObservationSpec
from sim.skills import SkillConfig, skill_config_from_dict

FORMAT = "pacman-pete-policy"
FORMAT_VERSION = 1


class PolicyError(ValueError):
    """A policy file that cannot be used, or an input it cannot take, named."""


@dataclass(frozen=True)
class ActionScale:
    names: tuple[str, ...]
    scale: tuple[float, ...]  # action * scale = the command in `units`
    units: tuple[str, ...]


@dataclass(frozen=True)
class PolicyMetadata:
    spec: ObservationSpec
    input_name: str
    output_name: str
    actions: ActionScale
    raw: dict[str, Any]

    @classmethod
    def from_dict(cls, data: dict[str, Any], where: str = "policy metadata") -> PolicyMetadata:
        if data.get("format") != FORMAT:
            raise PolicyError(f"{where}: not a {FORMAT} file (format {data.get('format')!r})")
        if data.get("format_version") != FORMAT_VERSION:
            raise PolicyError(
                f"{where}: format_version {data.get('format_version')!r}, "
                f"this code reads {FORMAT_VERSION}"
            )
        try:
            spec = ObservationSpec.from_dict(dict(data["observation"]))
            fingerprint = data["observation_fingerprint"]
            io = data["input"], data["output"]
            acts = data["actions"]
            actions = ActionScale(
                tuple(acts["names"]), tuple(float(s) for s in acts["scale"]), tuple(acts["units"])
            )
        except (KeyError, TypeError) as e:
            raise PolicyError(f"{where}: missing or malformed entry {e}") from e
        except ObservationError as e:
            raise PolicyError(f"{where}: {e}") from e
        if spec.fingerprint() != fingerprint:
            raise PolicyError(
                f"{where}: observation fingerprint {fingerprint} does not match its spec "
                f"({spec.fingerprint()}): the file was edited or is corrupt"
            )
        if int(io[0]["size"]) != spec.size:
            raise PolicyError(f"{where}: input size {io[0]['size']} != spec size {spec.size}")
        if len(actions.scale) != int(io[1]["size"]):
            raise PolicyError(f"{where}: {len(actions.scale)} action scales for {io[1]['size']}")
        return cls(spec, str(io[0]["name"]), str(io[1]["name"]), actions, data)


def metadata_path(onnx_path: Path) -> Path:
    return onnx_path.with_suffix(".json")


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


class OnnxPolicy:
    """A deterministic policy: the network's clipped mean action."""

    def __init__(self, path: str | Path, expected_spec: ObservationSpec | None = None) -> None:
        import onnxruntime as ort

        self.path = Path(path)
        if not self.path.is_file():
            raise PolicyError(f"no policy file {self.path}")
        meta_file = metadata_path(self.path)
        if not meta_file.is_file():
            raise PolicyError(f"{self.path}: its metadata {meta_file.name} is missing")
        try:
            data = json.loads(meta_file.read_text())
        except json.JSONDecodeError as e:
            raise PolicyError(f"{meta_file}: not valid JSON: {e}") from e
        self.meta = PolicyMetadata.from_dict(data, str(meta_file))
        expected_hash = data.get("onnx_sha256")
        if expected_hash and expected_hash != sha256(self.path):
            raise PolicyError(f"{self.path}: contents do not match onnx_sha256 in {meta_file.name}")
        if (
            expected_spec is not None
            and expected_spec.fingerprint() != self.meta.spec.fingerprint()
        ):
            raise PolicyError(_spec_difference(expected_spec, self.meta.spec))
        options = ort.SessionOptions()
        # One thread: a batch-1 MLP is faster without thread hand-offs, and the Jetson's other
        # cores are busy with perception.
        options.intra_op_num_threads = 1
        options.inter_op_num_threads = 1
        try:
            self.session = ort.InferenceSession(
                str(self.path), options, providers=["CPUExecutionProvider"]
            )
        except Exception as e:  # onnxruntime raises its own exception types
            raise PolicyError(f"{self.path}: onnxruntime cannot load it: {e}") from e
        inputs = {i.name: i for i in self.session.get_inputs()}
        if self.meta.input_name not in inputs:
            raise PolicyError(f"{self.path}: no input named {self.meta.input_name!r}")
        self.name = self.path.stem

    @property
    def spec(self) -> ObservationSpec:
        return self.meta.spec

    @property
    def skills(self) -> SkillConfig | None:
        """The skill controller's settings when the actions are skill scores (sim/skills.py)."""
        data = self.meta.raw["actions"].get("skills")
        return None if data is None else skill_config_from_dict(data)

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        x = np.asarray(obs, dtype=np.float32)
        single = x.ndim == 1
        if single:
            x = x[None, :]
        if x.ndim != 2 or x.shape[1] != self.spec.size:
            raise PolicyError(
                f"observation must have {self.spec.size} values (spec fingerprint "
                f"{self.spec.fingerprint()}), got shape {np.shape(obs)}"
            )
        if not np.all(np.isfinite(x)):
            raise PolicyError("observation contains NaN or infinity")
        out = self.session.run([self.meta.output_name], {self.meta.input_name: x})[0]
        return out[0] if single else out

    def command(self, obs: np.ndarray) -> tuple[float, ...]:
        """The action scaled to the robot's units (m/s, rad/s clockwise)."""
        a = self(obs)
        return tuple(float(v) * s for v, s in zip(a, self.meta.actions.scale, strict=True))


def _spec_difference(expected: ObservationSpec, got: ObservationSpec) -> str:
    a, b = expected.to_dict(), got.to_dict()
    diff = {k: (a[k], b[k]) for k in a if a[k] != b.get(k)}
    return (
        f"the policy expects another observation (fingerprint {got.fingerprint()}, "
        f"this robot builds {expected.fingerprint()}); differences (robot, policy): {diff}"
    )
