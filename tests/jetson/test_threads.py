"""The daemon's helper threads (camera, recording) lower their own priority, not the loop's."""

from __future__ import annotations

import io
import os
import sys
import threading
import time
from pathlib import Path

import pytest

from jetson.camera_feed import CameraWorker
from jetson.clock import MonotonicClock
from jetson.log import EventLog
from jetson.threads import HELPER_NICE_STEP, lower_this_thread

pytestmark = pytest.mark.skipif(not sys.platform.startswith("linux"), reason="Linux threads")


def _nice(tid: int | None = None) -> int:
    return os.getpriority(os.PRIO_PROCESS, tid or threading.get_native_id())


def test_a_thread_lowers_only_itself() -> None:
    main_before = _nice()
    seen: dict[str, int | None] = {}

    def helper() -> None:
        before = _nice()
        seen["got"] = lower_this_thread()
        seen["expected"] = min(19, before + HELPER_NICE_STEP)
        seen["now"] = _nice()

    th = threading.Thread(target=helper)
    th.start()
    th.join()
    assert seen["got"] == seen["expected"] == seen["now"]
    assert _nice() == main_before  # the loop's thread keeps its priority


def test_the_camera_thread_runs_below_the_loop(tmp_path: Path) -> None:
    class Frames:
        def read(self) -> object:
            time.sleep(0.01)
            return type("F", (), {"timestamp_s": 0.0, "index": 0})()

        def close(self) -> None:
            pass

    tids: list[int] = []

    def process(frame: object) -> object:
        tids.append(threading.get_native_id())
        return type("R", (), {"rings_robot_xy": []})()

    worker = CameraWorker(Frames, process, MonotonicClock(), EventLog(io.StringIO()))
    worker.start()
    try:
        deadline = time.monotonic() + 10
        while not tids and time.monotonic() < deadline:
            time.sleep(0.01)
        assert tids
        assert _nice(tids[0]) == min(19, _nice() + HELPER_NICE_STEP)
    finally:
        worker.stop()
