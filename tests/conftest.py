"""Fixtures shared by several test files."""

from __future__ import annotations

import json
import warnings
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pytest


@pytest.fixture(scope="session")
def untrained_ringnet() -> Callable[..., tuple[Any, Path]]:
    """Builds an untrained RingNet, exports it to ONNX with its .json beside it and returns
    (net, path). Batch-norm statistics get values other than 0 and 1, so export and
    quantization must carry them through too."""

    def build(
        path: Path, *, seed: int, width: int, blocks: int = 1, **meta: Any
    ) -> tuple[Any, Path]:
        torch = pytest.importorskip("torch")
        from jetson.perception.cnn.model import STRIDE, RingNet, export_onnx
        from jetson.perception.cnn.runtime import metadata_path

        torch.manual_seed(seed)
        net = RingNet(width=width, blocks=blocks)
        for m in net.modules():
            if isinstance(m, torch.nn.BatchNorm2d):
                m.running_mean.uniform_(-0.5, 0.5)
                m.running_var.uniform_(0.5, 2.0)
        net.eval()
        with warnings.catch_warnings():
            warnings.simplefilter("ignore", DeprecationWarning)  # the legacy exporter, on purpose
            export_onnx(net, path, 96, 128)
        info = {"format": "pete-ringnet", "version": 1, "stride": STRIDE, **meta}
        metadata_path(path).write_text(json.dumps(info))
        return net, path

    return build
