"""`pete-jetson dashboard --recording FILE` and `pete-jetson report RECORDING`."""

from __future__ import annotations

import argparse
import json
import time
from pathlib import Path

HELP = """\
  pete-jetson dashboard    replay a session recording in the dashboard (a time slider)
  pete-jetson report       plots of a session recording (speeds, who drove, rings, latency)
"""


def add_commands(sub: argparse._SubParsersAction) -> None:
    d = sub.add_parser(
        "dashboard",
        help="replay a session recording in the dashboard's page, with a time slider",
        description="Serve the dashboard (the page `pete-jetson run --dashboard` serves) over a "
        "session recording: the camera frames it kept, the pose, the ring and goal memories "
        "(rebuilt by running the recording's decisions again), the link and the latency, at "
        "any moment of the session. Read-only.",
    )
    d.add_argument("--recording", type=Path, required=True, help="a session-*.jsonl[.gz] file")
    d.add_argument(
        "--address",
        default="127.0.0.1:8080",
        metavar="[HOST:]PORT",
        help="where to serve it (default: 127.0.0.1:8080)",
    )
    d.add_argument(
        "--policy", help="the policy to rebuild the memories with (default: the recorded path)"
    )
    d.set_defaults(func=cmd_dashboard)
    r = sub.add_parser(
        "report",
        help="plots of a session recording: speeds, who drove, rings seen, latency",
        description="Write report.png and report.json for a session recording.",
    )
    r.add_argument("recording", type=Path, help="a session-*.jsonl[.gz] file")
    r.add_argument("--out", type=Path, help="folder for the report (default: RECORDING-report/)")
    r.set_defaults(func=cmd_report)


def cmd_dashboard(args: argparse.Namespace) -> int:
    from jetson.dashboard.address import parse_address
    from jetson.dashboard.replay import ReplaySource, Timeline
    from jetson.dashboard.server import DashboardServer
    from jetson.errors import JetsonError

    try:
        host, port = parse_address(args.address)
        policy = None
        if args.policy:
            from jetson.autonomy.policy import OnnxPolicy

            policy = OnnxPolicy(args.policy)
        timeline = Timeline(args.recording, policy)
    except (JetsonError, ValueError, OSError) as exc:
        raise RuntimeError(str(exc)) from exc
    for w in timeline.warnings:
        print(f"warning: {w}")
    server = DashboardServer(ReplaySource(timeline), host, port)
    try:
        server.start()
    except OSError as exc:
        raise RuntimeError(str(exc)) from exc
    span = timeline.end_t - timeline.start_t
    print(
        f"replaying {args.recording} ({span:.1f} s, {len(timeline.frames)} camera frames) at "
        f"{server.url} (read-only); Ctrl-C stops",
        flush=True,
    )
    try:
        while True:
            time.sleep(1.0)
    except KeyboardInterrupt:
        pass
    finally:
        server.stop()
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    from jetson.dashboard.report import write_report
    from jetson.errors import JetsonError

    try:
        info = write_report(args.recording, args.out)
    except ImportError as exc:
        raise RuntimeError(
            f"the report draws with matplotlib: pip install matplotlib ({exc})"
        ) from exc
    except (JetsonError, OSError) as exc:
        raise RuntimeError(str(exc)) from exc
    print(json.dumps({k: info[k] for k in ("cycles", "seconds", "driven_s", "latency_ms")}))
    print(f"wrote {info['files']['plots']} and {info['files']['summary']}")
    return 0
