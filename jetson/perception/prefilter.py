"""The original team's GRIP pre-filter: an HSV window, a box-blurred mask, the image masked.

Their pipeline (REFERENCE section 1) thresholds the image to the purple HSV window, box-blurs with
radius 17 (ksize 35) and masks the image with bitwise_and. We blur the binary mask, not the image:
a box blur of the mask spreads every in-window pixel into a 35x35 neighbourhood, so the masked
image keeps each ring whole with a margin of context (its shading, its hole, the floor around it)
and blacks out everything far from purple. Blurring the image first instead would smear small,
distant rings into the floor colour before the threshold sees them.
"""

from __future__ import annotations

from dataclasses import asdict, dataclass, field
from typing import Any

import cv2
import numpy as np
from numpy.typing import NDArray

from jetson.errors import CameraConfigError


@dataclass(frozen=True)
class HsvWindow:
    """Inclusive HSV bounds on OpenCV's scales (H 0-180, S and V 0-255)."""

    h: tuple[float, float] = (123.02, 169.30)
    s: tuple[float, float] = (38.98, 192.22)
    v: tuple[float, float] = (75.67, 255.0)

    def __post_init__(self) -> None:
        for name, top in (("h", 180.0), ("s", 255.0), ("v", 255.0)):
            lo, hi = getattr(self, name)
            if not 0.0 <= lo <= hi <= top:
                raise CameraConfigError(f"HSV {name} window must satisfy 0 <= low <= high <= {top}")

    def bounds(self) -> tuple[NDArray[np.uint8], NDArray[np.uint8]]:
        """Integer bounds for cv2.inRange: a pixel is in when its value lies in [low, high]."""
        lo = np.array([np.ceil(self.h[0]), np.ceil(self.s[0]), np.ceil(self.v[0])], np.uint8)
        hi = np.array([np.floor(self.h[1]), np.floor(self.s[1]), np.floor(self.v[1])], np.uint8)
        return lo, hi

    def mask(self, bgr: NDArray[np.uint8]) -> NDArray[np.uint8]:
        """255 where the pixel's colour is inside the window, else 0."""
        hsv = cv2.cvtColor(bgr, cv2.COLOR_BGR2HSV)
        lo, hi = self.bounds()
        return cv2.inRange(hsv, lo, hi)


@dataclass(frozen=True)
class PrefilterConfig:
    enabled: bool = True
    window: HsvWindow = field(default_factory=HsvWindow)
    blur_ksize: int = 35  # box blur of the mask, at 640x480; scaled with the image width
    reference_width: int = 640

    def __post_init__(self) -> None:
        if self.blur_ksize < 1:
            raise CameraConfigError(f"blur_ksize must be at least 1, got {self.blur_ksize}")

    def ksize_for(self, width: int) -> int:
        k = round(self.blur_ksize * width / self.reference_width)
        return max(1, k | 1)  # odd, so the box is centred on its pixel

    def to_dict(self) -> dict[str, Any]:
        return asdict(self)

    @classmethod
    def from_dict(cls, data: dict[str, Any]) -> PrefilterConfig:
        data = dict(data)
        known = {"enabled", "window", "blur_ksize", "reference_width"}
        if set(data) - known:
            raise CameraConfigError(f"unknown pre-filter keys {sorted(set(data) - known)}")
        w = data.pop("window", {})
        try:
            window = HsvWindow(**{k: tuple(v) for k, v in w.items()})
            return cls(window=window, **data)
        except TypeError as exc:
            raise CameraConfigError(f"bad pre-filter config: {exc}") from exc


@dataclass
class Prefiltered:
    image: NDArray[np.uint8]  # the input with everything far from the window blacked out
    colour_mask: NDArray[np.uint8]  # 255 where the pixel itself is in the HSV window
    region: NDArray[np.uint8]  # 255 where the blurred mask is non-zero (what `image` keeps)


def prefilter(bgr: NDArray[np.uint8], config: PrefilterConfig) -> Prefiltered:
    mask = config.window.mask(bgr)
    k = config.ksize_for(bgr.shape[1])
    # A box blur of a 0/255 mask is non-zero exactly where a box around the pixel holds an
    # in-window pixel, i.e. a dilation by a k x k square.
    region = cv2.dilate(mask, np.ones((k, k), np.uint8)) if k > 1 else mask
    image = cv2.bitwise_and(bgr, bgr, mask=region)
    return Prefiltered(image=image, colour_mask=mask, region=region)
