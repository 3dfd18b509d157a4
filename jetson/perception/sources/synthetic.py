"""Synthetic frames as a live camera would deliver them: rings on a floor with depth
(jetson.perception.synthetic), at a steady rate, forever.

For trying the daemon, the dashboard and the benchmarks without a camera:
`pete-jetson run --camera-source synthetic` (30 frames a second) or `synthetic:FPS`.
"""

from __future__ import annotations

import time

import numpy as np

from jetson.autonomy.camera import CameraMount, Intrinsics
from jetson.perception.frame import Frame
from jetson.perception.sources.base import FrameSource

DEFAULT_FPS = 30.0
SCENES = 8  # rendered once, served in turn


class SyntheticSource(FrameSource):
    def __init__(
        self,
        fps: float = DEFAULT_FPS,
        intrinsics: Intrinsics | None = None,
        mount: CameraMount | None = None,
        seed: int = 1,
    ) -> None:
        from jetson.perception.synthetic import random_frame

        if not 0 < fps <= 1000:
            raise ValueError(f"synthetic frames a second must be in (0, 1000], not {fps}")
        rng = np.random.default_rng(seed)
        self._frames = [random_frame(rng, intrinsics, mount, index=i).frame for i in range(SCENES)]
        self.period_s = 1.0 / fps
        self.description = f"synthetic frames, {fps:g} a second"
        self._index = 0
        self._due = time.monotonic()

    def read(self) -> Frame:
        self._due += self.period_s
        wait = self._due - time.monotonic()
        if wait > 0:
            time.sleep(wait)
        else:
            self._due = time.monotonic()  # fell behind: keep the rate from now on
        f = self._frames[self._index % SCENES]
        self._index += 1
        return Frame(f.color, f.depth_m, f.intrinsics, time.monotonic(), self._index)
