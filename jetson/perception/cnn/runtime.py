"""The CNN ring detector at run time: onnxruntime, numpy and OpenCV only (no torch).

A model is two files side by side: NAME.onnx (cnn/model.py's export) and NAME.json, its metadata:

    {"format": "pete-ringnet", "version": 1, "stride": 4, "input_long_side": 320,
     "score_threshold": 0.4, "width": 16, "trained_on": [...], "training": {...}}

The image is resized so its long side is input_long_side and both sides are multiples of 16
(640x480 -> 320x240; a 416x416 image -> 320x320), converted to RGB in [0, 1], and run once;
boxes are read off the heatmap's peaks and scaled back to the image. A small image is blown up
at most `max_upscale` times (metadata, default 2.25): a network run on a low-resolution frame
blown up far past what it trained on takes its blur and resampling for rings.
"""

from __future__ import annotations

import json
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from jetson.autonomy.providers import open_session
from jetson.errors import ModelError
from jetson.models import DEFAULT_DETECTOR
from jetson.perception.detection import Detection, non_max_suppression

MODEL_FORMAT = "pete-ringnet"
MODEL_VERSION = 1
MULTIPLE = 16
# Measured (docs/notes/2026-11-26-perception-cut-rings-and-larger-input.md): the 240x180
# renders the full-stack match feeds the detector score as well blown up 2.27 times as 2.5, and
# worse at 2.9 (twice the false rings).
DEFAULT_MAX_UPSCALE = 2.25


@dataclass(frozen=True)
class ModelInfo:
    stride: int = 4
    input_long_side: int = 320
    score_threshold: float = 0.4
    max_upscale: float = DEFAULT_MAX_UPSCALE
    extra: dict[str, Any] | None = None

    @classmethod
    def load(cls, path: Path) -> ModelInfo:
        try:
            data = json.loads(path.read_text())
        except FileNotFoundError as exc:
            msg = f"model metadata {path} is missing (it goes beside the .onnx)"
            raise ModelError(msg) from exc
        except (OSError, json.JSONDecodeError) as exc:
            raise ModelError(f"model metadata {path} cannot be read: {exc}") from exc
        if data.get("format") != MODEL_FORMAT or data.get("version") != MODEL_VERSION:
            raise ModelError(f"{path} is not {MODEL_FORMAT} version {MODEL_VERSION} metadata")
        try:
            info = cls(
                stride=int(data["stride"]),
                input_long_side=int(data["input_long_side"]),
                score_threshold=float(data["score_threshold"]),
                max_upscale=float(data.get("max_upscale", DEFAULT_MAX_UPSCALE)),
                extra=data,
            )
        except (KeyError, TypeError, ValueError) as exc:
            raise ModelError(f"{path}: bad metadata: {exc}") from exc
        if not info.max_upscale >= 1.0:
            raise ModelError(f"{path}: max_upscale must be >= 1, got {info.max_upscale}")
        return info

    def input_size(self, width: int, height: int) -> tuple[int, int]:
        """The network input for a width x height image: input_long_side, or less where that
        would blow the image up more than max_upscale times."""
        long_side = min(self.input_long_side, round(self.max_upscale * max(width, height)))
        return input_size(width, height, long_side)


def metadata_path(model: Path) -> Path:
    return model.with_suffix(".json")


def input_size(width: int, height: int, long_side: int) -> tuple[int, int]:
    """Network input (width, height): long side ~long_side, both multiples of 16."""
    scale = long_side / max(width, height)
    w = max(MULTIPLE, round(width * scale / MULTIPLE) * MULTIPLE)
    h = max(MULTIPLE, round(height * scale / MULTIPLE) * MULTIPLE)
    return w, h


def to_input(bgr: NDArray[np.uint8], size: tuple[int, int]) -> NDArray[np.float32]:
    """(1, 3, H, W) float32 RGB in [0, 1]."""
    img = cv2.resize(bgr, size, interpolation=cv2.INTER_AREA)
    rgb = cv2.cvtColor(img, cv2.COLOR_BGR2RGB)
    return np.ascontiguousarray(rgb.transpose(2, 0, 1)[None], dtype=np.float32) * np.float32(
        1.0 / 255.0
    )


