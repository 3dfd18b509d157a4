"""Pre-filter + detector + localisation: the one call per frame the daemon makes.

    pipeline = Pipeline(make_detector("cnn"), CameraConfig.load(path))
    result = pipeline.process(frame)
    view.rings_robot_xy = result.rings_robot_xy          # jetson.autonomy.spec.RobotView

Positions use the frame's own intrinsics (a RealSense and the simulator's stream send theirs;
image folders and videos get the camera config's) and the camera config's mount.

The HSV colour mask is computed once per frame and shared: the pre-filter (when enabled) masks
the detector's input with it, the classical detector thresholds nothing twice, and the localiser
uses it to pick the ring's own pixels.
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path

import numpy as np
from numpy.typing import NDArray

from jetson.errors import CameraConfigError
from jetson.perception.camera import CameraConfig
from jetson.perception.classical import ClassicalConfig, ClassicalDetector
from jetson.perception.detection import Detection, Detector
from jetson.perception.frame import Frame
from jetson.perception.localise import Localiser, LocaliserConfig, RingEstimate, rings_robot_xy
from jetson.perception.prefilter import PrefilterConfig, prefilter

DETECTORS = ("classical", "cnn")


def make_detector(
    name: str,
    camera: CameraConfig | None = None,
    model: Path | None = None,
    score_threshold: float | None = None,
    classical: ClassicalConfig | None = None,
    providers: Sequence[str] | None = None,
) -> Detector:
    """A detector by name: "classical" or "cnn" (the shipped model unless `model` is given, on
    `providers`, onnxruntime's execution providers: jetson.autonomy.providers)."""
    if name == "classical":
        return ClassicalDetector(classical, camera)
    if name == "cnn":
        from jetson.perception.cnn.runtime import CnnDetector

        return CnnDetector(model, score_threshold, providers=providers)
    raise CameraConfigError(f"unknown detector {name!r}; choose from {DETECTORS}")


@dataclass
class Result:
    detections: list[Detection]
    rings: list[RingEstimate]  # the detections that could be placed, nearest first
    timings_ms: dict[str, float] = field(default_factory=dict)

    @property
    def rings_robot_xy(self) -> NDArray[np.float64]:
        return rings_robot_xy(self.rings)


class Pipeline:
    def __init__(
        self,
        detector: Detector,
        camera: CameraConfig | None = None,
        prefilter_config: PrefilterConfig | None = None,
        localiser_config: LocaliserConfig | None = None,
    ) -> None:
        self.detector = detector
        self.camera = camera or CameraConfig()
        self.prefilter = prefilter_config or PrefilterConfig(enabled=False)
        self.localiser = Localiser(self.camera, localiser_config)

    def process(self, frame: Frame, localiser: Localiser | None = None) -> Result:
        """Detect and place the rings of one frame; `localiser` overrides the pipeline's own
        (a frame taken from another camera mount)."""
        t0 = time.perf_counter()
        image = frame.color
        if self.prefilter.enabled:
            pf = prefilter(image, self.prefilter)
            image, mask = pf.image, pf.colour_mask
        else:
            mask = self.prefilter.window.mask(image)
        t1 = time.perf_counter()
        dets = self.detector.detect(image, frame.depth_m, mask)
        t2 = time.perf_counter()
        rings = (localiser or self.localiser).localise(dets, frame.depth_m, mask, frame.intrinsics)
        t3 = time.perf_counter()
        return Result(
            dets,
            rings,
            {
                "prefilter": (t1 - t0) * 1e3,
                "detect": (t2 - t1) * 1e3,
                "localise": (t3 - t2) * 1e3,
            },
        )
