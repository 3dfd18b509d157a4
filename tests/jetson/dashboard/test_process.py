"""The dashboard's own process: the shared slots never make the robot's side wait, the server
runs in another process below the robot's loop, and it ends with the daemon's process."""

from __future__ import annotations

import multiprocessing
import os
import subprocess
import sys
import textwrap
import threading
import time
from typing import Any

import pytest

from jetson.dashboard.bridge import Bridge, Latest, Slot
from jetson.threads import HELPER_NICE_STEP


@pytest.fixture
def ctx() -> Any:
    return multiprocessing.get_context("spawn")


def test_a_slot_keeps_the_newest_and_is_read_once(ctx: Any) -> None:
    slot = Slot(ctx, 64)
    assert slot.take(0) is None
    assert slot.put(b"first") and slot.put(b"second")
    seq, data = slot.take(0)
    assert data == b"second" and seq == 2
    assert slot.take(seq) is None
    assert not slot.put(b"x" * 65) and slot.dropped_large == 1
    assert slot.take(seq) is None  # the payload that did not fit changed nothing


def test_a_reader_holding_the_slot_never_makes_the_writer_wait(ctx: Any) -> None:
    slot = Slot(ctx, 64)
    slot._lock.acquire()  # a dashboard stalled in the middle of a read
    try:
        t0 = time.perf_counter()
        written = [slot.put(b"snapshot") for _ in range(1000)]
        spent = time.perf_counter() - t0
    finally:
        slot._lock.release()
    assert not any(written) and slot.dropped_busy == 1000
    assert spent < 0.1, f"1000 refused writes took {spent:.3f} s"
    assert slot.put(b"after") and slot.take(0)[1] == b"after"


def test_the_flag_and_the_latest_value_cross_processes(ctx: Any) -> None:
    bridge = Bridge(ctx, 4096, 4096)
    child = ctx.Process(target=_child_echo, args=(bridge,))
    child.start()
    try:
        deadline = time.monotonic() + 30
        while not bridge.wanted.take():
            assert time.monotonic() < deadline and child.is_alive(), "the child never asked"
            time.sleep(0.01)
        assert bridge.post_snapshot({"n": 7, "rings": [[0.1, 0.2]]})
        child.join(30)
        assert child.exitcode == 0
        assert Latest(bridge.stats).get() == {"seen": 7}
    finally:
        if child.is_alive():
            child.kill()


def _child_echo(bridge: Bridge) -> None:
    latest = Latest(bridge.snapshots)
    bridge.wanted.set()
    deadline = time.monotonic() + 20
    while latest.get() is None and time.monotonic() < deadline:
        time.sleep(0.01)
    import pickle

    bridge.stats.put(pickle.dumps({"seen": latest.value["n"]}))


def test_the_server_runs_in_its_own_process_below_the_loop(live: Any) -> None:
    dashboard = live.service.dashboard
    pid = dashboard._process.pid
    assert pid != os.getpid() and dashboard.alive
    ours = os.getpriority(os.PRIO_PROCESS, 0)
    assert os.getpriority(os.PRIO_PROCESS, pid) == min(19, ours + HELPER_NICE_STEP)
    # The daemon's process has no server thread: only the robot's own threads.
    names = {t.name for t in threading.enumerate()}
    assert "pete-dashboard" not in names


def test_the_dashboard_ends_with_the_daemon_process() -> None:
    """A daemon killed outright (SIGKILL: no stop() runs) takes its dashboard with it."""
    script = textwrap.dedent(
        """
        import sys, time
        from unittest import mock
        from jetson.dashboard.process import live_server
        from jetson.settings import DashboardSettings

        daemon = mock.Mock(frames=None, log=None)
        server = live_server(daemon, None, DashboardSettings(address="127.0.0.1:0")).start()
        print(server._process.pid, flush=True)
        time.sleep(60)
        """
    )
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
        assert not _alive(child_pid), "the dashboard's process outlived the daemon's"
    finally:
        if parent.poll() is None:
            parent.kill()


def _alive(pid: int) -> bool:
    try:
        with open(f"/proc/{pid}/stat") as f:
            return f.read().rsplit(")", 1)[1].split()[0] != "Z"
    except FileNotFoundError:
        return False
