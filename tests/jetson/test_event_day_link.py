"""Event day: a Brain that is absent, or a port that fails, costs a few log lines, not tens of
thousands; a returning Brain is found within about a second; a cable pulled and returned keeps
the match's memories, a new Brain boot or a new match starts afresh.

- reconnect backoff (jetson.loop.Backoff) and the daemon against a port that opens and fails at
  once (/dev/null), as a process and in a thread;
- the log's limits (jetson.log.EventLog): repeats aggregated, a rate bound whatever happens;
- the decider's memories across reconnects to a jetson.testing.FakeBrain.
"""

from __future__ import annotations

import contextlib
import io
import json
import os
import signal
import subprocess
import sys
import threading
import time
from collections import Counter
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest

from jetson.autonomy.spec import ObservationSpec
from jetson.camera_feed import SyncPerception
from jetson.clock import MonotonicClock
from jetson.decide import Decider
from jetson.log import EventLog, LogLimits
from jetson.loop import Backoff, Daemon
from jetson.settings import DecisionConfig, LinkConfig
from jetson.testing import FakeBrain, ProbePolicy, default_state, write_mlp_policy
from protocol.messages import MatchPhase

ROOT = Path(__file__).resolve().parents[2]
pytestmark = pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning")


def wait_for(cond: Callable[[], bool], timeout_s: float = 5.0) -> bool:
    deadline = time.monotonic() + timeout_s
    while not cond():
        if time.monotonic() > deadline:
            return False
        time.sleep(0.002)
    return True


@contextlib.contextmanager
def daemon_on(port: str | Path, policy: Any = None, **kw: Any) -> Iterator[tuple[Daemon, Any]]:
    clock = MonotonicClock()
    out = io.StringIO()
    decision = kw.pop("decision", None) or DecisionConfig()
    daemon = Daemon(
        Decider(policy or ProbePolicy(), decision),
        clock,
        EventLog(out, None, clock, "debug"),
        link=LinkConfig(port=str(port)),
        summary_period_s=0.25,
        **kw,
    )
    stop = threading.Event()
    thread = threading.Thread(target=daemon.run, args=(stop,), daemon=True)
    thread.start()
    try:
        yield daemon, out
    finally:
        stop.set()
        thread.join(5.0)
        assert not thread.is_alive(), "the daemon did not stop"


def records(out: io.StringIO, event: str | None = None) -> list[dict[str, Any]]:
    lines = [json.loads(x) for x in out.getvalue().splitlines() if x]
    return [r for r in lines if event is None or r["event"] == event]


def point(link: Path, target: str) -> None:
    """Swap the stable name to another device, atomically (as udev does)."""
    tmp = link.with_name(link.name + ".tmp")
    with contextlib.suppress(FileNotFoundError):
        tmp.unlink()
    tmp.symlink_to(target)
    os.replace(tmp, link)


# --- backoff --------------------------------------------------------------------------------------


def test_backoff_doubles_from_the_poll_period_to_its_cap_and_starts_again_on_success() -> None:
    b = Backoff(0.05, 1.0)
    assert b.ready(0.0)
    now, waits = 0.0, []
    for _ in range(8):
        b.failed(now)
        waits.append(round(b.next_s - now, 3))
        assert not b.ready(now) and b.ready(b.next_s)
        now = b.next_s
    assert waits == [0.05, 0.1, 0.2, 0.4, 0.8, 1.0, 1.0, 1.0]
    b.succeeded()
    assert b.ready(now) and b.failures == 0
    b.failed(now)
    assert round(b.next_s - now, 3) == 0.05


def test_the_backoff_cap_is_a_checked_setting() -> None:
    from jetson.errors import SettingsError

    assert LinkConfig().reconnect_max_s == 1.0
    with pytest.raises(SettingsError, match="reconnect_max_s"):
        LinkConfig(reconnect_max_s=5.0)
    with pytest.raises(SettingsError, match="reconnect_max_s"):
        LinkConfig(reconnect_poll_s=0.2, reconnect_max_s=0.1)


