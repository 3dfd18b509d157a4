"""bench.dashboard, tiny: its three scenarios once for two seconds, into a temporary folder."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from bench.browser import missing_reason

pytestmark = [
    pytest.mark.skipif(missing_reason() is not None, reason=str(missing_reason())),
    pytest.mark.timeout(180),
]


def test_a_tiny_run_writes_every_metric(tmp_path: Path) -> None:
    from bench.dashboard import main

    assert main(["--seconds", "2", "--rounds", "1", "--rate", "50", "--nice", "0",
                 "--out", str(tmp_path)]) == 0  # fmt: skip
    data = json.loads((tmp_path / "dashboard.json").read_text())
    m = data["metrics"]
    assert data["benchmark"] == "dashboard"
    for scenario in ("without", "with", "browser"):
        assert m[f"cycles_{scenario}"] >= 90 and m[f"unanswered_{scenario}"] == 0
    assert m["page_state_hz"] > 0 and m["page_frame_hz"] > 0
    # the browser scenario's page draws the with run's messages, replayed without a server
    assert m["page_state_hz_browser"] > 0 and m["page_frame_hz_browser"] > 0
    assert set(data["targets"]) == {
        "daemon_p99_ratio_with_to_browser", "daemon_p99_ms_with", "page_state_hz",
        "page_frame_hz",
    }  # fmt: skip


def test_the_browser_scenario_needs_a_with_run_first() -> None:
    from bench.dashboard import run_scenario

    with pytest.raises(ValueError, match="run `with` first"):
        run_scenario(1.0, 50.0, "browser")
