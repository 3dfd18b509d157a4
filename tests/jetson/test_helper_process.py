"""The daemon's helper processes (jetson/helper_process.py: the camera's and the dashboard's)
end with the daemon's process, even when it is killed outright, and a child that never answers
is reported, not waited for forever."""

from __future__ import annotations

import os
import subprocess
import sys
import textwrap
import time
from multiprocessing.connection import Connection

import pytest

from jetson.helper_process import Helper

CAMERA = """
from jetson.camera_process import CameraProcess
from jetson.log import EventLog
from jetson.settings import CameraSettings

settings = CameraSettings(source={folder!r}, detector="classical", retry_s=0.05)
helper = CameraProcess(settings, EventLog(io.StringIO()))
helper.start()
"""

DASHBOARD = """
from unittest import mock
from jetson.dashboard.process import live_server
from jetson.settings import DashboardSettings

daemon = mock.Mock(frames=None, log=None)
helper = live_server(daemon, None, DashboardSettings(address="127.0.0.1:0")).start()
"""


@pytest.mark.parametrize("starts", [CAMERA, DASHBOARD], ids=["camera", "dashboard"])
def test_a_helper_ends_with_the_daemon_process(starts: str, tmp_path: object) -> None:
    """A daemon killed outright (SIGKILL: no stop() runs) takes its helper's process with it."""
    script = "import io, time\n" + textwrap.dedent(starts).format(folder=str(tmp_path))
    script += "print(helper.pid, flush=True)\ntime.sleep(60)\n"
    parent = subprocess.Popen(
        [sys.executable, "-c", script], stdout=subprocess.PIPE, text=True, cwd=os.getcwd()
    )
    try:
        assert parent.stdout is not None
        child_pid = int(parent.stdout.readline())
        assert _alive(child_pid)
        parent.kill()
        parent.wait(10)
        deadline = time.monotonic() + 5
        while _alive(child_pid) and time.monotonic() < deadline:
            time.sleep(0.05)
        assert not _alive(child_pid), "the helper's process outlived the daemon's"
    finally:
        if parent.poll() is None:
            parent.kill()


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False


def _silent(conn: Connection) -> None:
    time.sleep(30)


def test_a_child_that_never_answers_is_reported_and_stopped() -> None:
    helper = Helper.spawn(_silent, (), "pete-test")
    t0 = time.monotonic()
    assert helper.await_reply(0.5) is None
    assert time.monotonic() - t0 < 5
    helper.stop(0.5)
    assert not helper.alive
