"""RingNet: a small fully convolutional ring detector, trained from scratch (needs torch).

CenterNet-style: at stride 4 the network predicts, per cell, a ring-centre heatmap, the centre's
offset inside the cell and the box's log width and height (in cells). Four stride-2 stages (16,
32, 64, 96 channels at the default width) with a small top-down path back to stride 4 keep it
near 0.1 GMAC at 320x240, so one CPU core runs it in milliseconds. The input is RGB in [0, 1];
normalisation happens inside, so the runtime needs only a resize and a transpose.

Exported with `export_onnx`, the graph also does the sigmoid and the 3x3 max-pool peak test, so
the Jetson's decoding (cnn/runtime.py) is a threshold and a gather in numpy.
"""

from __future__ import annotations

import warnings
from pathlib import Path

import torch
from torch import nn
from torch.nn import functional

STRIDE = 4
HEAD_CHANNELS = 5  # heat logit, offset x, offset y, log w, log h
HEAT_PRIOR = 0.02  # initial heat everywhere: few cells hold a ring centre


def _cbr(c_in: int, c_out: int, stride: int = 1, dilation: int = 1) -> nn.Sequential:
    return nn.Sequential(
        nn.Conv2d(c_in, c_out, 3, stride, padding=dilation, dilation=dilation, bias=False),
        nn.BatchNorm2d(c_out),
        nn.ReLU(inplace=True),
    )


class RingNet(nn.Module):
    """`blocks` is the number of 3x3 convolutions after the down-sampling one in stages 3 and 4
    (stride 8 and 16), where depth is cheapest: at 480x368 one more block in each widens the
    receptive field to a whole cluster of touching rings for ~45 % more network time (measured:
    the pipeline's 127 frames/s become 110)."""

    def __init__(self, width: int = 16, blocks: int = 1) -> None:
        super().__init__()
        c1, c2, c3, c4 = width, 2 * width, 4 * width, 6 * width
        self.width = width
        self.blocks = blocks
        self.stem = _cbr(3, c1, 2)
        self.stage2 = nn.Sequential(_cbr(c1, c2, 2), _cbr(c2, c2))
        self.stage3 = nn.Sequential(_cbr(c2, c3, 2), *(_cbr(c3, c3) for _ in range(blocks)))
        # Dilations 2, 4, 2, 4, ...: the deepest stage sees a whole cluster.
        self.stage4 = nn.Sequential(
            _cbr(c3, c4, 2), *(_cbr(c4, c4, dilation=2 + 2 * (k % 2)) for k in range(blocks))
        )
        self.lateral4 = nn.Conv2d(c4, c2, 1)
        self.lateral3 = nn.Conv2d(c3, c2, 1)
        self.lateral2 = nn.Conv2d(c2, c2, 1)
        self.head = nn.Sequential(_cbr(c2, c2), nn.Conv2d(c2, HEAD_CHANNELS, 1))
        prior = torch.log(torch.tensor(HEAT_PRIOR / (1 - HEAT_PRIOR)))
        with torch.no_grad():
            self.head[1].bias.zero_()
            self.head[1].bias[0] = prior

    def forward(self, rgb: torch.Tensor) -> torch.Tensor:
        """(N, 3, H, W) RGB in [0, 1], H and W multiples of 16 -> (N, 5, H/4, W/4) raw."""
        x = (rgb - 0.45) / 0.25
        f2 = self.stage2(self.stem(x))
        f3 = self.stage3(f2)
        f4 = self.stage4(f3)
        p3 = self.lateral3(f3) + functional.interpolate(self.lateral4(f4), scale_factor=2.0)
        p2 = self.lateral2(f2) + functional.interpolate(p3, scale_factor=2.0)
        return self.head(functional.relu(p2))


class ExportWrapper(nn.Module):
    """What the ONNX graph computes: peak heat (0 off the 3x3 maxima) and the box terms."""

    def __init__(self, net: RingNet) -> None:
        super().__init__()
        self.net = net

    def forward(self, rgb: torch.Tensor) -> tuple[torch.Tensor, torch.Tensor]:
        raw = self.net(rgb)
        heat = torch.sigmoid(raw[:, 0:1])
        peaks = heat * (functional.max_pool2d(heat, 3, 1, 1) == heat).to(heat.dtype)
        offset = torch.sigmoid(raw[:, 1:3])
        return peaks, torch.cat([offset, raw[:, 3:5]], dim=1)


def export_onnx(net: RingNet, path: Path, height: int = 240, width: int = 320) -> None:
    """Write the model as ONNX (opset 17) with dynamic batch, height and width."""
    was_training = net.training
    # The wrapper must be in eval mode too: the exporter restores the exported module's mode
    # afterwards, and a fresh module is in training mode, which would flip `net` with it.
    wrapper = ExportWrapper(net).eval()
    dummy = torch.zeros(1, 3, height, width)
    path.parent.mkdir(parents=True, exist_ok=True)
    with warnings.catch_warnings():
        # The legacy exporter is deliberate (see dynamo=False); its deprecation notice is noise.
        warnings.simplefilter("ignore", DeprecationWarning)
        _export(wrapper, dummy, path)
    net.train(was_training)


def _export(module: nn.Module, dummy: torch.Tensor, path: Path) -> None:
    torch.onnx.export(
        module,
        (dummy,),
        str(path),
        input_names=["rgb"],
        output_names=["peaks", "boxes"],
        dynamic_axes={
            "rgb": {0: "batch", 2: "height", 3: "width"},
            "peaks": {0: "batch", 2: "cells_y", 3: "cells_x"},
            "boxes": {0: "batch", 2: "cells_y", 3: "cells_x"},
        },
        opset_version=17,
        dynamo=False,  # the TorchScript exporter needs no onnxscript (REFERENCE section 7)
    )
