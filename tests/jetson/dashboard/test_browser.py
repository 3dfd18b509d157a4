"""The dashboard in a real browser: headless Chromium (Debian's, driven by Selenium) on a short
lockstep full-stack match (brain_host + the cable + the daemon + the simulated field and camera)
with the dashboard on a loopback port. From the page itself: the match clock advances; at a
moment where the match is held still, the robot's pose drawn on the field is within 5 cm of the
daemon's, the ring and goal counts and the link counters are the daemon's, and the camera
picture is not blank. A screenshot goes into the run folder (dashboard.png). The match runs as
`pete-sim match --stack full --dashboard 127.0.0.1:0 --record` does."""

from __future__ import annotations

import threading
import time
from pathlib import Path
from typing import Any

import pytest

from bench.browser import Browser, missing_reason
from jetson.models import DEFAULT_POLICY
from sim.fullstack.brain_host import DEFAULT_BINARY

pytestmark = [
    pytest.mark.skipif(not DEFAULT_BINARY.exists(), reason="brain_host is not built: make build"),
    pytest.mark.skipif(missing_reason() is not None, reason=str(missing_reason())),
    pytest.mark.timeout(120),
]

HOLD_AT_MS = 3000  # match time at which the match is held while the page is checked


class HeldMatch:
    """A lockstep full-stack match (sim.fullstack.runner.FullStackMatch) with the dashboard on,
    held once at HOLD_AT_MS: the daemon publishes a snapshot on the match's thread and the
    match waits while the test looks at the page."""

    def __init__(self, out: Path) -> None:
        from sim.fullstack.options import MatchOptions
        from sim.fullstack.runner import FullStackMatch

        options = MatchOptions(
            stack="full", seed=3, seconds=5.0, gif=False, plots=False, out=out,
            policy=DEFAULT_POLICY, dashboard="127.0.0.1:0", record=True,
        )  # fmt: skip
        held = self

        class Match(FullStackMatch):
            def _tick(self) -> None:
                super()._tick()
                if self.match_ms == HOLD_AT_MS and not held.held.is_set():
                    held.hold(self)

        out.mkdir(parents=True, exist_ok=True)
        self.match = Match(options, out, None)
        self.url: str | None = None
        self.truth: dict[str, Any] = {}
        self.held = threading.Event()
        self.release = threading.Event()
        self.error: BaseException | None = None
        self.thread = threading.Thread(target=self._run, daemon=True)

    def _run(self) -> None:
        try:
            self.result = self.match.run()
        except BaseException as exc:
            self.error = exc
            self.held.set()

    def hold(self, match: Any) -> None:
        daemon = match.jetson.daemon
        snap = daemon.observer.publish(daemon)  # on the daemon's own thread: its exact state
        d = daemon.decider
        c = daemon.counters
        self.truth = {
            "n": snap["n"],
            "x": daemon.last_state.x,
            "y": daemon.last_state.y,
            "known_rings": len(d.ring_memory.known),
            "goals": len(d.goal_memory.known),
            "states": c.states,
            "commands": c.commands,
            "received": c.received + daemon.decoder.stats.received,
            "errors": sum(daemon.link_errors().values()),
            "phase_ms": daemon.last_state.phase_ms,
            "partner_link": None
            if daemon.partner_status is None
            else daemon.partner_status.link.name.lower(),
        }
        self.held.set()
        self.release.wait(60)

    def start(self) -> str:
        self.thread.start()
        deadline = time.monotonic() + 30
        while self.url is None and time.monotonic() < deadline:
            if self.error is not None:
                raise self.error
            server = getattr(self.match, "dashboard", None)
            if server is not None and server.port:
                self.url = server.url
            time.sleep(0.02)
        assert self.url, "the match's dashboard never started"
        return self.url


def test_dashboard_in_chromium_on_a_full_stack_match(tmp_path: Path) -> None:
    out = tmp_path / "match"
    run = HeldMatch(out)
    url = run.start()
    try:
        with Browser(1400, 1250) as b:
            b.open(url)
            b.wait(lambda: b.js("return D.state !== null && D.state.match !== null"), 30, "a State")
            first = b.js("return D.state.match.phase_ms")
            assert b.text("readonly").startswith("Read-only")
            assert run.held.wait(60), "the match never reached the hold"
            if run.error is not None:
                raise run.error
            t = run.truth
            # The page catches up with the snapshot published at the hold.
            b.wait(lambda: b.js("return D.state.n") == t["n"], 10, "the held snapshot")
            b.wait(lambda: b.js("return D.cameraDrawn") > 0, 10, "a camera frame")
            time.sleep(0.3)  # the last frame drawn
            page = b.js(
                "return {clock: Number(document.getElementById('match-clock').dataset.phaseMs),"
                " robot: D.drawn.robot, rings: D.drawn.rings, goals: D.drawn.goals,"
                " spread: D.cameraSpread()}"
            )
            assert page["clock"] > first, "the match clock advances on the page"
            assert page["clock"] == t["phase_ms"]
            err = ((page["robot"]["x"] - t["x"]) ** 2 + (page["robot"]["y"] - t["y"]) ** 2) ** 0.5
            assert err <= 0.05, f"pose on the page {page['robot']} vs the daemon's {t}"
            rings = page["rings"]
            assert rings["seen"] + rings["remembered"] == t["known_rings"], (rings, t)
            assert page["goals"] == t["goals"]
            assert int(b.text("link-states")) == t["states"]
            assert int(b.text("link-commands")) == t["commands"]
            assert b.text("link-received").split(" / ")[0] == str(t["received"])
            assert (
                int(b.js("return document.getElementById('link-errors').dataset.total"))
                == (t["errors"])
            )
            assert page["spread"] > 20, "the camera picture is not blank"
            # The partner link as the Brain reports it (this match's Brain has no radio).
            link = b.js("return document.getElementById('partner-link').dataset.link")
            assert link == (t["partner_link"] or ""), (link, t["partner_link"])
            shot = b.screenshot(out / "dashboard.png")
            assert shot.stat().st_size > 20_000
    finally:
        run.release.set()
        run.thread.join(60)
    if run.error is not None:
        raise run.error
    assert run.result is not None
    # The match's session recording keeps camera frames for `pete-jetson dashboard --recording`.
    from jetson.dashboard.replay import Timeline

    (session,) = (out / "sessions").glob("session-*")
    timeline = Timeline(session)
    assert len(timeline.frames) >= 10 and timeline.snapshots[-1]["field"]["memory"]


def test_the_dashboard_needs_the_daemon_in_this_process() -> None:
    from sim.errors import MatchError
    from sim.fullstack.options import MatchOptions

    for bad in ({"stack": "sim"}, {"daemon": "process"}):
        with pytest.raises(MatchError, match="dashboard"):
            MatchOptions(dashboard="127.0.0.1:0", **bad)
