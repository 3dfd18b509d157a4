"""What every benchmark shares: timing, the result table, and bench/results/NAME.json.

A result file always has the same shape, so that tools can compare runs without knowing the
benchmark:

    {"benchmark": NAME,
     "metrics": {KEY: number},
     "targets": {KEY: {"target": number, "op": ">=" or "<=", "met": bool}},
     "machine": "CPU model, N cores, Python X.Y.Z, OS",
     "date": "YYYY-MM-DD"}

`python -m bench.report` turns every such file into RESULTS.md.
"""

from __future__ import annotations

import datetime
import json
import math
import os
import platform
import statistics
import subprocess
import time
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Literal

RESULTS_DIR = Path(__file__).resolve().parent / "results"

Op = Literal[">=", "<="]
OPS: tuple[Op, ...] = (">=", "<=")


def machine_description() -> str:
    """One line naming what produced the numbers; timings mean little without it."""
    return (
        f"{_cpu_model()}, {os.cpu_count() or '?'} cores, "
        f"Python {platform.python_version()}, {_os_name()}"
    )


def _cpu_model() -> str:
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                key, _, value = line.partition(":")
                # x86 says "model name"; some ARM kernels (a Jetson) only say "Hardware" or nothing.
                if key.strip() in ("model name", "Hardware", "cpu model") and value.strip():
                    return value.strip()
    except OSError:
        pass
    return platform.processor() or platform.machine() or "unknown CPU"


def _os_name() -> str:
    try:
        with open("/etc/os-release") as f:
            for line in f:
                if line.startswith("PRETTY_NAME="):
                    return line.split("=", 1)[1].strip().strip('"')
    except OSError:
        pass
    return f"{platform.system()} {platform.release()}"


def median_ns(fn: Callable[[], object], *, number: int = 1, repeats: int = 7) -> float:
    """Median wall time of one call of `fn`, in nanoseconds.

    Each repeat times `number` back-to-back calls and divides, so that calls far shorter than the
    clock's resolution still measure; the median of the repeats ignores a repeat the OS preempted.
    """
    if number < 1 or repeats < 1:
        raise ValueError("number and repeats must be at least 1")
    samples = []
    for _ in range(repeats):
        start = time.perf_counter_ns()
        for _ in range(number):
            fn()
        samples.append((time.perf_counter_ns() - start) / number)
    return statistics.median(samples)


def per_second(ns_per_call: float) -> float:
    return 1e9 / ns_per_call if ns_per_call > 0 else math.inf


@dataclass
class Result:
    """Collects a benchmark's metrics and targets, then reports and saves them."""

    name: str
    metrics: dict[str, float] = field(default_factory=dict)
    targets: dict[str, tuple[float, Op]] = field(default_factory=dict)

    def add(self, key: str, value: float) -> None:
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise TypeError(f"metric {key!r} must be a number, got {value!r}")
        if not math.isfinite(value):
            raise ValueError(f"metric {key!r} is {value}, which JSON cannot hold")
        self.metrics[key] = value

    def target(self, key: str, value: float, op: Op) -> None:
        if op not in OPS:
            raise ValueError(f"target {key!r}: op must be one of {OPS}, got {op!r}")
        self.targets[key] = (value, op)

    def met(self) -> dict[str, bool]:
        """Whether each target holds; a target whose metric was never measured is not met."""
        out = {}
        for key, (goal, op) in self.targets.items():
            value = self.metrics.get(key)
            if value is None:
                out[key] = False
            else:
                out[key] = value >= goal if op == ">=" else value <= goal
        return out

    @property
    def all_met(self) -> bool:
        return all(self.met().values())

    def as_dict(self) -> dict[str, object]:
        met = self.met()
        return {
            "benchmark": self.name,
            "metrics": dict(self.metrics),
            "targets": {
                key: {"target": goal, "op": op, "met": met[key]}
                for key, (goal, op) in self.targets.items()
            },
            "machine": machine_description(),
            "date": datetime.date.today().isoformat(),
        }

    def table(self) -> str:
        met = self.met()
        rows = [("metric", "value", "target", "met")]
        for key, value in self.metrics.items():
            if key in self.targets:
                goal, op = self.targets[key]
                rows.append((key, _fmt(value), f"{op} {_fmt(goal)}", "yes" if met[key] else "NO"))
            else:
                rows.append((key, _fmt(value), "", ""))
        for key, (goal, op) in self.targets.items():
            if key not in self.metrics:
                rows.append((key, "(missing)", f"{op} {_fmt(goal)}", "NO"))
        widths = [max(len(r[i]) for r in rows) for i in range(4)]
        lines = []
        for i, r in enumerate(rows):
            lines.append(
                f"{r[0]:<{widths[0]}}  {r[1]:>{widths[1]}}  {r[2]:<{widths[2]}}  {r[3]}".rstrip()
            )
            if i == 0:
                lines.append("-" * len(lines[0]))
        return "\n".join(lines)

    def save(self, directory: Path = RESULTS_DIR) -> Path:
        directory.mkdir(parents=True, exist_ok=True)
        path = directory / f"{self.name}.json"
        path.write_text(json.dumps(self.as_dict(), indent=2) + "\n")
        return path

    def report(self, directory: Path = RESULTS_DIR) -> Path:
        """Print the table and the machine, save the JSON, and return its path."""
        print(self.table())
        print(f"\nmachine: {machine_description()}")
        path = self.save(directory)
        print(f"wrote {_display(path)}")
        return path


def _fmt(value: float) -> str:
    if isinstance(value, int) or float(value).is_integer():
        return f"{int(value):,}"
    if abs(value) >= 1000:
        return f"{value:,.0f}"
    return f"{value:.4g}"


def _display(path: Path) -> str:
    try:
        return str(path.relative_to(Path.cwd()))
    except ValueError:
        return str(path)


def run_json_tool(bench: str, argv: list[str], timeout_s: float) -> dict[str, object]:
    """Run a benchmark's helper binary and return the JSON object it prints, or exit with a message
    naming the benchmark, the binary and what went wrong."""
    binary = argv[0]
    try:
        proc = subprocess.run(argv, capture_output=True, text=True, timeout=timeout_s, check=False)
    except subprocess.TimeoutExpired:
        raise SystemExit(f"bench.{bench}: {binary} ran past {timeout_s} s") from None
    except OSError as exc:
        raise SystemExit(f"bench.{bench}: cannot run {binary}: {exc} (run `make build`)") from None
    if proc.returncode != 0:
        raise SystemExit(
            f"bench.{bench}: {binary} exited with {proc.returncode}: {proc.stderr.strip()}"
        )
    try:
        data = json.loads(proc.stdout)
    except json.JSONDecodeError as exc:
        raise SystemExit(f"bench.{bench}: {binary} did not print JSON ({exc})") from None
    if not isinstance(data, dict):
        raise SystemExit(f"bench.{bench}: {binary} printed {type(data).__name__}, not an object")
    return data


def positive_number(bench: str, what: str, value: object) -> float:
    """`value` as a float if it is a finite number above zero, else exit naming its source."""
    if (
        isinstance(value, bool)
        or not isinstance(value, int | float)
        or not math.isfinite(value)
        or value <= 0
    ):
        raise SystemExit(f"bench.{bench}: {what} = {value!r}")
    return float(value)
