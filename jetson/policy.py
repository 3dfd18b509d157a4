"""The driving policy: an exported policy.onnx and its policy.json, run with onnxruntime.

The files are what sim.training.export writes (format "pacman-pete-policy", version 1): the
network takes the raw stacked observation of sim.observation and returns actions in [-1, 1];
policy.json carries the observation spec (checked against its fingerprint), the input and output
names, and how each action scales to the robot's units, or, for a skill policy, the settings of
the controller that drives its skills (sim/skills.py). The Jetson reads them here with numpy,
onnxruntime, sim.observation and sim.skills only (tests check this reader against sim.policy's
on the same file, so the two cannot drift apart).
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from sim.observation import ObservationError, ObservationSpec
from sim.skills import SkillConfig, skill_config_from_dict

FORMAT = "pacman-pete-policy"
FORMAT_VERSION = 1
DEFAULT_MODEL = Path(__file__).resolve().parent.parent / "models" / "policy" / "policy.onnx"


class PolicyError(RuntimeError):
    """A policy that cannot be loaded or run, named with the reason."""


class Policy(Protocol):
    """What the decision code needs from a policy."""

    spec: ObservationSpec
    action_names: tuple[str, ...]  # "linear", "angular", optionally "intake", "clamp"
    action_scale: tuple[float, ...]  # action * scale = m/s, rad/s clockwise, ...
    description: str
    # Set when the actions are skill scores: the controller that turns them into driving.
    skills: SkillConfig | None

    def __call__(self, obs: NDArray[np.float32]) -> NDArray[np.float32]: ...


def control_hz_of(meta: Mapping[str, Any]) -> float | None:
    """The control rate the policy was trained at, if its metadata says: a top-level
    "control_hz", else the first one inside its training record (e.g. the world config's)."""

    def find(node: Any, depth: int) -> float | None:
        if not isinstance(node, Mapping) or depth > 6:
            return None
        value = node.get("control_hz")
        if isinstance(value, int | float) and not isinstance(value, bool) and value > 0:
            return float(value)
        for child in node.values():
            if (found := find(child, depth + 1)) is not None:
                return found
        return None

    return find({"control_hz": meta.get("control_hz"), "training": meta.get("training")}, 0)


class OnnxPolicy:
    """A deterministic policy from policy.onnx + policy.json; call with one observation."""

    def __init__(self, path: str | Path) -> None:
        import onnxruntime as ort

        p = Path(path)
        if p.is_dir():
            p = p / "policy.onnx"
        if not p.is_file():
            raise PolicyError(f"no policy at {path} (give policy.onnx or its folder)")
        meta_file = p.with_suffix(".json")
        if not meta_file.is_file():
            raise PolicyError(f"{p}: its metadata {meta_file.name} is missing beside it")
        try:
            meta = json.loads(meta_file.read_text())
        except (OSError, json.JSONDecodeError) as exc:
            raise PolicyError(f"{meta_file}: cannot be read: {exc}") from exc
        self.path = p
        self.meta = meta
        self.sha256 = hashlib.sha256(p.read_bytes()).hexdigest()
        self._parse(meta, str(meta_file))
        options = ort.SessionOptions()
        # Batch-1 MLP: one thread beats thread hand-offs, and perception needs the other cores.
        options.intra_op_num_threads = 1
        options.inter_op_num_threads = 1
        try:
            self._session = ort.InferenceSession(
                str(p), options, providers=["CPUExecutionProvider"]
            )
        except Exception as exc:  # onnxruntime has its own exception types
            raise PolicyError(f"{p}: onnxruntime cannot load it: {exc}") from exc
        names = [i.name for i in self._session.get_inputs()]
        if self._input not in names:
            raise PolicyError(f"{p}: no input named {self._input!r} (it has {names})")
        self.control_hz = control_hz_of(meta)
        self.description = f"{p} sha256 {self.sha256[:12]}"

    def _parse(self, meta: dict[str, Any], where: str) -> None:
        if meta.get("format") != FORMAT or meta.get("format_version") != FORMAT_VERSION:
            raise PolicyError(
                f"{where}: not a {FORMAT} v{FORMAT_VERSION} file "
                f"(format {meta.get('format')!r} v{meta.get('format_version')!r})"
            )
        try:
            self.spec = ObservationSpec.from_dict(dict(meta["observation"]))
            fingerprint = meta["observation_fingerprint"]
            self._input = str(meta["input"]["name"])
            self._output = str(meta["output"]["name"])
            in_size, out_size = int(meta["input"]["size"]), int(meta["output"]["size"])
            acts = meta["actions"]
            self.action_names = tuple(str(n) for n in acts["names"])
            self.action_scale = tuple(float(s) for s in acts["scale"])
            skills = acts.get("skills")
            self.skills = None if skills is None else skill_config_from_dict(dict(skills))
        except (KeyError, TypeError, ValueError) as exc:
            raise PolicyError(f"{where}: missing or malformed entry {exc}") from exc
        except ObservationError as exc:
            raise PolicyError(f"{where}: {exc}") from exc
        if self.spec.fingerprint() != fingerprint:
            raise PolicyError(
                f"{where}: observation fingerprint {fingerprint} does not match its spec "
                f"({self.spec.fingerprint()})"
            )
        if in_size != self.spec.size:
            raise PolicyError(f"{where}: input size {in_size} != observation size {self.spec.size}")
        if not len(self.action_names) == len(self.action_scale) == out_size:
            raise PolicyError(f"{where}: {out_size} outputs but names/scales do not match")
        if self.skills is not None:
            if self.action_names != tuple(self.skills.option_names()):
                raise PolicyError(
                    f"{where}: skill names {self.action_names} do not match its skills"
                )
            try:
                self.skills.check(self.spec)
            except ValueError as exc:
                raise PolicyError(f"{where}: {exc}") from exc
        elif self.action_names[:2] != ("linear", "angular"):
            raise PolicyError(f"{where}: actions must start with linear, angular (or be skills)")
        expected = meta.get("onnx_sha256")
        if expected and expected != self.sha256:
            raise PolicyError(f"{self.path}: contents do not match onnx_sha256 in {where}")

    def __call__(self, obs: NDArray[np.float32]) -> NDArray[np.float32]:
        x = np.asarray(obs, dtype=np.float32).reshape(1, -1)
        if x.shape[1] != self.spec.size:
            raise PolicyError(f"observation has {x.shape[1]} values, the policy {self.spec.size}")
        out = self._session.run([self._output], {self._input: x})[0]
        return np.asarray(out, dtype=np.float32).reshape(-1)
