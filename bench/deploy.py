"""Benchmark of the deployment: how exposed the daemon's systemd unit leaves the Jetson.

    python -m bench.deploy [--unit jetson/deploy/pete-jetson.service] [--strict]

`systemd-analyze security --offline=true` rates the unit file itself (no running service, no
root): 0 is a fully locked-down service, 10 one with every door open; systemd calls 9.2
"UNSAFE" and up to 4.0 "OK". The rating is systemd's own weighting of some eighty settings
(no new privileges, a read-only system, private /tmp, no home, a device allow list, the address
families and system calls allowed, ...); the count of settings it still finds open comes with
it. The number depends only on the unit file and the systemd version, which is recorded too.
"""

from __future__ import annotations

import argparse
import json
import re
import shutil
import subprocess
import sys
from dataclasses import dataclass
from pathlib import Path

from bench.common import Result

ROOT = Path(__file__).resolve().parent.parent
UNIT = ROOT / "jetson" / "deploy" / "pete-jetson.service"
TARGET = 4.0  # systemd's "OK" ends here
TIMEOUT_S = 60
_OVERALL = re.compile(r"Overall exposure level for \S+: ([0-9]+(?:\.[0-9]+)?) (\S+)")


class DeployBenchError(RuntimeError):
    """systemd-analyze answered something this benchmark cannot read, or there is no unit."""


class NoSystemdAnalyze(DeployBenchError):
    """systemd-analyze is not installed: nothing to measure with (`make bench` goes on)."""


@dataclass(frozen=True)
class Rating:
    exposure: float  # 0 (locked down) .. 10 (nothing restricted)
    label: str  # systemd's word for it: OK, MEDIUM, EXPOSED, UNSAFE
    open_settings: int  # the settings systemd counts against the unit
    systemd_version: int


def systemd_analyze() -> str:
    found = shutil.which("systemd-analyze")
    if found is None:
        raise NoSystemdAnalyze(
            "systemd-analyze is not installed (it comes with systemd: apt-get install systemd)"
        )
    return found


def _run(argv: list[str]) -> str:
    try:
        proc = subprocess.run(argv, capture_output=True, text=True, timeout=TIMEOUT_S)
    except subprocess.TimeoutExpired:
        raise DeployBenchError(f"{' '.join(argv)} ran past {TIMEOUT_S} s") from None
    if proc.returncode != 0:
        raise DeployBenchError(
            f"{' '.join(argv)} exited with {proc.returncode}: {proc.stderr.strip()}"
        )
    return proc.stdout


def rate(unit: Path) -> Rating:
    """systemd's security rating of `unit`, read offline."""
    if not unit.is_file():
        raise DeployBenchError(f"no unit file {unit}")
    tool = systemd_analyze()
    base = [tool, "security", "--offline=true", "--no-pager"]
    text = _run([*base, str(unit)])
    found = _OVERALL.search(text)
    if found is None:
        raise DeployBenchError(f"systemd-analyze printed no overall exposure for {unit}")
    try:
        rows = json.loads(_run([*base, "--json=short", str(unit)]))
        open_settings = sum(1 for r in rows if r.get("exposure") not in (None, "0.0"))
    except (json.JSONDecodeError, AttributeError, TypeError) as exc:
        raise DeployBenchError(f"systemd-analyze --json=short for {unit}: {exc}") from None
    version = re.match(r"systemd (\d+)", _run([tool, "--version"]))
    if version is None:
        raise DeployBenchError("systemd-analyze --version printed no version")
    return Rating(float(found.group(1)), found.group(2), open_settings, int(version.group(1)))


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(
        prog="python -m bench.deploy",
        description=__doc__,
        formatter_class=argparse.RawDescriptionHelpFormatter,
    )
    parser.add_argument(
        "--unit", type=Path, default=UNIT, help="the unit file to rate (default: the shipped one)"
    )
    parser.add_argument("--strict", action="store_true", help="exit 1 if the target is missed")
    args = parser.parse_args(argv)
    try:
        rating = rate(args.unit)
    except NoSystemdAnalyze as exc:
        print(f"bench.deploy: skipped: {exc}; no numbers were written", file=sys.stderr)
        return 0
    except DeployBenchError as exc:
        print(f"bench.deploy: {exc}; no numbers were written", file=sys.stderr)
        return 2
    result = Result("deploy")
    result.add("systemd_exposure", rating.exposure)
    result.add("open_settings", rating.open_settings)
    result.add("systemd_version", rating.systemd_version)
    result.target("systemd_exposure", TARGET, "<=")
    print(f"(systemd-analyze security --offline=true: {rating.exposure} {rating.label})\n")
    result.report()
    if not result.all_met:
        print(f"target missed: systemd_exposure {rating.exposure} > {TARGET}", file=sys.stderr)
        return 1 if args.strict else 0
    return 0


if __name__ == "__main__":
    sys.exit(main())
