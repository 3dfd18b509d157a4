"""Keeping the CPUs quick to wake while the daemon runs: a PM QoS request on the CPU's wake-up
latency.

Between two States the daemon's loop sleeps (4 to 20 ms), and an idle CPU goes into an idle
state it must climb out of when the next State arrives: a Jetson's deep CPU idle states, or a
virtual machine's halted vCPU, which the host must schedule again. The first decision after
the nap then runs slowly, and on such machines those wake-ups, not the decision's own work,
make the daemon's latency tail (docs/notes/2026-11-26-dashboard-latency.md: on a 16-core VM,
decide() after a 4-ms nap had a p99 of 4 to 7 ms against 1.6 ms back to back).

Linux's answer is a PM QoS request: while a process holds /dev/cpu_dma_latency open with a value
written to it, the kernel keeps every CPU in idle states that wake within that many
microseconds (0: the polling idle state only; jetson_clocks and cyclictest use the same
request). It costs power: idle CPUs spin instead of sleeping. `[system] cpu_wake_latency_us`
sets it (-1: no request). The request ends when the file is closed, including when the process
dies. Opening the file needs root or the udev rule jetson/deploy/99-pete-brain.rules installs;
a daemon that cannot hold it logs why and runs without it.
"""

from __future__ import annotations

import os
import struct

DEVICE = "/dev/cpu_dma_latency"


class CpuWakeLatency:
    """One PM QoS request on the CPUs' wake-up latency, held from hold() until release()."""

    def __init__(self, microseconds: int, device: str = DEVICE) -> None:
        self.microseconds = microseconds
        self.device = device
        self._fd: int | None = None

    @property
    def held(self) -> bool:
        return self._fd is not None

    def hold(self) -> str | None:
        """Make the request: None when it is held, else why it is not (nothing raised)."""
        if self._fd is not None or self.microseconds < 0:
            return None
        try:
            fd = os.open(self.device, os.O_WRONLY | os.O_CLOEXEC)
        except OSError as exc:
            return f"cannot open {self.device}: {exc.strerror or exc}"
        try:
            os.write(fd, struct.pack("=i", self.microseconds))
        except OSError as exc:
            os.close(fd)
            return f"cannot write {self.device}: {exc.strerror or exc}"
        self._fd = fd
        return None

    def release(self) -> None:
        if self._fd is not None:
            os.close(self._fd)
            self._fd = None
