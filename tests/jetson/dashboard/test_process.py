"""The dashboard's own process: the flag and the snapshots cross between the processes, the
server runs in another process below the robot's loop, and it ends with the daemon's process.
The slots themselves are tested in tests/jetson/test_slots.py."""

from __future__ import annotations

import multiprocessing
import os
import threading
import time
from typing import Any

import pytest

from jetson.dashboard.bridge import Bridge
from jetson.slots import Latest
from jetson.threads import HELPER_NICE_STEP


@pytest.fixture
def ctx() -> Any:
    return multiprocessing.get_context("spawn")


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
    pid = dashboard.pid
    assert pid != os.getpid() and dashboard.alive
    ours = os.getpriority(os.PRIO_PROCESS, 0)
    assert os.getpriority(os.PRIO_PROCESS, pid) == min(19, ours + HELPER_NICE_STEP)
    # The daemon's process has no server thread: only the robot's own threads.
    names = {t.name for t in threading.enumerate()}
    assert "pete-dashboard" not in names
