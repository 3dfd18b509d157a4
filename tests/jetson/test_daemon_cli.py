"""`pete-jetson run` and `replay` as a user starts them: a separate process, real signals, the
settings file, and errors that say what is wrong."""

from __future__ import annotations

import json
import signal
import subprocess
import sys
import time
from pathlib import Path

import pytest

from jetson import cli
from jetson.testing import FakeBrain, write_mlp_policy

ROOT = Path(__file__).resolve().parents[2]


def wait_for(cond, timeout_s: float = 30.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while not cond():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.005)
    return True


@pytest.mark.parametrize("sig", [signal.SIGINT, signal.SIGTERM], ids=["SIGINT", "SIGTERM"])
def test_a_signal_makes_the_daemon_send_a_stop_record_and_exit_cleanly(
    tmp_path: Path, sig: signal.Signals
) -> None:
    policy = write_mlp_policy(tmp_path / "policy", seed=4)
    brain = FakeBrain(link_path=tmp_path / "pete-brain").start()
    config = tmp_path / "pete-jetson.toml"
    config.write_text(
        f'[link]\nport = "{brain.path}"\n[policy]\npath = "{policy}"\n'
        f'[camera]\nenabled = false\n[record]\ndir = "{tmp_path / "sessions"}"\n'
        f'[log]\nfile = "{tmp_path / "log.jsonl"}"\n'
    )
    proc = subprocess.Popen(
        [sys.executable, "-m", "jetson.cli", "run", "--config", str(config)],
        cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
    )  # fmt: skip
    try:
        assert wait_for(lambda: sum(c.command.linear != 0 for c in brain.commands) >= 10), (
            proc.stderr.read() if proc.poll() is not None else "no Commands"  # type: ignore[union-attr]
        )
        proc.send_signal(sig)
        _, stderr = proc.communicate(timeout=10)
        assert proc.returncode == 0, stderr
        assert wait_for(lambda: not brain.commands[-1].command.intake, 5.0)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
        brain.close()
    last = brain.commands[-1].command
    assert (last.linear, last.angular, last.intake) == (0.0, 0.0, False)
    assert any(c.command.linear != 0 for c in brain.commands[:-1])
    # The human summary went to stderr, the JSON log to its file.
    assert "latency p50" in stderr
    events = [json.loads(x) for x in (tmp_path / "log.jsonl").read_text().splitlines()]
    names = [e["event"] for e in events]
    assert {"start", "config", "port_open", "link_up", "signal", "stop_sent"} <= set(names)
    assert names[-1] == "exit"
    # The session recording replays identically.
    [session] = (tmp_path / "sessions").glob("session-*.jsonl.gz")
    assert cli.main(["replay", str(session)]) == 0


def test_bad_settings_are_refused_at_start_with_the_reason(
    tmp_path: Path, capsys: pytest.CaptureFixture[str]
) -> None:
    bad = tmp_path / "bad.toml"
    bad.write_text("[decision]\ndrive_phases = ['disabled']\n")
    assert cli.main(["run", "--config", str(bad)]) == 2
    assert "'disabled' is not a phase the policy may drive in" in capsys.readouterr().err
    assert cli.main(["run", "--no-camera", "--policy", str(tmp_path / "missing.onnx")]) == 2
    assert "no policy at" in capsys.readouterr().err
    junk = tmp_path / "session-junk.jsonl"
    junk.write_text('{"kind": "cycle"}\n')
    assert cli.main(["replay", str(junk)]) == 2
    assert "not a pete-jetson session recording" in capsys.readouterr().err