def decode(
    peaks: NDArray[np.float32],
    boxes: NDArray[np.float32],
    stride: int,
    threshold: float,
    scale_xy: tuple[float, float],
    max_detections: int = 100,
) -> list[Detection]:
    """Detections from one image's outputs: peaks (1, Hc, Wc), boxes (4, Hc, Wc)."""
    ys, xs = np.nonzero(peaks[0] >= threshold)
    if ys.size == 0:
        return []
    scores = peaks[0, ys, xs]
    if scores.size > max_detections:
        top = np.argsort(-scores)[:max_detections]
        ys, xs, scores = ys[top], xs[top], scores[top]
    ox, oy, lw, lh = (boxes[k, ys, xs] for k in range(4))
    cx = (xs + ox) * stride
    cy = (ys + oy) * stride
    w = np.exp(np.clip(lw, -4.0, 6.0)) * stride
    h = np.exp(np.clip(lh, -4.0, 6.0)) * stride
    sx, sy = scale_xy
    dets = [
        Detection(
            float((cx[i] - w[i] / 2) * sx),
            float((cy[i] - h[i] / 2) * sy),
            float((cx[i] + w[i] / 2) * sx),
            float((cy[i] + h[i] / 2) * sy),
            float(scores[i]),
        )
        for i in range(len(scores))
    ]
    # Boxes are not clipped to the image: clipping bought nothing in detection F1 and took the
    # localiser's ring-shaped pixel mask off rings cut by the edge (placed-ring precision in
    # the demo match 0.980 -> 0.962). Peaks are already local maxima; NMS only removes twin
    # peaks on one ring.
    return non_max_suppression(dets, 0.6)


class CnnDetector:
    name = "cnn"

    def __init__(
        self,
        model: Path | str | None = None,
        score_threshold: float | None = None,
        threads: int = 1,
        providers: Sequence[str] | None = None,
    ) -> None:
        path = Path(model) if model is not None else DEFAULT_DETECTOR
        if not path.is_file():
            raise ModelError(
                f"detector model {path} does not exist (train one with `pete-jetson detector "
                "train`, or use --detector classical)"
            )
        self.info = ModelInfo.load(metadata_path(path))
        self.threshold = (
            score_threshold if score_threshold is not None else self.info.score_threshold
        )
        try:
            # One thread by default: the pipeline's budget is one core, the daemon owns the rest.
            self.session, self.provider = open_session(path, threads, providers)
        except ValueError as exc:  # providers that this onnxruntime does not have
            raise ModelError(f"detector model {path}: {exc}") from exc
        except ImportError as exc:
            msg = f"onnxruntime cannot be imported ({exc}): pip install 'pacman-pete[jetson]'"
            raise ModelError(msg) from exc
        except Exception as exc:  # onnxruntime raises its own exception types
            raise ModelError(f"{path} is not a loadable ONNX model: {exc}") from exc
        self.path = path

    def detect(
        self,
        bgr: NDArray[np.uint8],
        depth_m: NDArray[np.float32] | None = None,
        colour_mask: NDArray[np.uint8] | None = None,
    ) -> list[Detection]:
        h, w = bgr.shape[:2]
        size = self.info.input_size(w, h)
        peaks, boxes = self.session.run(None, {"rgb": to_input(bgr, size)})
        return decode(
            peaks[0], boxes[0], self.info.stride, self.threshold, (w / size[0], h / size[1])
        )


def network_ms(model: Path, long_side: int, repeats: int = 30) -> float:
    """Median milliseconds of one network run on a 640x480 frame's input, on one CPU thread."""
    import time

    session, _ = open_session(model, threads=1, wanted=("cpu",))
    w, h = input_size(640, 480, long_side)
    x = np.random.default_rng(0).random((1, 3, h, w), dtype=np.float32)
    session.run(None, {"rgb": x})
    times = []
    for _ in range(repeats):
        t0 = time.perf_counter()
        session.run(None, {"rgb": x})
        times.append(time.perf_counter() - t0)
    return float(np.median(times) * 1000.0)
