"""The one policy reader: an exported policy.onnx and its policy.json, run with onnxruntime.

    policy = OnnxPolicy("jetson/models/policy/policy.onnx")   # or its folder; policy.json beside
    action = policy(obs)                                     # one observation, or a batch (N, size)
    linear_mps, angular_rad_s = policy.command(obs)          # scaled to the robot; clockwise

The files are what sim.training.export writes (format "pacman-pete-policy", version 1): the
network takes the raw stacked observation (spec.py) and returns actions in [-1, 1]; policy.json
carries the observation spec (checked against its fingerprint), the input and output names, how
each action scales to the robot's units, or, for a skill policy, the settings of the controller
that drives its skills (skills.py). A file that does not say all of this consistently, or whose
spec differs from the one the caller builds, is refused with the reason named, never run on the
wrong inputs. The robot and the simulator both read policies here: numpy and onnxruntime only
(imported when a policy is opened). It runs on the best execution provider installed, or on those
`providers` names (jetson.autonomy.providers); `.provider` says which one it got.
"""

from __future__ import annotations

import hashlib
import json
from collections.abc import Mapping, Sequence
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.providers import open_session
from jetson.autonomy.skills import SkillConfig, skill_config_from_dict
from jetson.autonomy.spec import ObservationSpec
from jetson.errors import ObservationError, PolicyError

FORMAT = "pacman-pete-policy"
FORMAT_VERSION = 1


class Policy(Protocol):
    """What the decision code needs from a policy."""

    spec: ObservationSpec
    action_names: tuple[str, ...]  # "linear", "angular", optionally "intake", "clamp"
    action_scale: tuple[float, ...]  # action * scale = m/s, rad/s clockwise, ...
    description: str
    # Set when the actions are skill scores: the controller that turns them into driving.
    skills: SkillConfig | None

    def __call__(self, obs: NDArray[np.float32]) -> NDArray[np.float32]: ...


def metadata_path(onnx_path: Path) -> Path:
    """Where a policy.onnx's metadata lives: policy.json beside it."""
    return onnx_path.with_suffix(".json")


def sha256(path: Path) -> str:
    return hashlib.sha256(path.read_bytes()).hexdigest()


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
    """A deterministic policy from policy.onnx + policy.json: the network's clipped mean action.

    `expected_spec`: the observation the caller builds; a policy trained on another is refused
    with the differing fields named. `providers`: onnxruntime execution providers in order of
    preference (jetson.autonomy.providers); None, the best one installed.
    """

    def __init__(
        self,
        path: str | Path,
        expected_spec: ObservationSpec | None = None,
        providers: Sequence[str] | None = None,
    ) -> None:
        p = Path(path)
        if p.is_dir():
            p = p / "policy.onnx"
        if not p.is_file():
            raise PolicyError(f"no policy at {path} (give policy.onnx or its folder)")
        meta_file = metadata_path(p)
        if not meta_file.is_file():
            raise PolicyError(f"{p}: its metadata {meta_file.name} is missing beside it")
        try:
            meta = json.loads(meta_file.read_text())
        except (OSError, UnicodeDecodeError, json.JSONDecodeError) as exc:
            raise PolicyError(f"{meta_file}: cannot be read: {exc}") from exc
        if not isinstance(meta, dict):
            raise PolicyError(f"{meta_file}: must hold a JSON object")
        self.path = p
        self.name = p.stem
        self.meta: dict[str, Any] = meta
        self.sha256 = sha256(p)
        self._parse(meta, str(meta_file))
        if expected_spec is not None and expected_spec.fingerprint() != self.spec.fingerprint():
            raise PolicyError(_spec_difference(expected_spec, self.spec))
        self._session, self.provider = _open_session(p, providers)
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
            self.action_units = tuple(str(u) for u in acts.get("units", ()))
            skills = acts.get("skills")
            self.skills = None if skills is None else skill_config_from_dict(dict(skills))
        except ObservationError as exc:
            raise PolicyError(f"{where}: {exc}") from exc
        except (KeyError, TypeError, ValueError) as exc:
            raise PolicyError(f"{where}: missing or malformed entry {exc}") from exc
        if self.spec.fingerprint() != fingerprint:
            raise PolicyError(
                f"{where}: observation fingerprint {fingerprint} does not match its spec "
                f"({self.spec.fingerprint()}): the file was edited or is corrupt"
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
        """Actions for one observation (size,) or a batch (N, size)."""
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
        out = np.asarray(self._session.run([self._output], {self._input: x})[0], np.float32)
        return out[0] if single else out

    def command(self, obs: NDArray[np.float32]) -> tuple[float, ...]:
        """The action scaled to the robot's units (m/s, rad/s clockwise, ...)."""
        a = self(obs)
        return tuple(float(v) * s for v, s in zip(a, self.action_scale, strict=True))


def _open_session(path: Path, providers: Sequence[str] | None) -> tuple[Any, str]:
    try:
        # One thread: a batch-1 MLP is faster without thread hand-offs, and perception needs
        # the other cores.
        return open_session(path, threads=1, wanted=providers)
    except ValueError as exc:  # providers that this onnxruntime does not have
        raise PolicyError(f"{path}: {exc}") from exc
    except ImportError as exc:
        msg = f"onnxruntime cannot be imported ({exc}): pip install 'pacman-pete[jetson]'"
        raise PolicyError(msg) from exc
    except Exception as exc:  # onnxruntime raises its own exception types
        raise PolicyError(f"{path}: onnxruntime cannot load it: {exc}") from exc


def _spec_difference(expected: ObservationSpec, got: ObservationSpec) -> str:
    a, b = expected.to_dict(), got.to_dict()
    diff = {k: (a[k], b[k]) for k in a if a[k] != b.get(k)}
    return (
        f"the policy expects another observation (fingerprint {got.fingerprint()}, "
        f"this robot builds {expected.fingerprint()}); differences (robot, policy): {diff}"
    )
