"""Priorities of the daemon's helper threads.

On Linux each thread is scheduled on its own and has its own niceness. The control loop (the
process's main thread, at the unit's Nice=-10) must answer every State within milliseconds;
the camera thread (tens of milliseconds of detection a second) and the recording's writer
(encoding and writing) need throughput, not promptness. Each lowers its own priority by
HELPER_NICE_STEP when it starts, so that when it and the loop want the same core, the loop
runs first; whatever the loop leaves is theirs. On a 2-core machine this takes the camera's
cost off the loop's tail (docs/notes/2026-11-26-dashboard-latency.md).
"""

from __future__ import annotations

import contextlib
import os
import sys
import threading

HELPER_NICE_STEP = 10  # the helper threads' niceness above the process's (19 at most)


def lower_this_thread(step: int = HELPER_NICE_STEP) -> int | None:
    """Raise the calling thread's niceness by `step` (never above 19); the niceness it now has,
    or None where threads have no niceness of their own (not Linux)."""
    if not sys.platform.startswith("linux"):  # elsewhere a thread id is not a process id
        return None
    tid = threading.get_native_id()
    with contextlib.suppress(OSError):
        now = os.getpriority(os.PRIO_PROCESS, tid)
        os.setpriority(os.PRIO_PROCESS, tid, min(19, now + step))
        return os.getpriority(os.PRIO_PROCESS, tid)
    return None
