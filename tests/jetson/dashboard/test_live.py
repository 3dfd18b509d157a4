"""The dashboard against a live daemon (FakeBrain, synthetic camera frames): the page and its
assets, the WebSocket's updates and their rates, the snapshot against the daemon's own state,
read-only and same-origin only, a browser that never reads, the dashboard off, a port taken."""

from __future__ import annotations

import asyncio
import base64
import json
import re
import socket
import time
import urllib.error
import urllib.request
from importlib import resources
from pathlib import Path
from typing import Any

import aiohttp
import cv2
import numpy as np
import pytest

pytestmark = pytest.mark.filterwarnings("error::pytest.PytestUnhandledThreadExceptionWarning")


def get(url: str, method: str = "GET", headers: dict[str, str] | None = None) -> tuple[int, bytes]:
    req = urllib.request.Request(url, method=method, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=5) as r:
            return r.status, r.read()
    except urllib.error.HTTPError as exc:
        return exc.code, exc.read()


async def collect(url: str, seconds: float, origin: str | None = None) -> list[dict[str, Any]]:
    """Every message of the dashboard's WebSocket for `seconds`."""
    out = []
    headers = {"Origin": origin} if origin else {}
    async with (
        aiohttp.ClientSession() as session,
        session.ws_connect(url.replace("http", "ws") + "ws", headers=headers) as ws,
    ):
        deadline = time.monotonic() + seconds
        while (left := deadline - time.monotonic()) > 0:
            try:
                msg = await ws.receive(timeout=left)
            except TimeoutError:
                break
            if msg.type != aiohttp.WSMsgType.TEXT:
                break
            out.append(json.loads(msg.data) | {"_at": time.monotonic()})
    return out


def test_page_and_assets_are_served_with_no_outside_address(live: Any) -> None:
    status, body = get(live.url)
    assert status == 200
    page = body.decode()
    assert "Read-only" in page and "Nothing on it moves the robot" in page
    for name in ("index.html", "dashboard.js", "dashboard.css"):
        text = resources.files("jetson.dashboard").joinpath("static", name).read_text()
        # No CDN, no font or script from elsewhere: the field has no internet.
        assert not re.search(r"(?:src|href)\s*=\s*[\"']?(?:https?:)?//", text), name
        assert "cdn" not in text.lower(), name
    for path in ("dashboard.js", "dashboard.css"):
        status, _ = get(live.url + path)
        assert status == 200


def test_websocket_updates_rates_and_content(live: Any) -> None:
    msgs = asyncio.run(collect(live.url, 3.0))
    kinds = [m["kind"] for m in msgs]
    assert kinds[0] == "hello" and msgs[0]["read_only"] is True and msgs[0]["mode"] == "live"
    states = [m for m in msgs if m["kind"] == "state"]
    frames = [m for m in msgs if m["kind"] == "frame"]
    assert any(m["kind"] == "jetson" for m in msgs)
    span = 3.0
    assert len(states) / span >= 10, f"{len(states)} snapshots in {span} s"
    # The synthetic camera gives 20 frames a second; the dashboard sends up to 10.
    assert len(frames) / span >= 5, f"{len(frames)} frames in {span} s"
    s = states[-1]
    assert s["link"]["up"] and s["link"]["ours"] == s["link"]["brain"]
    assert s["match"]["phase"] == "autonomous" and s["match"]["driver"] == "jetson"
    assert s["pose"]["gps_status"] == "ok" and s["command"]["reason"] == "policy"
    assert (
        s["link"]["latency"]["n"] > 0
        and sum(s["link"]["latency"]["hist"]) == s["link"]["latency"]["n"]
    )
    assert s["field"]["memory"] and s["field"]["remembered"], "the shipped policy remembers rings"
    assert s["field"]["skill"] is not None
    # This daemon runs neither the goal nor the robot detector: the camera sees none of either.
    assert s["field"]["goals_seen"] == [] and s["field"]["robots_seen"] == []
    f = frames[-1]
    img = cv2.imdecode(np.frombuffer(base64.b64decode(f["jpeg"]), np.uint8), cv2.IMREAD_COLOR)
    assert img is not None and img.shape[1] == 320 and img.std() > 5
    assert f["depth"] is not None and f["size"] == [320, 240]
    boxes = [b for m in frames for b in m["boxes"]]
    assert boxes, "the synthetic frames' rings are detected and drawn"
    assert all(len(b) == 6 for b in boxes)
    assert any(b[5] is not None for b in boxes), "placed rings carry their distance"


def test_snapshot_equals_the_daemon(live: Any, waiter: Any) -> None:
    """A snapshot published on the daemon's thread between two turns is the daemon's state."""
    observer = live.daemon.observer
    live.brain.send_log("ready to go")
    assert waiter(lambda: observer.brain_lines and observer.brain_lines[-1][2] == "ready to go")
    status, body = get(live.url + "api/snapshot")
    assert status == 200
    snap = json.loads(body)
    assert snap["kind"] == "state" and snap["brain_lines"][-1][2] == "ready to go"
    # Counters only grow: the snapshot's never exceed the daemon's a moment later.
    c = live.daemon.counters
    assert 0 < snap["link"]["states"] <= c.states
    assert snap["link"]["commands"] <= c.commands
    assert snap["link"]["errors"] == {}