def test_an_absent_brain_for_4_s_is_a_few_log_lines_not_tens_of_thousands(tmp_path: Path) -> None:
    """`--port /dev/null`: a port that opens and hangs up at once. Without backoff it was
    reopened every turn: 44,060 link_down warnings in 4 s."""
    policy = write_mlp_policy(tmp_path / "policy", seed=1)
    log = tmp_path / "log.jsonl"
    argv = [
        sys.executable, "-m", "jetson.cli", "run", "--port", "/dev/null", "--policy", str(policy),
        "--no-camera", "--no-record", "--log", str(log), "--quiet",
    ]  # fmt: skip
    proc = subprocess.Popen(argv, cwd=ROOT, stderr=subprocess.PIPE, text=True)
    try:
        assert wait_for(lambda: log.exists() and '"port_open"' in log.read_text(), 30.0)
        time.sleep(4.0)
        proc.send_signal(signal.SIGTERM)
        _, stderr = proc.communicate(timeout=10)
    finally:
        if proc.poll() is None:
            proc.kill()
            proc.communicate()
    assert proc.returncode == 0, stderr
    lines = [json.loads(x) for x in log.read_text().splitlines()]
    events = [r["event"] for r in lines]
    assert len(lines) <= 40, f"{len(lines)} lines in 4 s: {Counter(events).most_common(4)}"
    # Backoff: about one attempt a second once it reaches its cap.
    exit_ = lines[-1]
    assert exit_["event"] == "exit"
    assert 4 <= exit_["counters"]["connects"] <= 12, exit_["counters"]
    # The same line, repeated, is written a few times, then once as a count.
    assert events.count("link_down") == 3 and events.count("port_open") == 3
    repeated = {r["of"]: r for r in lines if r["event"] == "repeated"}
    assert set(repeated) == {"link_down", "port_open"}
    assert repeated["link_down"]["msg"].startswith("link_down x")
    assert (
        events.count("link_down") + repeated["link_down"]["count"]
        == (exit_["counters"]["disconnects"])
    )


def test_a_brain_behind_a_failing_port_is_found_within_a_second_of_returning(
    tmp_path: Path,
) -> None:
    link = tmp_path / "pete-brain"
    brain = FakeBrain(link_path=link).start()
    point(link, "/dev/null")  # the name exists, but nothing answers behind it
    try:
        with daemon_on(link) as (daemon, out):
            time.sleep(3.0)
            attempts = daemon.counters.connects
            assert 4 <= attempts <= 10, f"{attempts} attempts in 3 s: no backoff"
            returned = time.monotonic()
            point(link, brain.pty_path)
            assert wait_for(lambda: brain.first_hello_after_appearing is not None, 3.0)
            found_s = brain.first_hello_after_appearing - returned  # type: ignore[operator]
            assert wait_for(lambda: len(brain.commands) >= 5)
            assert daemon.backoff.failures == 0  # the link came up: back to the start
    finally:
        brain.close()
    assert found_s < 1.2, f"the Brain was found {found_s:.3f} s after it returned"
    assert records(out, "link_up")


# --- the log's limits ---------------------------------------------------------------------------


class WallClock:
    def __init__(self) -> None:
        self.t = 1000.0

    def __call__(self) -> float:
        return self.t


def parsed(out: io.StringIO) -> list[dict[str, Any]]:
    return [json.loads(x) for x in out.getvalue().splitlines()]


def test_a_repeated_line_is_written_a_few_times_then_as_one_count() -> None:
    out, wall = io.StringIO(), WallClock()
    log = EventLog(out, wall=wall)
    for _ in range(1500):  # 100 a second for 15 s
        log.warning("link_down", "link down (end of file)")
        wall.t += 0.01
    lines = parsed(out)
    assert len(lines) <= 6
    downs = [r for r in lines if r["event"] == "link_down"]
    assert 3 <= len(downs) <= 4  # the burst, then one every repeat_every_s
    [during] = [r for r in lines if r["event"] == "repeated"]  # while they went on
    assert during["of"] == "link_down" and during["msg"].startswith("link_down x")
    assert during["level"] == "warning" and during["span_s"] == pytest.approx(10.0, abs=0.1)
    wall.t += 0.5
    log.flush_repeats()  # the repeats may go on (0.5 s ago): nothing yet
    assert len(parsed(out)) == len(lines)
    wall.t += 2.0
    log.flush_repeats()  # they stopped: their count is written
    lines = parsed(out)
    downs = [r for r in lines if r["event"] == "link_down"]
    counts = [r["count"] for r in lines if r["event"] == "repeated"]
    assert len(counts) == 2 and lines[-1]["event"] == "repeated"
    assert len(downs) + sum(counts) == 1500  # nothing disappears without a count
    # Another message of the same event is not a repeat.
    log.warning("link_down", "link down (hung up)")
    assert parsed(out)[-1]["msg"] == "link down (hung up)"


