"""The camera in a process of its own (jetson/camera_process.py): its results, frame copies and log
lines reach the daemon's process; a model that cannot load fails start(); a camera that cannot
open is retried and logged, never raised; and the process ends with the daemon's."""

from __future__ import annotations

import io
import json
import time
from pathlib import Path
from typing import Any

import cv2
import numpy as np
import pytest

from jetson.camera_process import CameraProcess
from jetson.errors import CameraProcessError
from jetson.log import EventLog
from jetson.settings import CameraSettings


def image_folder(root: Path, n: int = 4) -> Path:
    """Synthetic frames (rings on a floor, with depth) as a dataset folder: images/, depth/."""
    from jetson.autonomy.camera import Intrinsics
    from jetson.perception.frame import depth_to_mm
    from jetson.perception.synthetic import random_frame

    rng = np.random.default_rng(3)
    k = Intrinsics().scaled(320, 240)
    (root / "images").mkdir(parents=True)
    (root / "depth").mkdir()
    for i in range(n):
        frame = random_frame(rng, k, max_rings=4, index=i).frame
        cv2.imwrite(str(root / "images" / f"{i:03d}.png"), frame.color)
        cv2.imwrite(str(root / "depth" / f"{i:03d}.png"), depth_to_mm(frame.depth_m))
    return root


def lines(out: io.StringIO) -> list[dict[str, Any]]:
    return [json.loads(x) for x in out.getvalue().splitlines() if x.startswith("{")]


def wait_for(cond: Any, timeout_s: float = 30.0) -> Any:
    deadline = time.monotonic() + timeout_s
    while not (got := cond()) and time.monotonic() < deadline:
        time.sleep(0.02)
    return got


def test_results_frames_and_log_lines_reach_the_daemon(tmp_path: Path) -> None:
    folder = image_folder(tmp_path / "frames")
    out = io.StringIO()
    settings = CameraSettings(source=str(folder), detector="classical", retry_s=0.05)
    camera = CameraProcess(settings, EventLog(out))
    tap = camera.frame_copies(0.0, 160)
    camera.start()
    try:
        assert camera.alive
        first = wait_for(camera.latest)
        assert first is not None and first.error is None
        # Stamped on the machine's monotonic clock, which both processes read.
        assert abs(time.monotonic() - first.stamp_s) < 5.0
        assert wait_for(lambda: camera.frames >= 8), camera.counters
        later = camera.latest()
        assert later is not None and later.id > first.id
        assert wait_for(lambda: any(len(r) for r in [camera.latest().rings_robot_xy]))
        view = wait_for(lambda: tap.newest)
        assert view is not None and view.color.shape[1] == 160 and view.depth_m is not None
        assert wait_for(lambda: tap.get(tap.newest.id) is not None)
        records = wait_for(lambda: [r for r in lines(out) if r.get("event") == "camera_open"])
        assert records and "images in" in records[0]["msg"]
    finally:
        camera.stop()
    assert not camera.alive


def test_a_model_that_cannot_load_fails_start(tmp_path: Path) -> None:
    settings = CameraSettings(source="realsense", model=str(tmp_path / "missing.onnx"))
    camera = CameraProcess(settings, EventLog(io.StringIO()))
    with pytest.raises(CameraProcessError, match=r"missing\.onnx"):
        camera.start(timeout_s=60)
    assert not camera.alive


def test_the_detector_runs_in_the_cameras_process_and_its_provider_is_logged(
    tmp_path: Path,
) -> None:
    """The shipped CNN detector, built in the camera's process with this machine's onnxruntime:
    the daemon's log says which provider it runs on, as the camera thread's build does."""
    out = io.StringIO()
    settings = CameraSettings(source=str(image_folder(tmp_path / "frames")), retry_s=0.05)
    camera = CameraProcess(settings, EventLog(out))
    camera.start(timeout_s=60)
    try:
        lines_ = [r for r in lines(out) if r.get("event") == "onnxruntime"]
        assert camera.provider is not None and camera.provider.endswith("ExecutionProvider")
        assert [r["msg"] for r in lines_] == [f"ring detector runs on {camera.provider}"]
        assert wait_for(lambda: camera.frames >= 2), camera.counters
    finally:
        camera.stop()


def test_a_camera_that_cannot_open_is_retried_and_logged(tmp_path: Path) -> None:
    out = io.StringIO()
    settings = CameraSettings(
        source=str(tmp_path / "no-such-folder"), detector="classical", retry_s=0.05
    )
    camera = CameraProcess(settings, EventLog(out))
    camera.start()
    try:
        errors = wait_for(lambda: camera.latest() is None and [
            r for r in lines(out) if r.get("event") == "camera_error"
        ])  # fmt: skip
        assert errors and "no-such-folder" in errors[0]["msg"]
        assert camera.alive and camera.latest() is None
    finally:
        camera.stop()