def test_the_partner_over_vexlink_is_in_the_snapshot(live: Any, waiter: Any) -> None:
    """What the Brain hands over of the alliance partner reaches the page as the daemon keeps it."""
    from protocol.messages import Partner, PartnerFlags, PartnerLink, PartnerStatus, TargetKind

    report = Partner(
        x_mm=1200, y_mm=-300, heading_cdeg=9000, flags=PartnerFlags.POSE_OK, goal=255, rings=2,
        target=TargetKind.RING, target_id=255, target_x_mm=900, target_y_mm=-600, match_ms=0,
    )  # fmt: skip
    live.brain.send_message(PartnerStatus(PartnerLink.UP, 30, 5, 6, 0, 0, 0))
    live.brain.send_message(report)
    assert waiter(lambda: live.daemon.partner == report)

    def partner() -> Any:
        snap = json.loads(get(live.url + "api/snapshot")[1])
        p = snap["partner"]
        return p if p and p["report"] else None

    p = waiter(partner)
    assert p and p["link"] == "up" and p["received"] == 5
    assert p["report"]["pose"] == [1.2, -0.3, 90.0] and p["report"]["target"] == "ring"


def test_websocket_from_another_origin_is_refused(live: Any) -> None:
    with pytest.raises(aiohttp.WSServerHandshakeError) as err:
        asyncio.run(collect(live.url, 0.5, origin="http://evil.example"))
    assert err.value.status == 403
    host = live.url.split("//")[1].rstrip("/")
    same = asyncio.run(collect(live.url, 0.5, origin=f"http://{host}"))
    assert same and same[0]["kind"] == "hello"


def test_nothing_can_be_changed(live: Any) -> None:
    for method in ("POST", "PUT", "DELETE", "PATCH"):
        for path in ("", "api/snapshot", "ws"):
            status, _ = get(live.url + path, method)
            assert status == 405, (method, path, status)
    status, _ = get(live.url + "api/settings")
    assert status == 404
    status, _body = get(live.url)
    assert status == 200


def test_a_browser_that_never_reads_does_not_slow_the_robot(live: Any, waiter: Any) -> None:
    """A WebSocket client that stops reading: the daemon answers every State as before and the
    server keeps nothing queued for it beyond its socket buffer."""
    host, port = live.url.split("//")[1].rstrip("/").split(":")
    sock = socket.create_connection((host, int(port)))
    sock.setsockopt(socket.SOL_SOCKET, socket.SO_RCVBUF, 4096)
    key = base64.b64encode(b"0123456789abcdef").decode()
    sock.sendall(
        f"GET /ws HTTP/1.1\r\nHost: {host}:{port}\r\nUpgrade: websocket\r\n"
        f"Connection: Upgrade\r\nSec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n"
        .encode()
    )  # fmt: skip
    try:
        n0 = live.daemon.counters.states
        time.sleep(3.0)
        answered = live.daemon.counters.states - n0
        assert answered >= 100, f"{answered} States answered in 3 s at 50 a second"
        lat = sorted(live.daemon.latency.recent)[-answered:]
        assert lat and max(lat) < 0.5
        server = live.service.dashboard
        # Frames were dropped for the stalled reader, not queued: what was sent in 3 s is far
        # below 10 a second of ~10 kB frames.
        assert server.sent["frame"] <= 40
    finally:
        sock.close()


def test_dashboard_off_costs_one_attribute(stack: Any, waiter: Any) -> None:
    with stack(dashboard=None) as running:
        assert waiter(lambda: running.daemon.counters.states >= 10)
        assert running.service.dashboard is None
        assert running.daemon.observer is None
        assert running.daemon.decider.last_obs is not None  # the decision keeps its inputs


def test_a_port_taken_leaves_the_robot_driving(stack: Any, waiter: Any) -> None:
    taken = socket.socket()
    taken.bind(("127.0.0.1", 0))
    taken.listen(1)
    port = taken.getsockname()[1]
    try:
        with stack(dashboard=f"127.0.0.1:{port}") as running:
            assert waiter(lambda: running.daemon.counters.states >= 10)
            # The loop drives while the dashboard's process finds the port taken.
            assert waiter(lambda: running.service.dashboard is None, 60.0)
            assert running.daemon.observer is None
            n = running.daemon.counters.states
            assert waiter(lambda: running.daemon.counters.states >= n + 10)
            errors = running.records("dashboard")
            assert errors and errors[0]["level"] == "error" and "no dashboard" in errors[0]["msg"]
    finally:
        taken.close()


def test_recording_keeps_frames_and_still_replays(stack: Any, waiter: Any) -> None:
    from jetson.replay import Records, replay

    with stack(frames_hz=4.0) as running:
        assert waiter(lambda: running.daemon.counters.states >= 150)
        path = running.daemon.recorder.path
    records = list(Records(Path(path)))
    frames = [r for r in records if r["kind"] == "frame"]
    cycles = [r for r in records if r["kind"] == "cycle"]
    span = cycles[-1]["t"] - cycles[0]["t"]
    assert 2.0 * span <= len(frames) <= 4.0 * span + 2, (len(frames), span)
    img = cv2.imdecode(np.frombuffer(base64.b64decode(frames[0]["jpeg"]), np.uint8), 1)
    assert img.shape[1] == 160 and img.std() > 5
    assert frames[0]["depth"] and frames[0]["size"] == [320, 240]
    assert replay(path).ok  # the frames change nothing for pete-jetson replay
