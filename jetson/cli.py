"""`pete-jetson`: what runs on the robot's Jetson. Commands arrive with the parts they drive."""

from __future__ import annotations

import argparse
import sys

from jetson.dashboard.cli import HELP as DASHBOARD_HELP
from jetson.dashboard.cli import add_commands as add_dashboard_commands
from jetson.perception.cli import HELP as PERCEPTION_HELP
from jetson.perception.cli import add_commands as add_perception_commands
from jetson.service import HELP as DAEMON_HELP
from protocol.cli_conventions import make_parser

DESCRIPTION = (
    """\
The Jetson side of Pac-Man Pete: finds the V5 Brain, talks the wire protocol, sees rings, drives.

  pete-jetson ports        list V5 Brain serial ports (the user port is the one to talk on)
"""
    + DAEMON_HELP
    + DASHBOARD_HELP
    + PERCEPTION_HELP
)


def _cmd_ports(_: argparse.Namespace) -> int:
    from jetson.ports import list_v5_ports

    ports = list_v5_ports()
    if not ports:
        print("no V5 Brain found (USB VID 0x2888): is the Brain on and plugged into the Jetson?")
        return 1
    for p in ports:
        print(f"{p.device:<16} {p.kind:<8} {p.description}")
    return 0


def build_parser() -> argparse.ArgumentParser:
    parser = make_parser("pete-jetson", DESCRIPTION)
    sub = parser.add_subparsers(dest="command", required=True, metavar="COMMAND")
    p = sub.add_parser("ports", help="list V5 Brain serial ports, user port first")
    p.set_defaults(func=_cmd_ports)
    add_daemon_commands(sub)
    add_dashboard_commands(sub)
    add_perception_commands(sub)
    return parser


def add_daemon_commands(sub: argparse._SubParsersAction) -> None:
    """The daemon's commands (run, replay): registered by jetson.service, kept apart from the
    perception commands so that each part adds its own."""
    from jetson.service import add_commands

    add_commands(sub)


def main(argv: list[str] | None = None) -> int:
    args = build_parser().parse_args(argv)
    try:
        return args.func(args)
    except RuntimeError as exc:
        print(f"pete-jetson: error: {exc}", file=sys.stderr)
        return 2


if __name__ == "__main__":
    sys.exit(main())
