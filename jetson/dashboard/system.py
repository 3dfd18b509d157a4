"""The Jetson's own health for the dashboard: CPU, memory, temperature, disk left for recordings.

Read from /proc and /sys (Linux, a Jetson's L4T included) by the dashboard's thread once a second;
whatever is not readable on a machine is None, never an error.
"""

from __future__ import annotations

import os
import shutil
import time
from pathlib import Path
from typing import Any

THERMAL = Path("/sys/class/thermal")


def _cpu_times() -> tuple[float, float] | None:
    """(busy, total) jiffies of all CPUs, from /proc/stat."""
    try:
        with open("/proc/stat") as f:
            parts = f.readline().split()
    except OSError:
        return None
    if not parts or parts[0] != "cpu":
        return None
    values = [float(v) for v in parts[1:]]
    idle = values[3] + (values[4] if len(values) > 4 else 0.0)  # idle + iowait
    total = sum(values[:8])
    return total - idle, total


def _meminfo() -> dict[str, float]:
    out = {}
    try:
        with open("/proc/meminfo") as f:
            for line in f:
                key, _, rest = line.partition(":")
                fields = rest.split()
                if fields:
                    out[key] = float(fields[0]) * 1024.0
    except OSError:
        pass
    return out


def _process_cpu_s(pid: int | None) -> float | None:
    """CPU seconds (user + system) of a process; None (this process's own clock is used
    instead) for this process."""
    if pid is None:
        return time.process_time()
    try:
        with open(f"/proc/{pid}/stat") as f:
            fields = f.read().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return None


def _rss_bytes(pid: int | None = None) -> float | None:
    try:
        with open(f"/proc/{pid or 'self'}/statm") as f:
            return float(f.read().split()[1]) * os.sysconf("SC_PAGE_SIZE")
    except (OSError, ValueError, IndexError):
        return None


def temperatures() -> dict[str, float]:
    """Each thermal zone's temperature, degrees C, by its type (CPU-therm, GPU-therm, ...)."""
    out: dict[str, float] = {}
    try:
        zones = sorted(THERMAL.glob("thermal_zone*"))
    except OSError:
        return out
    for z in zones:
        try:
            kind = (z / "type").read_text().strip() or z.name
            milli = float((z / "temp").read_text().strip())
        except (OSError, ValueError):
            continue
        if -40_000 < milli < 150_000:
            out[kind] = round(milli / 1000.0, 1)
    return out


class SystemStats:
    """One reading a second of the machine and the daemon's process (sample() computes rates
    since the previous call). `pid`: the daemon's process when it is not this one (the
    dashboard's own process reads it)."""

    def __init__(self, record_dir: str | None = None, pid: int | None = None) -> None:
        self.record_dir = record_dir
        self.pid = pid
        self._cpu = _cpu_times()
        self._proc = _process_cpu_s(pid)
        self._wall = time.monotonic()

    def sample(self, dashboard_thread_s: float | None = None) -> dict[str, Any]:
        wall = time.monotonic()
        span = max(wall - self._wall, 1e-6)
        cpu = _cpu_times()
        cpu_pct = None
        if cpu is not None and self._cpu is not None and cpu[1] > self._cpu[1]:
            cpu_pct = round(100.0 * (cpu[0] - self._cpu[0]) / (cpu[1] - self._cpu[1]), 1)
        proc = _process_cpu_s(self.pid)
        proc_pct = None
        if proc is not None and self._proc is not None:
            proc_pct = round(100.0 * (proc - self._proc) / span, 1)
        self._cpu, self._proc, self._wall = cpu, proc, wall
        mem = _meminfo()
        total = mem.get("MemTotal")
        avail = mem.get("MemAvailable")
        disk = None
        if self.record_dir:
            where = Path(self.record_dir)
            while not where.exists() and where != where.parent:
                where = where.parent
            try:
                usage = shutil.disk_usage(where)
                disk = {"path": str(self.record_dir), "free_gb": round(usage.free / 1e9, 2),
                        "total_gb": round(usage.total / 1e9, 2)}  # fmt: skip
            except OSError:
                disk = None
        temps = temperatures()
        rss = _rss_bytes(self.pid)
        return {
            "kind": "jetson",
            "cpu_pct": cpu_pct,
            "cpus": os.cpu_count(),
            "load": round(os.getloadavg()[0], 2) if hasattr(os, "getloadavg") else None,
            "process_cpu_pct": proc_pct,
            "dashboard_cpu_pct": None
            if dashboard_thread_s is None
            else round(100.0 * dashboard_thread_s / span, 2),
            "rss_mb": None if rss is None else round(rss / 1e6, 1),
            "mem_used_pct": None
            if not total or avail is None
            else round(100.0 * (1.0 - avail / total), 1),
            "mem_total_gb": None if not total else round(total / 1e9, 2),
            "temps_c": temps,
            "temp_max_c": max(temps.values()) if temps else None,
            "disk": disk,
        }
