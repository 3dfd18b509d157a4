"""Int8 ring detector: static quantization of an exported RingNet with onnxruntime.

    pete-jetson detector quantize --model runs/a/ringnet.onnx --calib DIR [--calib DIR2] \
        --out jetson/models/ringnet.onnx

Weights become int8 (one scale per output channel) and activations uint8, as QuantizeLinear /
DequantizeLinear pairs around every convolution but the first and the last (quantize() says
why): the QDQ format, which onnxruntime's CPU kernels and TensorRT both run as integer
arithmetic. The activations' ranges come from running the
float model over calibration images, preprocessed exactly as the runtime does (cnn/runtime.py),
drawn evenly from the calibration folders but never from the images the model held out of its
training: those are what `detector eval` scores it on.

Why: on one CPU core the int8 network runs in about half the time of the float one (measured
in docs/notes/2026-11-25-perception-more-renders-and-int8.md), which pays for a larger input
(smaller rings found) within the 60 frames/s budget. Needs the `onnx` package (the sim extra);
the result runs with onnxruntime alone, like every model here.
"""

from __future__ import annotations

import hashlib
import json
import tempfile
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from jetson.errors import DatasetError, ModelError
from jetson.perception.cnn.runtime import (
    ModelInfo,
    metadata_path,
    network_ms,
    to_input,
)
from jetson.perception.dataset import RingDataset
from jetson.perception.evaluate import heldout_of

DEFAULT_FRAMES = 96


@dataclass(frozen=True)
class QuantizeReport:
    out: Path
    calibration_images: int
    float_ms: float  # one frame at 640x480, one thread
    int8_ms: float


def calibration_images(
    folders: list[Path], frames: int, meta: dict[str, Any]
) -> Iterator[tuple[str, str, np.ndarray]]:
    """(folder, image name, BGR image): `frames` in all, spread evenly over the folders and over
    each folder's images, skipping the images the model held out."""
    if not folders:
        raise DatasetError("quantization needs at least one --calib folder of images")
    if frames < 1:
        raise DatasetError(f"--frames must be at least 1, got {frames}")
    per = [frames // len(folders) + (k < frames % len(folders)) for k in range(len(folders))]
    for folder, n in zip(folders, per, strict=True):
        ds = RingDataset(folder)
        held = heldout_of(meta, folder) or set()
        usable = [i for i, name in enumerate(ds.names) if name not in held]
        if not usable:
            raise DatasetError(f"{folder}: every image is held out of the model's training")
        picks = np.linspace(0, len(usable) - 1, num=min(n, len(usable))).round().astype(int)
        for k in dict.fromkeys(picks.tolist()):
            i = usable[k]
            yield str(folder), ds.names[i], ds.image(i)


def edge_convolutions(model: Path) -> list[str]:
    """The names of the graph's first and last convolutions."""
    import onnx

    convs = [n.name for n in onnx.load(str(model)).graph.node if n.op_type == "Conv"]
    return list(dict.fromkeys([convs[0], convs[-1]])) if convs else []


def quantize(
    model: Path,
    folders: list[Path],
    out: Path,
    frames: int = DEFAULT_FRAMES,
    all_int8: bool = False,
) -> QuantizeReport:
    """Write the int8 model `out` (and its metadata beside it) from the float model `model`.

    The first and the last convolution stay float unless `all_int8`: the first reads the
    image, whose fine colour steps decide ring against floor on real photos, and the last
    writes the heat and box terms that are thresholded and exponentiated. They are two of
    twelve convolutions and cheap (3 input channels; 5 output channels); quantized too, they cost
    a model trained at input 560 0.02 F1 on the held-out photos
    (docs/notes/2026-11-25-perception-more-renders-and-int8.md)."""
    try:
        from onnxruntime.quantization import (
            CalibrationDataReader,
            CalibrationMethod,
            QuantFormat,
            QuantType,
            quantize_static,
        )
        from onnxruntime.quantization.shape_inference import quant_pre_process
    except ImportError as exc:
        raise ModelError(
            f"quantization needs the onnx package ({exc}): pip install 'pacman-pete[sim]'"
        ) from exc
    if not model.is_file():
        raise ModelError(f"model {model} does not exist")
    info = ModelInfo.load(metadata_path(model))
    meta = dict(info.extra or {})
    if "quantization" in meta:
        raise ModelError(f"{model} is already quantized; quantize the float model it came from")
    if out.resolve() == model.resolve():
        raise ModelError("--out must differ from --model: the float model is the calibration's")

    inputs: list[np.ndarray] = []
    used: dict[str, int] = {}
    for folder, _, bgr in calibration_images(folders, frames, meta):
        h, w = bgr.shape[:2]
        inputs.append(to_input(bgr, info.input_size(w, h)))
        used[folder] = used.get(folder, 0) + 1

    class Reader(CalibrationDataReader):  # type: ignore[misc]
        def __init__(self) -> None:
            self._it = iter(inputs)

        def get_next(self) -> dict[str, np.ndarray] | None:
            x = next(self._it, None)
            return None if x is None else {"rgb": x}

    out.parent.mkdir(parents=True, exist_ok=True)
    with tempfile.TemporaryDirectory() as tmp:
        prepared = Path(tmp) / "prepared.onnx"
        # Symbolic shape inference cannot follow the dynamic height and width through the
        # top-down path's resizes; ONNX's own inference and the graph optimisation suffice.
        quant_pre_process(str(model), str(prepared), skip_symbolic_shape=True)
        keep_float = [] if all_int8 else edge_convolutions(prepared)
        quantize_static(
            str(prepared),
            str(out),
            Reader(),
            quant_format=QuantFormat.QDQ,
            activation_type=QuantType.QUInt8,
            weight_type=QuantType.QInt8,
            per_channel=True,
            calibrate_method=CalibrationMethod.MinMax,
            nodes_to_exclude=keep_float,
        )
    meta["quantization"] = {
        "format": "QDQ",
        "weights": "int8, per output channel",
        "activations": "uint8, MinMax ranges",
        "float_nodes": keep_float,
        "calibration": [{"folder": f, "images": n} for f, n in used.items()],
        # Activation ranges depend a little on the input scale; `detector tune` warns when it
        # moves the model away from this size.
        "input_long_side": info.input_long_side,
        "float_model": model.name,
        "float_sha256": hashlib.sha256(model.read_bytes()).hexdigest(),
        # `validation` above was measured with the float model.
    }
    metadata_path(out).write_text(json.dumps(meta, indent=2) + "\n")
    return QuantizeReport(
        out,
        len(inputs),
        network_ms(model, info.input_long_side),
        network_ms(out, info.input_long_side),
    )
