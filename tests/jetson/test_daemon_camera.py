"""The daemon's camera thread on the real perception path (jetson.perception: a frame stream over
a socket, the classical detector, localisation), as `pete-jetson run` builds it: rings seen in
rendered frames reach the policy's observation, and a stream that dies and comes back is
survived."""

from __future__ import annotations

import io
import threading
import time
from pathlib import Path

import numpy as np
import pytest

from jetson.autonomy.camera import CameraMount, Intrinsics
from jetson.clock import MonotonicClock
from jetson.perception.sources.stream import FrameStreamServer
from jetson.perception.synthetic import Ring, Scene, render
from jetson.service import build
from jetson.settings import Settings
from jetson.testing import FakeBrain, ProbePolicy

# A daemon or camera thread that dies of an exception fails the test, not just warns.
pytestmark = pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning")
UNIT = 1.8288
TRUTH = np.array([[0.15, 0.75], [-0.25, 1.1]])


def wait_for(cond, timeout_s: float = 10.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while not cond():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True


class Streamer:
    """Serves one rendered frame every 30 ms to whoever connects, until stopped."""

    def __init__(self, address: str, frame) -> None:
        self.server = FrameStreamServer(address)
        self.frame = frame
        self._stop = threading.Event()
        self.sent = 0
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while not self._stop.is_set():
            if not self.server.connected and not self.server.wait_for_client(0.05):
                continue
            self.frame.index = self.sent
            if self.server.send(self.frame):
                self.sent += 1
            self._stop.wait(0.03)

    def close(self) -> None:
        self._stop.set()
        self._thread.join(2.0)
        self.server.close()


def test_rings_from_the_camera_stream_reach_the_policy_and_a_dead_stream_is_survived(
    tmp_path: Path,
) -> None:
    intr = Intrinsics().scaled(320, 240)
    scene = Scene(rings=[Ring(float(x), float(y)) for x, y in TRUTH])
    frame = render(scene, intr, CameraMount(), None).frame
    address = f"unix:{tmp_path / 'frames.sock'}"
    brain = FakeBrain(link_path=tmp_path / "pete-brain").start()
    streamer = Streamer(address, frame)
    policy = ProbePolicy()
    policy.keep_observations = True
    settings = Settings().with_overrides(
        link={"port": brain.path},
        camera={"source": address, "detector": "classical", "retry_s": 0.1},
        decision={"perception_max_age_s": 0.2},
        record={"dir": ""},
    )
    out = io.StringIO()
    service = build(settings, MonotonicClock(), out, None, policy=policy)
    two_rings = 2 / 10 * 2.0
    runner = threading.Thread(target=service.run, daemon=True)
    runner.start()
    try:
        assert wait_for(
            lambda: (
                brain.commands and brain.commands[-1].command.angular == pytest.approx(two_rings)
            )
        )
        obs = policy.observations[-1]
        slots = obs[6:36].reshape(10, 3)
        assert slots[:2, 2].tolist() == [1.0, 1.0] and slots[2:, 2].sum() == 0
        seen = slots[:2, :2] * UNIT
        assert np.allclose(seen, TRUTH, atol=0.05), seen  # nearest first, within 5 cm
        streamer.close()  # the simulator (or the camera) goes away
        assert wait_for(lambda: brain.commands[-1].command.angular == 0.0)
        assert brain.commands[-1].command.linear != 0.0  # still driving, seeing no rings
        streamer = Streamer(address, frame)  # and comes back
        assert wait_for(lambda: brain.commands[-1].command.angular == pytest.approx(two_rings))
    finally:
        service.stop()
        runner.join(5.0)
        streamer.close()
        brain.close()
    assert service.camera.opens >= 2 and service.camera.frames >= 2
    log = out.getvalue()
    assert '"camera_error"' in log or '"camera_end"' in log
    assert '"camera_open"' in log
