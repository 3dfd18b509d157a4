"""Pre-filter + detector + localisation: the one call per frame the daemon makes.

    pipeline = Pipeline(make_detector("cnn"), CameraConfig.load(path))
    result = pipeline.process(frame)
    view.rings_robot_xy = result.rings_robot_xy          # jetson.autonomy.spec.RobotView

Positions use the frame's own intrinsics (a RealSense and the simulator's stream send theirs;
image folders and videos get the camera config's) and the camera config's mount.

The HSV colour mask is computed once per frame and shared: the pre-filter (when enabled) masks
the detector's input with it, the classical detector thresholds nothing twice, and the localiser
uses it to pick the ring's own pixels.

With a goal detector (jetson/perception/goals.py; `[camera] goals`, on for the scripted
alliance) the pipeline also finds the mobile goals in the frame's colour image, unfiltered by the
pre-filter, with the frame's intrinsics: `result.goals_robot`, (N, 3) x, y robot frame and colour
code, what jetson.autonomy.alliance.AllianceInputs.goals_robot takes (none from a frame without
depth: a goal is placed with its depth). Without one it reports no goals, and the rings are
found exactly as before.

With a robot detector (jetson/perception/robots.py; `[camera] robots`, on for a policy whose
observation reads the robots it sees) the pipeline finds the robots by their licence plates the
same way: `result.robots_robot`, (N, 3) x, y robot frame and alliance code
(ROBOT_ALLIANCE_CODES), none from a frame without depth (a plate is placed with its depth).
"""

from __future__ import annotations

import time
from collections.abc import Sequence
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
from numpy.typing import NDArray

from jetson.errors import CameraConfigError
from jetson.perception.camera import CameraConfig
from jetson.perception.classical import ClassicalConfig, ClassicalDetector
from jetson.perception.detection import Detection, Detector
from jetson.perception.frame import Frame
from jetson.perception.goals import GoalDetector, GoalSighting, goals_robot
from jetson.perception.localise import Localiser, LocaliserConfig, RingEstimate, rings_robot_xy
from jetson.perception.prefilter import PrefilterConfig, prefilter
from jetson.perception.robots import RobotDetector, RobotSighting

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
    goals: list[GoalSighting] = field(default_factory=list)  # with a goal detector
    robots: list[RobotSighting] = field(default_factory=list)  # with a robot detector

    @property
    def rings_robot_xy(self) -> NDArray[np.float64]:
        return rings_robot_xy(self.rings)

    @property
    def goals_robot(self) -> NDArray[np.float64]:
        return goals_robot(self.goals)

    @property
    def robots_robot(self) -> NDArray[np.float64]:
        """(N, 3): x, y robot frame and alliance code (jetson.perception.robots)."""
        return RobotDetector.as_array(self.robots)


class Pipeline:
    def __init__(
        self,
        detector: Detector,
        camera: CameraConfig | None = None,
        prefilter_config: PrefilterConfig | None = None,
        localiser_config: LocaliserConfig | None = None,
        goal_detector: GoalDetector | None = None,
        robot_detector: RobotDetector | None = None,
    ) -> None:
        self.detector = detector
        self.camera = camera or CameraConfig()
        self.prefilter = prefilter_config or PrefilterConfig(enabled=False)
        self.localiser = Localiser(self.camera, localiser_config)
        self.goal_detector = goal_detector
        self.robot_detector = robot_detector

    def process(self, frame: Frame, localiser: Localiser | None = None) -> Result:
        """Detect and place the rings of one frame; `localiser` overrides the pipeline's own
        (a frame taken from another camera mount; the goals and robots are placed with their
        detectors' own mount)."""
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
        timings = {
            "prefilter": (t1 - t0) * 1e3,
            "detect": (t2 - t1) * 1e3,
            "localise": (t3 - t2) * 1e3,
        }
        goals: list[GoalSighting] = []
        robots: list[RobotSighting] = []
        # Goals and plates are placed with their depth: a frame without a depth image shows none.
        if frame.depth_m is not None:
            if self.goal_detector is not None:
                goals = self.goal_detector.detect(frame.color, frame.depth_m, frame.intrinsics)
                timings["goals"] = (time.perf_counter() - t3) * 1e3
            if self.robot_detector is not None:
                t4 = time.perf_counter()
                robots = self.robot_detector.detect(frame.color, frame.depth_m, frame.intrinsics)
                timings["robots"] = (time.perf_counter() - t4) * 1e3
        return Result(dets, rings, timings, goals, robots)


def make_pipeline(camera_settings: Any) -> tuple[CameraConfig, Pipeline]:
    """The pipeline as `[camera]` (jetson.settings.CameraSettings) configures it: (camera
    config, Pipeline), with the goal detector when `goals` is true and the robot detector when
    `robots` is (jetson.service.make_camera settles both from the whole settings and the
    policy: Settings.detects_goals, Settings.detects_robots; None here is off). A missing model
    or a bad camera config fails here, at start-up."""
    cs = camera_settings
    camera = CameraConfig.load(Path(cs.config)) if cs.config else CameraConfig()
    model = Path(cs.model) if cs.model else None
    detector = make_detector(cs.detector, camera, model, cs.threshold, providers=cs.providers)
    goals = GoalDetector(camera) if cs.goals else None
    robots = RobotDetector(camera) if cs.robots else None
    return camera, Pipeline(
        detector,
        camera,
        PrefilterConfig(enabled=cs.prefilter),
        goal_detector=goals,
        robot_detector=robots,
    )
