"""What a ring detector returns, the interface every detector meets, and box arithmetic."""

from __future__ import annotations

from dataclasses import dataclass
from typing import Protocol

import numpy as np
from numpy.typing import NDArray

# A Tipping Point ring (sim/field/tipping_point.toml): 4 in across with a 2 in hole, so the tube's
# centre circle has radius 1.5 in and the tube radius 0.5 in.
RING_MAJOR_M = 1.5 * 0.0254
RING_MINOR_M = 0.5 * 0.0254
RING_OUTER_M = 2 * (RING_MAJOR_M + RING_MINOR_M)


@dataclass(frozen=True)
class Detection:
    """An axis-aligned box in pixels of the frame's colour image (x right, y down; x1, y1
    exclusive edges, so width = x1 - x0) and a confidence in [0, 1]."""

    x0: float
    y0: float
    x1: float
    y1: float
    score: float

    @property
    def width(self) -> float:
        return self.x1 - self.x0

    @property
    def height(self) -> float:
        return self.y1 - self.y0

    @property
    def center(self) -> tuple[float, float]:
        return (self.x0 + self.x1) / 2.0, (self.y0 + self.y1) / 2.0

    def as_array(self) -> NDArray[np.float64]:
        return np.array([self.x0, self.y0, self.x1, self.y1])


class Detector(Protocol):
    """A ring detector: BGR image in, boxes out, highest score first.

    `colour_mask` is the pre-filter's HSV mask when the pre-filter ran (a detector may reuse it
    instead of thresholding again); `depth_m` is the aligned depth when the frame has one.
    """

    name: str

    def detect(
        self,
        bgr: NDArray[np.uint8],
        depth_m: NDArray[np.float32] | None = None,
        colour_mask: NDArray[np.uint8] | None = None,
    ) -> list[Detection]: ...


def iou_matrix(a: NDArray[np.float64], b: NDArray[np.float64]) -> NDArray[np.float64]:
    """IoU of every box in a (N, 4) with every box in b (M, 4), boxes as x0, y0, x1, y1."""
    a = np.asarray(a, dtype=np.float64).reshape(-1, 4)
    b = np.asarray(b, dtype=np.float64).reshape(-1, 4)
    ix0 = np.maximum(a[:, None, 0], b[None, :, 0])
    iy0 = np.maximum(a[:, None, 1], b[None, :, 1])
    ix1 = np.minimum(a[:, None, 2], b[None, :, 2])
    iy1 = np.minimum(a[:, None, 3], b[None, :, 3])
    inter = np.clip(ix1 - ix0, 0, None) * np.clip(iy1 - iy0, 0, None)
    area_a = (a[:, 2] - a[:, 0]) * (a[:, 3] - a[:, 1])
    area_b = (b[:, 2] - b[:, 0]) * (b[:, 3] - b[:, 1])
    union = area_a[:, None] + area_b[None, :] - inter
    with np.errstate(divide="ignore", invalid="ignore"):
        out = np.where(union > 0, inter / union, 0.0)
    return out


def non_max_suppression(dets: list[Detection], iou_threshold: float) -> list[Detection]:
    """Greedy NMS: keep the best box, drop the others overlapping it by more than the threshold."""
    if not dets:
        return []
    order = sorted(dets, key=lambda d: d.score, reverse=True)
    boxes = np.array([d.as_array() for d in order])
    ious = iou_matrix(boxes, boxes)
    keep: list[int] = []
    suppressed = np.zeros(len(order), dtype=bool)
    for i in range(len(order)):
        if suppressed[i]:
            continue
        keep.append(i)
        suppressed |= ious[i] > iou_threshold
    return [order[i] for i in keep]
