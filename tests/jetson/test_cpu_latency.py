"""The CPUs' wake-up latency request (jetson/cpu_latency.py): written as the kernel reads it,
held while the daemon runs and released after, and a request that cannot be made is logged,
never raised."""

from __future__ import annotations

import io
import json
import struct
from pathlib import Path

import pytest

from jetson.cpu_latency import CpuWakeLatency
from jetson.errors import SettingsError
from jetson.settings import Settings, SystemSettings


def test_the_request_is_a_native_int32_held_until_released(tmp_path: Path) -> None:
    device = tmp_path / "cpu_dma_latency"
    device.write_bytes(b"")
    request = CpuWakeLatency(7, str(device))
    assert request.hold() is None and request.held
    assert struct.unpack("=i", device.read_bytes()) == (7,)
    request.release()
    assert not request.held


def test_a_request_that_cannot_be_made_says_why(tmp_path: Path) -> None:
    request = CpuWakeLatency(0, str(tmp_path / "missing"))
    why = request.hold()
    assert why is not None and "missing" in why and not request.held
    assert CpuWakeLatency(-1, str(tmp_path / "missing")).hold() is None  # no request asked


@pytest.mark.parametrize("value", [-2, 1.5, True, "0", 2_000_000])
def test_bad_wake_latencies_are_refused(value: object) -> None:
    with pytest.raises(SettingsError, match="cpu_wake_latency_us"):
        SystemSettings(cpu_wake_latency_us=value)  # type: ignore[arg-type]
    with pytest.raises(SettingsError, match="cpu_wake_latency_us"):
        Settings.from_dict({"system": {"cpu_wake_latency_us": value}})


def test_the_daemon_holds_it_while_it_runs_and_logs_a_failure(tmp_path: Path) -> None:
    from jetson.service import build

    device = tmp_path / "cpu_dma_latency"
    device.write_bytes(b"")
    out = io.StringIO()
    settings = Settings().with_overrides(
        link={"port": str(tmp_path / "no-brain")}, camera={"enabled": False}, record={"dir": ""}
    )
    service = build(settings, log_stream=out, human_stream=io.StringIO())
    assert service.cpu_wake is not None and service.cpu_wake.microseconds == 0
    service.cpu_wake.device = str(device)
    service.stop()  # run() returns at once: the request is made and released around the loop
    assert service.run() == 0
    assert struct.unpack("=i", device.read_bytes()) == (0,) and not service.cpu_wake.held
    service = build(settings, log_stream=out, human_stream=io.StringIO())
    service.cpu_wake.device = str(tmp_path / "absent")
    service.stop()
    service.run()
    records = [json.loads(x) for x in out.getvalue().splitlines() if x.startswith("{")]
    wake = [r for r in records if r.get("event") == "cpu_wake_latency"]
    assert [r["level"] for r in wake] == ["info", "warning"]
    assert "absent" in wake[1]["msg"]


def test_no_request_in_lockstep_or_when_turned_off() -> None:
    from jetson.clock import ManualClock
    from jetson.service import build

    off = Settings().with_overrides(
        system={"cpu_wake_latency_us": -1}, camera={"enabled": False}, record={"dir": ""}
    )
    assert build(off, log_stream=io.StringIO()).cpu_wake is None
    lockstep = Settings().with_overrides(camera={"enabled": False}, record={"dir": ""})
    assert build(lockstep, ManualClock(), log_stream=io.StringIO()).cpu_wake is None
