"""Run the original team's deployed ONNX policy (BLRSAI, 2022) in our simulator, as a baseline.

The file is theirs and is not shipped: pass its path (e.g.
`pete-sim eval --policy original:PATH`). Its input `obs_0` has 25 floats (REFERENCE section 1):

    0        time since the start / 105
    1, 2     robot x, z in metres (Unity's floor plane; z is our y), field centre origin
    3, 4     0, 0
    5..24    the 10 nearest visible rings as (x, z) in the robot's frame (x right, z forward) in
             units of the 0.381 m robot cube, nearest first; missing rings are (0, 0)

and it outputs [speed, rotation] in [-1, 1]: speed x 0.61 m/s forward, rotation x 276.86 deg/s,
positive clockwise seen from above (Unity's y rotation), which is our angular convention.

Frames: Unity's x right and z forward on the floor, with the origin at the field centre, is our
GPS field frame with z as y (both measure rotation clockwise from above). Their observation had
no alliance rotation, so which side it was trained on is unknown; the adapter gives it the
alliance frame (red: the field frame; blue: rotated 180 degrees), the same convention our own
observation uses, so it sees its own side the same way from either. Their training noise
(+-0.1 m on x, z) is not added: the GPS reading is already noisy.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
from numpy.typing import ArrayLike

from jetson.autonomy.geometry import AllianceName, to_alliance_frame
from sim.errors import OriginalPolicyError
from sim.match import MatchCore
from sim.world.state import DriveCommand

N_INPUTS = 25
N_RINGS = 10
CUBE_M = 0.381  # their robot cube's edge: ring coordinates are in these units
MATCH_S = 105.0
SPEED_MPS = 0.61
TURN_RAD_S = math.radians(276.86)
INPUT_NAME = "obs_0"
DETERMINISTIC_OUTPUT = "deterministic_continuous_actions"


def original_observation(
    time_s: float,
    x_m: float,
    y_m: float,
    rings_robot_xy: ArrayLike,
    alliance: AllianceName = "red",
) -> np.ndarray:
    """The 25 inputs for a robot at GPS position (x, y) whose camera sees rings at robot-frame
    positions (N, 2) (x right, y forward, metres). The original had no heading input."""
    obs = np.zeros(N_INPUTS, dtype=np.float32)
    pos, _ = to_alliance_frame((x_m, y_m), None, alliance)
    obs[0] = time_s / MATCH_S
    obs[1], obs[2] = pos[0], pos[1]
    rings = np.asarray(rings_robot_xy, dtype=np.float64).reshape(-1, 2)
    if len(rings):
        d2 = np.einsum("ij,ij->i", rings, rings)
        nearest = rings[np.argsort(d2, kind="stable")[:N_RINGS]]
        obs[5 : 5 + 2 * len(nearest)] = (nearest / CUBE_M).ravel()
    return obs


class OriginalPolicy:
    """The ONNX file through onnxruntime; call with (25,) or (batch, 25) observations."""

    def __init__(self, path: str | Path) -> None:
        import onnxruntime as ort

        self.path = Path(path)
        if not self.path.is_file():
            raise OriginalPolicyError(f"no file {self.path}")
        options = ort.SessionOptions()
        options.intra_op_num_threads = 1
        options.inter_op_num_threads = 1
        try:
            self.session = ort.InferenceSession(
                str(self.path), options, providers=["CPUExecutionProvider"]
            )
        except Exception as e:
            raise OriginalPolicyError(f"{self.path}: onnxruntime cannot load it: {e}") from e
        inputs = self.session.get_inputs()
        if len(inputs) != 1 or inputs[0].name != INPUT_NAME or inputs[0].shape[-1] != N_INPUTS:
            got = [(i.name, i.shape) for i in inputs]
            raise OriginalPolicyError(
                f"{self.path}: expected one input {INPUT_NAME} [batch, {N_INPUTS}], got {got}"
            )
        outputs = [o.name for o in self.session.get_outputs()]
        if DETERMINISTIC_OUTPUT in outputs:
            self.output = DETERMINISTIC_OUTPUT
        elif "continuous_actions" in outputs:
            self.output = "continuous_actions"
        else:
            raise OriginalPolicyError(f"{self.path}: no continuous action output in {outputs}")

    def __call__(self, obs: np.ndarray) -> np.ndarray:
        x = np.asarray(obs, dtype=np.float32)
        single = x.ndim == 1
        x = x.reshape(-1, N_INPUTS)
        out = np.clip(self.session.run([self.output], {INPUT_NAME: x})[0], -1.0, 1.0)
        return out[0] if single else out


def looks_like_original(path: str | Path) -> bool:
    """An ONNX file with the ML-Agents input obs_0 [batch, 25] and no metadata of ours."""
    p = Path(path)
    if p.suffix != ".onnx" or not p.is_file() or p.with_suffix(".json").is_file():
        return False
    try:
        OriginalPolicy(p)
    except OriginalPolicyError:
        return False
    return True


def observe(core: MatchCore, index: int) -> np.ndarray:
    """The 25 inputs for robot `index` now: its GPS reading (noisy and delayed when the env has
    gps_noise) and the rings its camera sees."""
    view = core.view(index)
    return original_observation(view.time_s, view.x, view.y, view.rings_robot_xy, view.alliance)


class OriginalPlayer:
    """Drives a robot with the original policy (a sim.players.Player)."""

    def __init__(self, path: str | Path) -> None:
        self.policy = OriginalPolicy(path)
        self.name = "original"

    def reset(self, core: MatchCore, index: int, rng: np.random.Generator) -> None:
        pass

    def act(self, core: MatchCore, index: int, obs: np.ndarray) -> DriveCommand:
        speed, rotation = self.policy(observe(core, index))
        return DriveCommand(float(speed) * SPEED_MPS, float(rotation) * TURN_RAD_S)
