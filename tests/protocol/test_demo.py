"""`make demo` (for now the protocol demo) runs end to end against the C++ codec tool."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[2]
TOOL = ROOT / "build" / "host" / "bin" / "pete_codec_tool"


@pytest.mark.skipif(not TOOL.exists(), reason="C++ host tools not built (make build)")
def test_demo_runs_and_its_promises_hold() -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "protocol.demo", "--tool", str(TOOL)],
        capture_output=True,
        text=True,
        timeout=120,
        cwd=ROOT,
    )
    assert proc.returncode == 0, proc.stdout + proc.stderr
    assert "corrupt Commands delivered: 0" in proc.stdout
    assert "fingerprint mismatch" in proc.stdout


def test_demo_explains_a_missing_tool(tmp_path: Path) -> None:
    proc = subprocess.run(
        [sys.executable, "-m", "protocol.demo", "--tool", str(tmp_path / "absent")],
        capture_output=True,
        text=True,
        timeout=60,
        cwd=ROOT,
    )
    assert proc.returncode == 2
    assert "make build" in proc.stdout + proc.stderr
    assert "Traceback" not in proc.stderr