def test_the_logs_rate_is_bounded_whatever_happens_and_drops_are_reported() -> None:
    out, wall = io.StringIO(), WallClock()
    limits = LogLimits()
    log = EventLog(out, wall=wall, limits=limits)
    offered = 0
    for second in range(60):  # a minute of 3000 distinct lines a second over 30 events
        for i in range(3000):
            log.info(f"event{i % 30}", f"line {second}.{i}")
            offered += 1
            wall.t += 1 / 3000
        log.summary(f"summary {second}")  # the heartbeat is never held back
    log.close()
    lines = parsed(out)
    events = [r["event"] for r in lines]
    assert events.count("summary") == 60
    written = len(lines) - events.count("summary") - events.count("log_dropped")
    bound = limits.total_burst + limits.total_rate * 60
    assert written <= bound, f"{written} lines in a minute (bound {bound})"
    assert events.count("log_dropped") <= written + 1
    dropped = sum(r["count"] for r in lines if r["event"] == "log_dropped")
    assert written + dropped == offered  # every refused line is counted in a log_dropped line
    assert log.lines == len(lines)


def test_one_chatty_event_cannot_starve_the_others() -> None:
    out, wall = io.StringIO(), WallClock()
    log = EventLog(out, wall=wall)
    for i in range(10_000):
        log.info("brain_text", f"brain sout: spam {i}")
        if i == 5000:
            log.warning("link_down", "link down (hung up)")
        wall.t += 0.001
    assert any(r["event"] == "link_down" for r in parsed(out))


def test_bad_log_limits_are_refused() -> None:
    with pytest.raises(ValueError, match="event_rate"):
        LogLimits(event_rate=0)
    with pytest.raises(ValueError, match="burst"):
        LogLimits(repeat_burst=0)


# --- the decider's memories across reconnects ---------------------------------------------------


class Match:
    """FakeBrain's States for a robot standing at (0.5, -0.5) facing +x, red, in autonomous; the
    phase clock restarts when new_match() is called."""

    def __init__(self) -> None:
        self.start_s = 0.0

    def new_match(self) -> None:
        self.start_s = time.monotonic()

    def __call__(self, seq: int, t: float) -> dict[str, Any]:
        fields = default_state(seq, t)
        phase_s = t if self.start_s == 0.0 else max(0.0, time.monotonic() - self.start_s)
        fields.update(x=0.5, y=-0.5, heading=90.0, phase=MatchPhase.AUTONOMOUS)
        fields["phase_ms"] = int(phase_s * 1000)
        return fields


def test_the_match_memories_survive_a_reconnect_to_the_same_boot_not_a_new_boot_or_match(
    tmp_path: Path,
) -> None:
    # Prior ring A 1 m ahead of the robot (in view), B 1 m behind it.
    spec = ObservationSpec(ring_memory=True, prior_rings=((1.5, -0.5), (-0.5, -0.5)), n_stack=0)
    policy = ProbePolicy(spec)
    policy.keep_observations = True
    clock = MonotonicClock()
    perception = SyncPerception(lambda f: f, clock)
    match = Match()
    brain = FakeBrain(link_path=tmp_path / "pete-brain", make_state=match).start()

    def remembered() -> list[float]:
        obs = policy.observations[-1]
        return sorted(obs[spec.ring_offset + 2 : spec.frame_size : 3].tolist(), reverse=True)[:2]

    def answered(n: int) -> Callable[[], bool]:
        return lambda: len(brain.commands) >= n

    def reconnect(boot_id: int | None = None, meanwhile: Callable[[], None] | None = None) -> None:
        brain.vanish()
        assert wait_for(lambda: daemon.state == "waiting for port")
        if meanwhile is not None:
            meanwhile()
        brain.reappear(boot_id)
        assert wait_for(answered(len(brain.commands) + 10))

    try:
        decision = DecisionConfig(perception_max_age_s=0.2)
        with daemon_on(brain.path, policy, perception=perception, decision=decision) as (
            daemon,
            out,
        ):
            assert wait_for(answered(5))
            assert remembered() == [0.5, 0.5]  # the layout: both rings
            perception.set_rings([])  # a fresh picture without A: A is gone
            assert wait_for(lambda: remembered() == [0.5, 0.0])
            time.sleep(0.3)  # the picture ages: stale pictures prove nothing either way
            assert wait_for(answered(len(brain.commands) + 5)) and remembered() == [0.5, 0.0]
            reconnect()  # the cable pulled and returned: the same boot, the same match
            assert remembered() == [0.5, 0.0], "a reconnect to the same boot forgot the match"
            reconnect(0x5EED0002)  # the Brain power-cycled: a new boot starts afresh
            assert remembered() == [0.5, 0.5]
            perception.set_rings([])
            assert wait_for(lambda: remembered() == [0.5, 0.0])
            time.sleep(0.3)
            assert remembered() == [0.5, 0.0]
            # The same boot, but while the cable was out its phase clock went back: a new match.
            reconnect(meanwhile=match.new_match)
            assert remembered() == [0.5, 0.5]
    finally:
        brain.close()
    ups = records(out, "link_up")
    assert [u["memories"] for u in ups] == ["fresh", "kept", "fresh", "kept"]
