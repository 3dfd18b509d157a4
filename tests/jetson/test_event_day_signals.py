"""Event day: SIGTERM (systemd's stop) or SIGINT (Ctrl-C) at any moment, even while the Brain
floods the log, ends `pete-jetson run` within a second, and a connected Brain gets a stop Command
first.

The daemon runs as a process, exactly as the unit starts it, its log on stdout to a pipe read
slowly (as journald reads it); jetson.testing.FakeBrain is the Brain on a pty, and a thread makes
it print as fast as it can (each line was a line of the daemon's log). Signal handlers used to log
through the log's lock, which the interrupted main thread, blocked writing to that pipe, holds:
that hung the daemon until SIGKILL.
"""

from __future__ import annotations

import itertools
import json
import random
import signal
import subprocess
import sys
import threading
import time
from collections.abc import Callable
from pathlib import Path
from typing import IO

import pytest

from jetson.testing import FakeBrain, write_mlp_policy
from protocol.messages import LogLevel

ROOT = Path(__file__).resolve().parents[2]
EXIT_S = 1.0  # the daemon is gone this soon after the signal
MOMENTS = 6  # signals at random moments, half SIGTERM, half SIGINT


def wait_for(cond: Callable[[], bool], timeout_s: float = 30.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while not cond():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.002)
    return True


@pytest.fixture(scope="module")
def policy(tmp_path_factory: pytest.TempPathFactory) -> Path:
    return write_mlp_policy(tmp_path_factory.mktemp("policy"), seed=4)


class SlowReader:
    """The journal: reads the daemon's stdout, a little at a time."""

    def __init__(self, stream: IO[bytes]) -> None:
        self.data = bytearray()
        self._stream = stream
        self._thread = threading.Thread(target=self._run, daemon=True)
        self._thread.start()

    def _run(self) -> None:
        while chunk := self._stream.read1(2048):  # type: ignore[attr-defined]
            self.data += chunk
            time.sleep(0.002)  # about 1 MB/s

    def events(self) -> list[str]:
        self._thread.join(10.0)
        return [json.loads(x)["event"] for x in self.data.decode().splitlines() if x]


class Flood:
    """The Brain printing text and Log messages as fast as the pty takes them."""

    def __init__(self, brain: FakeBrain) -> None:
        self.brain = brain
        self.sent = 0
        self._stop = threading.Event()
        self._thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        for i in itertools.count():
            if self._stop.is_set():
                return
            self.brain.send_text(f"flood line {i}: the Brain's program printing in a loop")
            if i % 4 == 0:
                self.brain.send_log(f"flood log {i}", LogLevel.WARNING)
            self.sent += 1
            if i % 64 == 0:
                time.sleep(0.0005)  # let the Brain's own thread send its States

    def __enter__(self) -> Flood:
        self._thread.start()
        return self

    def __exit__(self, *_: object) -> None:
        self._stop.set()
        self._thread.join(5.0)


def run_once(
    tmp: Path, policy: Path, sig: signal.Signals, delay_s: float
) -> tuple[float, FakeBrain, float, list[str]]:
    """Start the daemon against a FakeBrain, flood, signal it `delay_s` after it drives; the
    seconds until it exited, the Brain, when the signal went, and the log's events."""
    brain = FakeBrain(link_path=tmp / "pete-brain").start()
    argv = [
        sys.executable, "-m", "jetson.cli", "run", "--port", brain.path, "--policy", str(policy),
        "--no-camera", "--record-dir", str(tmp / "sessions"), "--log-level", "debug", "--quiet",
    ]  # fmt: skip
    proc = subprocess.Popen(argv, cwd=ROOT, stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    assert proc.stdout is not None
    journal = SlowReader(proc.stdout)
    try:
        driving = lambda: sum(c.command.linear != 0 for c in brain.commands) >= 5  # noqa: E731
        assert wait_for(lambda: driving() or proc.poll() is not None), "no Commands"
        assert proc.poll() is None, proc.communicate()[1]
        with Flood(brain) as flood:
            time.sleep(delay_s)
            sent = time.monotonic()
            proc.send_signal(sig)
            try:
                proc.wait(timeout=10.0)
            except subprocess.TimeoutExpired:
                pytest.fail(f"{sig.name} {delay_s:.2f} s into a flood: still running after 10 s")
            exited_s = time.monotonic() - sent
            assert flood.sent > 0
        # Whatever the daemon wrote before exiting reaches the Brain's side of the pty.
        wait_for(lambda: bool(brain.commands) and not brain.commands[-1].command.intake, 2.0)
        stderr = proc.stderr.read().decode() if proc.stderr else ""
        assert proc.returncode == 0, stderr
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.wait()
        brain.close()
    return exited_s, brain, sent, journal.events()


def test_a_signal_at_any_moment_of_a_log_flood_ends_the_daemon_within_a_second_with_a_stop(
    tmp_path: Path, policy: Path
) -> None:
    rng = random.Random(42)
    for i in range(MOMENTS):
        sig = (signal.SIGTERM, signal.SIGINT)[i % 2]
        delay_s = rng.uniform(0.0, 0.8)
        tmp = tmp_path / f"run{i}"
        tmp.mkdir()
        exited_s, brain, sent, events = run_once(tmp, policy, sig, delay_s)
        where = f"{sig.name} {delay_s:.3f} s into the flood"
        assert exited_s < EXIT_S, f"{where}: exited after {exited_s:.3f} s"
        # The last Command the Brain got is a stop, sent after the signal; before it, driving.
        last = brain.commands[-1]
        assert (last.command.linear, last.command.angular, last.command.intake) == (
            0.0,
            0.0,
            False,
        ), where
        assert last.t >= sent, f"{where}: no stop Command after the signal"
        assert any(c.command.linear != 0 for c in brain.commands[:-1])
        # The signal is logged by the loop (not the handler), and the log ends cleanly.
        assert "signal" in events and "stop_sent" in events and events[-1] == "exit", where
