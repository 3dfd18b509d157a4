"""A live daemon with its dashboard for the dashboard's tests (conftest.py's fixtures use it):
jetson.testing.FakeBrain on a pty, the shipped policy, a camera thread over synthetic frames
(jetson.perception.synthetic, the classical detector), a session recording, and the dashboard on
a free loopback port."""

from __future__ import annotations

import contextlib
import io
import json
import threading
import time
from collections.abc import Callable, Iterator
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from jetson.autonomy.camera import Intrinsics
from jetson.camera_feed import CameraWorker
from jetson.clock import MonotonicClock
from jetson.log import EventLog
from jetson.perception.pipeline import make_pipeline
from jetson.service import Service, build
from jetson.settings import CameraSettings, Settings
from jetson.testing import FakeBrain


def wait_for(cond: Callable[[], Any], timeout_s: float = 10.0) -> Any:
    deadline = time.monotonic() + timeout_s
    while True:
        got = cond()
        if got:
            return got
        if time.monotonic() > deadline:
            return got
        time.sleep(0.01)


class SyntheticCamera:
    """Pre-rendered synthetic frames (rings on a floor, with depth), served in turn at `fps`."""

    def __init__(self, n: int = 3, fps: float = 20.0, seed: int = 0) -> None:
        from jetson.perception.synthetic import random_frame

        rng = np.random.default_rng(seed)
        k = Intrinsics().scaled(320, 240)
        self.frames = [random_frame(rng, k, max_rings=5, index=i).frame for i in range(n)]
        self.period = 1.0 / fps
        self.reads = 0

    def open(self) -> SyntheticCamera:
        return self

    def read(self) -> Any:
        time.sleep(self.period)
        frame = self.frames[self.reads % len(self.frames)]
        self.reads += 1
        return frame

    def close(self) -> None:
        pass


@dataclass
class Live:
    service: Service
    brain: FakeBrain
    camera: CameraWorker | None
    out: io.StringIO
    record_dir: Path

    @property
    def daemon(self) -> Any:
        return self.service.daemon

    @property
    def url(self) -> str:
        return self.service.dashboard.url

    @property
    def dashboard_ready(self) -> bool:
        dashboard = self.service.dashboard
        return dashboard is not None and dashboard.ready

    def records(self, event: str | None = None) -> list[dict[str, Any]]:
        lines = [json.loads(x) for x in self.out.getvalue().splitlines() if x]
        return [r for r in lines if event is None or r["event"] == event]


@contextlib.contextmanager
def live_stack(
    tmp: Path,
    dashboard: str | None = "127.0.0.1:0",
    camera: bool = True,
    frames_hz: float = 3.0,
    make_state: Any = None,
    decision: dict[str, Any] | None = None,
) -> Iterator[Live]:
    brain = FakeBrain(**({"make_state": make_state} if make_state else {}))
    out = io.StringIO()
    clock = MonotonicClock()
    worker = None
    if camera:
        _, pipeline = make_pipeline(CameraSettings(detector="classical"))
        source = SyntheticCamera()
        worker = CameraWorker(source.open, pipeline.process, clock, EventLog(out), retry_s=0.05)
    settings = Settings().with_overrides(
        link={"port": brain.path},
        camera={"enabled": False},
        record={"dir": str(tmp / "sessions"), "frames_hz": frames_hz, "compress": False},
        log={"summary": False, "level": "debug"},
        dashboard={"address": dashboard} if dashboard else {},
        **({"decision": decision} if decision else {}),
    )
    service = build(settings, clock, log_stream=out, perception=worker)
    if worker is not None:
        worker.start()
    brain.start()
    thread = threading.Thread(target=service.run, name="daemon", daemon=True)
    thread.start()
    try:
        yield Live(service, brain, worker, out, tmp / "sessions")
    finally:
        service.stop()
        thread.join(5.0)
        if worker is not None:
            worker.stop(2.0)
        brain.close()
